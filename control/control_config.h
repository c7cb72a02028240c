#pragma once
// The IAP controller's settings as a scenario gives them (the control process's params), so in-process users
// (tests, RL) read the same keys as the process.

#include "bridge/config.h"
#include "control/admittance.h"
#include "control/commanded_reference.h"
#include "control/iap_controller.h"
#include "control/wrench_control.h"

namespace iapsim::control {

/// Reads gravity_mps2, gains {kp, ki, kd, integral_limit} (6 numbers each: x, y, z, roll, pitch, yaw;
/// defaults: Table II) and gains.position_integral (platform, as (10): default | world), limits
/// {max_thrust_fraction, max_tilt_deg} and sub_aircraft_yaw (reference | platform). Throws
/// bridge::ConfigError naming the file, key and line.
IapControllerConfig ReadControllerConfig(bridge::YamlMap& params);

/// Reads the section `admittance: {mass, damping, stiffness (6 numbers each: x, y, z, roll, pitch, yaw;
/// defaults: Table IV), max_offset_m, max_offset_deg}` of `params` (empty or absent: the defaults).
AdmittanceConfig ReadAdmittanceConfig(bridge::YamlMap& params);

/// Reads the section `wrench_control: {gains: {kp, ki, kd, integral_limit} (defaults: Table V's motion
/// gains), wrench_gains: {kp, ki, kd, integral_limit, derivative_time_constant_s} (Table V), command_force_N,
/// command_torque_Nm (3 numbers each, the wrench the contact should apply to the platform, in P),
/// command_ramp_s, trigger:
/// {force_threshold_N, hold_s}}` of `params`. Throws bridge::ConfigError naming the file, key and line.
DirectWrenchConfig ReadDirectWrenchConfig(bridge::YamlMap& params);

/// Reads the section `shaping: {type: second_order (default) | none, ...}` of a `reference` (the keys of
/// the type: bandwidth_hz, max_velocity_mps, max_acceleration_mps2 (3 numbers each, x, y, z in W),
/// max_rate_dps, max_angular_acceleration_dps2 (roll, pitch, yaw); or velocity_time_constant_s for none).
/// Absent: the defaults. Throws bridge::ConfigError naming the file, key and line.
ReferenceShaping ReadReferenceShaping(bridge::YamlMap& reference);

}  // namespace iapsim::control
