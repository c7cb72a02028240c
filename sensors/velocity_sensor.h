#pragma once
// A velocity measurement, what a flight controller fuses from an external odometry (PX4's EKF2 external
// vision velocity; the seed's flight controllers take VIO positioning at 200 Hz, §VI): the true velocity
// of the IMU in W plus white Gaussian noise per axis, without delay. It lets the attitude EKF tell the
// vehicle's acceleration from its tilt (AttitudeEstimatorConfig::velocity_aided).

#include <Eigen/Core>
#include <cstdint>
#include <random>

namespace iapsim::sensors {

struct VelocitySensorConfig {
  double sigma_mps = 0.1;  ///< PX4's EKF2_EVV_NOISE default (src/modules/ekf2/params_external_vision.yaml)
  double rate_hz = 20.0;   ///< for the caller's schedule
};

class VelocitySensor {
 public:
  VelocitySensor(const VelocitySensorConfig& config, uint64_t seed);

  /// v_W_mps plus noise, drawn x, y, z.
  Eigen::Vector3d Measure(const Eigen::Vector3d& v_W_mps);
  const VelocitySensorConfig& config() const { return config_; }

 private:
  VelocitySensorConfig config_;
  std::mt19937_64 random_;
};

}  // namespace iapsim::sensors
