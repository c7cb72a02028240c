#include "sensors/velocity_sensor.h"

#include "sensors/gaussian.h"

namespace iapsim::sensors {

VelocitySensor::VelocitySensor(const VelocitySensorConfig& config, uint64_t seed)
    : config_(config), random_(seed) {}

Eigen::Vector3d VelocitySensor::Measure(const Eigen::Vector3d& v_W_mps) {
  return v_W_mps + config_.sigma_mps * Gaussian3(random_);
}

}  // namespace iapsim::sensors
