#pragma once
// The IAP controller's settings as a scenario gives them (the control process's params), so in-process users
// (tests, RL) read the same keys as the process.

#include "bridge/config.h"
#include "control/iap_controller.h"

namespace iapsim::control {

/// Reads gravity_mps2, gains {kp, ki, kd, integral_limit} (6 numbers each: x, y, z, roll, pitch, yaw;
/// defaults: Table II), limits {max_thrust_fraction, max_tilt_deg} and sub_aircraft_yaw (reference |
/// platform). Throws bridge::ConfigError naming the file, key and line.
IapControllerConfig ReadControllerConfig(bridge::YamlMap& params);

}  // namespace iapsim::control
