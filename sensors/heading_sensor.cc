#include "sensors/heading_sensor.h"

#include "sensors/attitude_estimator.h"
#include "sensors/gaussian.h"

namespace iapsim::sensors {

HeadingSensor::HeadingSensor(const HeadingSensorConfig& config, uint64_t seed)
    : config_(config), random_(seed) {}

double HeadingSensor::Measure(const Eigen::Quaterniond& q_WB) {
  return WrapToPi(RollPitchYaw_rad(q_WB).z() + config_.sigma_rad * StandardNormal(random_));
}

}  // namespace iapsim::sensors
