#pragma once
// What estimating the sub-aircraft of a run needs from its scenario, for `iapsim vio` over a bag and for
// the vio process alike: each stereo camera on a body (intrinsics, mount, topics), the IMU's mount and noise
// and the UWB anchors from the sensors process, the joints from the vehicle file; and the odometry each
// sub-aircraft shares with the others (seed Fig. 4), in one form for both.

#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bridge/scenario.h"
#include "render/camera_rig.h"
#include "sensors/imu.h"
#include "vio/config.h"
#include "vio/estimator.h"
#include "vio/stereo_rig.h"

namespace iapsim::vio {

struct SubAircraftSetup {
  std::string body;  ///< "iap/sub1"
  render::CameraConfig camera;
  StereoRig rig;
  Eigen::Isometry3d X_BI = Eigen::Isometry3d::Identity();
  sensors::ImuNoise imu_noise;
  std::string left_topic, right_topic, left_info_topic, imu_topic;
  std::string truth_topic;  ///< /<body>/odom: the first state ties the estimate to W (seed §VI-G)
  /// vio_uwb and virpo: the tag's ranges to the anchors (the tag is at the body's origin, sensors/uwb.h)
  std::string uwb_topic;
  std::map<std::string, Eigen::Vector3d> anchors_W;
  double range_sigma_m = 0.0;
  std::string attitude_topic;              ///< virpo: the flight controller's attitude, R_WB
  std::string odometry_topic;              ///< what the vio process publishes: /<body>/vio/odom
  std::string propagated_odometry_topic;   ///< and at the IMU's rate: /<body>/vio/imu_propagate
  std::optional<Eigen::Vector3d> joint_P;  ///< d_i, when the body is a sub-aircraft of the vehicle
};

struct RunSetup {
  std::string vehicle_name;
  std::vector<SubAircraftSetup> subs;
  std::vector<std::string> anchor_names;  ///< all of the scenario's UWB anchors, in its order
  /// The joints d_i in the order of `subs` and the platform's ground truth, when every sub-aircraft of the
  /// vehicle is estimated (the centre comes from all of them).
  std::vector<Eigen::Vector3d> joints_P;
  std::string platform_truth_topic;
  /// with joints_P, where the sensors process carries a platform_imu: its attitude EKF's estimate, whose tilt
  /// and rate the platform's estimate takes (PlatformOdometryOf), and that process
  std::string platform_attitude_topic, platform_attitude_process;
};

/// The sub-aircraft of `scenario` with a body-mounted stereo camera (those of `bodies` only, when given) for
/// `mode` (vio, vio_uwb, virpo). Throws bridge::ConfigError naming the scenario and what is missing.
RunSetup ReadRunSetup(const bridge::Scenario& scenario, const std::string& mode, const VioConfig& config,
                      const std::vector<std::string>& bodies);

/// The options of sub-aircraft i's estimator: the user's, with its IMU's noise, the tag and joint at its
/// body's origin and, for virpo, the link to every other sub-aircraft of `setup` in order.
EstimatorOptions EstimatorOptionsFor(const RunSetup& setup, std::size_t i, const std::string& mode,
                                     const VioConfig& config);

/// The odometry a sub-aircraft shares: its body's pose in W and twist in B (ROS), stamped t_ns.
nav_msgs::Odometry OdometryOf(const Estimate& estimate, const SubAircraftSetup& sub, int64_t t_ns);
/// The platform's own attitude estimate: an IMU on it and its EKF (the sensors process's platform_imu).
struct PlatformAttitude {
  Eigen::Quaterniond q_WP = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_P_radps = Eigen::Vector3d::Zero();  ///< bias-corrected
};
/// By stamp, as the sensors process publishes them (sensor_msgs/Imu on RunSetup::platform_attitude_topic).
using PlatformAttitudes = std::map<int64_t, PlatformAttitude>;
PlatformAttitude PlatformAttitudeOf(const sensor_msgs::Imu& attitude);
/// The newest at or before t_ns (the sensors process samples at every IMU step, which every stamp of the
/// sub-aircraft's estimates is); nullptr when there is none.
const PlatformAttitude* PlatformAttitudeAt(const PlatformAttitudes& attitudes, int64_t t_ns);

/// The platform's odometry from every sub-aircraft's at one stamp (`subs` in the order of `joints_P`, the
/// joints d_i in P): the pose is the rigid transform that best carries the joints onto the estimated ones
/// (UmeyamaRigid; a sub-aircraft's origin is its joint), the twist the rigid-body velocity that best
/// explains theirs (v_i = v_P + ω × R_WP d_i, least squares), in P. Frame ids `vehicle`/platform in W.
///
/// With `attitude`, the roll and pitch are the platform's own estimate's and the rate its gyroscope's; the
/// yaw stays the fit's, and the position and velocity are refitted with that attitude and rate (the mean
/// of J_i − R_WP d_i and of v_i − ω × R_WP d_i). Gravity makes the tilt observable to both, so the two agree
/// on it up to their errors, which for the fit are the sub-aircraft's height drifts over the joints' spacing;
/// the yaw of a gyroscope-propagated EKF drifts in its own way, and the positions would not share it.
nav_msgs::Odometry PlatformOdometryOf(const std::vector<Eigen::Vector3d>& joints_P,
                                      const std::vector<nav_msgs::Odometry>& subs, const std::string& vehicle,
                                      const PlatformAttitude* attitude = nullptr);

/// The IMU's state in a body's odometry (the ground truth that starts an estimate).
NavState ImuStateOf(const nav_msgs::Odometry& odometry, const Eigen::Isometry3d& X_BI);
/// The joint (the body's origin, seed §III-A) in another sub-aircraft's shared odometry.
PeerJoint PeerJointOf(const nav_msgs::Odometry& odometry);

}  // namespace iapsim::vio
