#pragma once
// Sample messages shared by the bridge's unit tests.

#include <iapsim_msgs/IapState.h>

#include <string>

namespace iapsim::bridge::testing {

/// A four-body IAP state with values that exercise every formatter: a name that reads as a number,
/// fractions that need full precision, a fixed joint and a non-zero wrench.
inline iapsim_msgs::IapState MakeSampleState() {
  iapsim_msgs::IapState state;
  state.header.seq = 7;
  state.header.stamp = ros::Time(1, 5000000);
  state.header.frame_id = "W";
  state.step = 1005;
  state.bodies.resize(4);
  for (size_t i = 0; i < state.bodies.size(); ++i) {
    state.bodies[i].name = i == 0 ? "platform" : "sub" + std::to_string(i);
    state.bodies[i].pose_W.position.x = 0.48 * static_cast<double>(i);
    state.bodies[i].pose_W.position.y = 0.1 * static_cast<double>(i);
    state.bodies[i].pose_W.position.z = -1.0 / 3.0;
    state.bodies[i].pose_W.orientation.w = 1.0;
    state.bodies[i].twist_B.angular.z = -0.25;
  }
  state.bodies[1].name = "1.5";  // reads as a float unless quoted
  state.joints.resize(3);
  state.joints[2].type = iapsim_msgs::JointState::TYPE_FIXED;
  state.external_wrench_P.force.z = 19.62;
  return state;
}

}  // namespace iapsim::bridge::testing
