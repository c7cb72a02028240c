#pragma once
// The frames of a vehicle for ROS's /tf and /tf_static, named and arranged as `iapsim urdf --ros` writes the
// vehicle (model/urdf.h, GenerateRosUrdf) with the vehicle's name as tf prefix, so rviz shows that URDF on
// them. The scheme (README, ROS):
//   world (ENU, REP-103) -> W (the seed's world, NED)                                   static
//   W -> V/base_link (the platform's pose; every body frame is FRD, as in the seed)      from the state
//   V/base_link -> V/platform (the URDF's fixed joint) -> V/P (the name odometry and wrench messages use)
//                                                                                       static
//   V/platform -> V/SUB_roll_link -> V/SUB_pitch_link -> V/SUB for a spherical joint:   from the state
//     R_PS = Rz(initial yaw) Rx(roll) Ry(pitch) Rz(yaw), the URDF's three joints
//   V/platform -> V/SUB (fixed joint), V/platform -> V/TOOL                              static

#include <iapsim_msgs/IapState.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "model/vehicle.h"

namespace iapsim::rosbridge {

struct FrameTransform {
  std::string parent, child;
  Eigen::Vector3d p_parent_child_m = Eigen::Vector3d::Zero();  // child's origin in the parent frame
  Eigen::Quaterniond q_parent_child = Eigen::Quaterniond::Identity();
};

/// world (ENU, x east, y north, z up) -> W (NED).
FrameTransform WorldToNed();

class VehicleTf {
 public:
  /// `name`: the vehicle's name in the run (its topics' and frames' prefix).
  VehicleTf(const model::Vehicle& vehicle, const std::string& name);

  const std::vector<FrameTransform>& fixed() const { return fixed_; }
  /// The moving frames at a state of this vehicle. Throws std::invalid_argument when the state does not
  /// have this vehicle's bodies and joints.
  const std::vector<FrameTransform>& Moving(const iapsim_msgs::IapState& state);

 private:
  std::string name_;
  std::vector<FrameTransform> fixed_;
  struct Joint {
    size_t index;  // of the sub-aircraft in the state's joints (bodies: index + 1)
    std::string sub;
    Eigen::Vector3d p_PJ_m;
    Eigen::Quaterniond q_PJ;  // the joint frame: the sub-aircraft's initial yaw about z of P
  };
  std::vector<Joint> spherical_;
  size_t sub_aircraft_ = 0;
  std::vector<FrameTransform> moving_;
};

/// Roll, pitch and yaw with R = Rx(roll) Ry(pitch) Rz(yaw) (pitch in [-pi/2, pi/2]).
Eigen::Vector3d RollPitchYawXyz(const Eigen::Matrix3d& R);

}  // namespace iapsim::rosbridge
