#include "rosbridge/vehicle_tf.h"

#include <gtest/gtest.h>

#include <map>
#include <random>

#include "bridge/eigen_msgs.h"

namespace iapsim::rosbridge {
namespace {

Eigen::Isometry3d ToIsometry(const FrameTransform& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = t.q_parent_child.toRotationMatrix();
  T.translation() = t.p_parent_child_m;
  return T;
}

// a frame's pose in `root`, composed along the parents of the transforms given
Eigen::Isometry3d PoseIn(const std::string& root, const std::string& frame,
                         const std::vector<FrameTransform>& transforms) {
  std::map<std::string, const FrameTransform*> by_child;
  for (const FrameTransform& t : transforms) by_child[t.child] = &t;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (std::string f = frame; f != root;) {
    const auto it = by_child.find(f);
    if (it == by_child.end()) throw std::runtime_error("no parent for " + f);
    T = ToIsometry(*it->second) * T;
    f = it->second->parent;
  }
  return T;
}

TEST(VehicleTf, WorldIsEnuAndWIsNed) {
  const FrameTransform t = WorldToNed();
  EXPECT_EQ(t.parent, "world");
  EXPECT_EQ(t.child, "W");
  EXPECT_TRUE((t.q_parent_child * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY()));   // north
  EXPECT_TRUE((t.q_parent_child * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d::UnitX()));   // east
  EXPECT_TRUE((t.q_parent_child * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitZ()));  // down
}

TEST(VehicleTf, RollPitchYawComposeBackToTheRotation) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), pitch(-1.5, 1.5);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d rpy(angle(random), pitch(random), angle(random));
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    EXPECT_TRUE(RollPitchYawXyz(R).isApprox(rpy, 1e-9)) << rpy.transpose();
  }
}

// The frames place every body where the state has it: the platform, and each sub-aircraft through its three
// joint frames, as the --ros URDF's chain does.
TEST(VehicleTf, TheJointChainPutsEachSubAircraftWhereTheStateHasIt) {
  const model::Vehicle vehicle = model::LoadVehicle(IAPSIM_SOURCE_DIR "/configs/vehicles/three_star.yaml");
  VehicleTf tf(vehicle, "iap");
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto rotation = [&] {
    return Eigen::Quaterniond(
        Eigen::Vector4d(unit(random), unit(random), unit(random), unit(random)).normalized());
  };
  for (int trial = 0; trial < 100; ++trial) {
    iapsim_msgs::IapState state;
    const Eigen::Quaterniond q_WP = rotation();
    const Eigen::Vector3d p_WP(unit(random), unit(random), -2.0 + unit(random));
    state.bodies.resize(vehicle.sub_aircraft.size() + 1);
    state.joints.resize(vehicle.sub_aircraft.size());
    state.bodies[0].pose_W.position = bridge::ToPointMsg(p_WP);
    state.bodies[0].pose_W.orientation = bridge::ToQuaternionMsg(q_WP);
    std::vector<Eigen::Isometry3d> T_WS;
    for (size_t s = 0; s < vehicle.sub_aircraft.size(); ++s) {
      const Eigen::Quaterniond q_PS = rotation();
      state.joints[s].orientation_PS = bridge::ToQuaternionMsg(q_PS);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = (q_WP * q_PS).toRotationMatrix();
      T.translation() = p_WP + q_WP * vehicle.sub_aircraft[s].joint_P_m;
      T_WS.push_back(T);
    }
    std::vector<FrameTransform> all = tf.fixed();
    const std::vector<FrameTransform>& moving = tf.Moving(state);
    all.insert(all.end(), moving.begin(), moving.end());
    const Eigen::Isometry3d T_WP = PoseIn("W", "iap/P", all);
    EXPECT_TRUE(T_WP.translation().isApprox(p_WP, 1e-12));
    EXPECT_TRUE(T_WP.linear().isApprox(q_WP.toRotationMatrix(), 1e-12));
    for (size_t s = 0; s < vehicle.sub_aircraft.size(); ++s) {
      const Eigen::Isometry3d T = PoseIn("W", "iap/" + vehicle.sub_aircraft[s].name, all);
      EXPECT_TRUE(T.translation().isApprox(T_WS[s].translation(), 1e-12)) << s;
      EXPECT_TRUE(T.linear().isApprox(T_WS[s].linear(), 1e-12)) << s;
    }
  }
}

TEST(VehicleTf, AStateOfAnotherVehicleIsRefused) {
  const model::Vehicle vehicle = model::LoadVehicle(IAPSIM_SOURCE_DIR "/configs/vehicles/three_star.yaml");
  VehicleTf tf(vehicle, "iap");
  iapsim_msgs::IapState state;
  state.bodies.resize(2);
  state.joints.resize(1);
  EXPECT_THROW(tf.Moving(state), std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::rosbridge
