#include "rosbridge/vehicle_tf.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "bridge/eigen_msgs.h"

namespace iapsim::rosbridge {
namespace {

Eigen::Quaterniond AboutAxis(double angle_rad, const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, axis));
}

}  // namespace

FrameTransform WorldToNed() {
  // NED's axes in ENU: north = +y, east = +x, down = -z (a half turn about (x + y)/sqrt(2))
  Eigen::Matrix3d R_ENU_NED;
  R_ENU_NED << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return {"world", "W", Eigen::Vector3d::Zero(), Eigen::Quaterniond(R_ENU_NED)};
}

Eigen::Vector3d RollPitchYawXyz(const Eigen::Matrix3d& R) {
  // R = Rx(r) Ry(p) Rz(y): R(0,2) = sin p, R(1,2) = -sin r cos p, R(2,2) = cos r cos p,
  // R(0,1) = -cos p sin y, R(0,0) = cos p cos y
  const double pitch = std::asin(std::clamp(R(0, 2), -1.0, 1.0));
  return {std::atan2(-R(1, 2), R(2, 2)), pitch, std::atan2(-R(0, 1), R(0, 0))};
}

VehicleTf::VehicleTf(const model::Vehicle& vehicle, const std::string& name)
    : name_(name), sub_aircraft_(vehicle.sub_aircraft.size()) {
  const std::string prefix = name + "/";
  fixed_.push_back({prefix + "base_link", prefix + "platform"});
  fixed_.push_back({prefix + "platform", prefix + "P"});
  for (const model::Tool& tool : vehicle.tools) {
    fixed_.push_back({prefix + "platform", prefix + tool.name, tool.origin_P_m,
                      Eigen::Quaterniond(model::RotationFromRpy(tool.rpy_P_rad))});
  }
  for (size_t s = 0; s < vehicle.sub_aircraft.size(); ++s) {
    const model::SubAircraft& sub = vehicle.sub_aircraft[s];
    const Eigen::Quaterniond q_PJ = AboutAxis(sub.initial_yaw_rad, Eigen::Vector3d::UnitZ());
    if (sub.joint == model::JointType::kSpherical) {
      spherical_.push_back({s, sub.name, sub.joint_P_m, q_PJ});
    } else {
      fixed_.push_back({prefix + "platform", prefix + sub.name, sub.joint_P_m, q_PJ});
    }
  }
  moving_.resize(1 + 3 * spherical_.size());
  moving_[0] = {"W", prefix + "base_link"};
  for (size_t j = 0; j < spherical_.size(); ++j) {
    const std::string sub = prefix + spherical_[j].sub;
    moving_[1 + 3 * j] = {prefix + "platform", sub + "_roll_link", spherical_[j].p_PJ_m};
    moving_[2 + 3 * j] = {sub + "_roll_link", sub + "_pitch_link"};
    moving_[3 + 3 * j] = {sub + "_pitch_link", sub};
  }
}

const std::vector<FrameTransform>& VehicleTf::Moving(const iapsim_msgs::IapState& state) {
  if (state.bodies.size() != sub_aircraft_ + 1 || state.joints.size() != sub_aircraft_) {
    throw std::invalid_argument("a state of " + std::to_string(state.bodies.size()) + " bodies and " +
                                std::to_string(state.joints.size()) + " joints for vehicle '" + name_ +
                                "' of " + std::to_string(sub_aircraft_) + " sub-aircraft");
  }
  moving_[0].p_parent_child_m = bridge::FromMsg(state.bodies[0].pose_W.position);
  moving_[0].q_parent_child = bridge::FromMsg(state.bodies[0].pose_W.orientation).normalized();
  for (size_t j = 0; j < spherical_.size(); ++j) {
    const Joint& joint = spherical_[j];
    const Eigen::Quaterniond q_PS = bridge::FromMsg(state.joints[joint.index].orientation_PS).normalized();
    const Eigen::Vector3d angles_rad = RollPitchYawXyz((joint.q_PJ.conjugate() * q_PS).toRotationMatrix());
    moving_[1 + 3 * j].q_parent_child = joint.q_PJ * AboutAxis(angles_rad.x(), Eigen::Vector3d::UnitX());
    moving_[2 + 3 * j].q_parent_child = AboutAxis(angles_rad.y(), Eigen::Vector3d::UnitY());
    moving_[3 + 3 * j].q_parent_child = AboutAxis(angles_rad.z(), Eigen::Vector3d::UnitZ());
  }
  return moving_;
}

}  // namespace iapsim::rosbridge
