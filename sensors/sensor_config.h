#pragma once
// The sensors' settings as a scenario gives them (the sensors process's params), so in-process users (tests,
// RL) read the same keys as the process. Keys and units: sensors/README.md.

#include <optional>
#include <string>
#include <vector>

#include "bridge/config.h"
#include "sensors/attitude_estimator.h"
#include "sensors/heading_sensor.h"
#include "sensors/imu.h"
#include "sensors/odometry.h"
#include "sensors/uwb.h"
#include "sensors/velocity_sensor.h"
#include "sensors/wrench_filter.h"

namespace iapsim::sensors {

struct SensorsConfig {
  ImuConfig imu;
  UwbConfig uwb;
  WrenchFilterConfig wrench_filter;
  AttitudeEstimatorConfig attitude_estimator;  ///< assumes the IMU's noise, mounting and gravity by default
  std::optional<HeadingSensorConfig> heading;  ///< absent: no heading measurement, yaw is not aided
  /// present: the EKF is velocity-aided (attitude_estimator.velocity_aided); absent: gravity-referenced
  std::optional<VelocitySensorConfig> velocity;
  std::optional<OdometryConfig> odometry;  ///< absent: no platform odometry is published
  /// present: the platform carries this IMU and an attitude EKF of its own (the IAP computer's), with
  /// platform_attitude_estimator's settings: attitude_estimator's, assuming this IMU's noise and mounting
  std::optional<ImuConfig> platform_imu;
  std::optional<AttitudeEstimatorConfig> platform_attitude_estimator;
};

/// Reads gravity_mps2 and the optional sections imu, uwb, wrench_filter, attitude_estimator, heading,
/// velocity, odometry and platform_imu of `params`; the caller reads its other keys and calls
/// params.Finish(). A uwb anchors_file is relative to the file of `params`. Throws bridge::ConfigError naming
/// the file, line and key.
SensorsConfig ReadSensorsConfig(bridge::YamlMap& params);

/// An anchors file: `anchors: [{name, position_m: [x, y, z]}, ...]` in W (configs/sensors/*.yaml).
std::vector<UwbAnchor> LoadUwbAnchors(const std::string& path);

}  // namespace iapsim::sensors
