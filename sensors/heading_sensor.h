#pragma once
// A heading (yaw) measurement, what a flight controller gets from its magnetometer: the true yaw plus
// Gaussian noise. It lets the attitude EKF observe yaw, which gravity alone leaves free.

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <random>

namespace iapsim::sensors {

struct HeadingSensorConfig {
  double sigma_rad = 2.0 * M_PI / 180.0;
  double rate_hz = 10.0;  ///< for the caller's schedule
};

class HeadingSensor {
 public:
  HeadingSensor(const HeadingSensorConfig& config, uint64_t seed);

  /// The yaw of q_WB (Z-Y-X Euler angles, rad) plus noise, in (−π, π].
  double Measure(const Eigen::Quaterniond& q_WB);
  const HeadingSensorConfig& config() const { return config_; }

 private:
  HeadingSensorConfig config_;
  std::mt19937_64 random_;
};

}  // namespace iapsim::sensors
