#pragma once
// The estimator's state of one sub-aircraft's IMU: pose and velocity in the estimator's world frame (NED,
// gravity +z) and the two biases, and the standard deviations of a prior on them.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace iapsim::vio {

struct ImuBiases {
  Eigen::Vector3d gyroscope_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d accelerometer_mps2 = Eigen::Vector3d::Zero();
};

/// The IMU's pose and velocity in W at one instant.
struct NavState {
  Eigen::Vector3d p_WI_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_WI = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_WI_W_mps = Eigen::Vector3d::Zero();
};

/// Another sub-aircraft's spherical joint as it shares it (seed Fig. 4: each sub-aircraft shares its
/// odometry): position and velocity in its own estimate of W.
struct PeerJoint {
  Eigen::Vector3d p_WJ_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_WJ_W_mps = Eigen::Vector3d::Zero();
};

/// Standard deviations of a prior on one state (the window's first, before anything was marginalised). The
/// rotation's are about W's axes: z is the yaw, x and y the tilt.
struct StatePriorSigmas {
  double position_m = 1e-3;
  double tilt_rad = 1e-3;
  double yaw_rad = 1e-3;
  double velocity_mps = 0.05;
  double gyroscope_bias_radps = 0.01;
  double accelerometer_bias_mps2 = 0.1;
};

}  // namespace iapsim::vio
