#include "control/control_config.h"

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace iapsim::control {
namespace {

// N finite numbers under `key`, kept as they are when absent.
template <int N>
void OptionalNumbers(bridge::YamlMap& map, const std::string& key, Eigen::Matrix<double, N, 1>* value,
                     const std::string& expected, bool non_negative) {
  if (!map.Has(key)) {
    map.SetResolved(key, YAML::Node(std::vector<double>(value->data(), value->data() + N)));
    return;
  }
  const std::vector<double> numbers = bridge::ReadNumberList(map, key, {static_cast<size_t>(N)});
  for (double v : numbers) {
    if (non_negative && v < 0.0) map.Fail(key, "expected " + expected);
  }
  *value = Eigen::Map<const Eigen::Matrix<double, N, 1>>(numbers.data());
}

// Six non-negative numbers under `key` (the diagonal of a gain matrix), kept as they are when absent.
void OptionalDiagonal(bridge::YamlMap& map, const std::string& key, Vector6d* value) {
  OptionalNumbers<6>(map, key, value, "6 non-negative numbers [x, y, z, roll, pitch, yaw]", true);
}

// gains {kp, ki, kd, integral_limit, position_integral: platform | world} of the tracker
void ReadTrackerGains(bridge::YamlMap& params, TrackerGains* gains) {
  bridge::YamlMap map = params.Map("gains");
  OptionalDiagonal(map, "kp", &gains->kp);
  OptionalDiagonal(map, "ki", &gains->ki);
  OptionalDiagonal(map, "kd", &gains->kd);
  OptionalDiagonal(map, "integral_limit", &gains->integral_limit);
  std::string frame = gains->position_integral_frame == PositionIntegralFrame::kWorld ? "world" : "platform";
  map.OptionalChoice("position_integral", &frame, {"platform", "world"});
  gains->position_integral_frame =
      frame == "world" ? PositionIntegralFrame::kWorld : PositionIntegralFrame::kPlatform;
  map.Finish();
}

// Three positive numbers under `key`, kept as they are when absent; `scale` converts what the file says
// (degrees) to what the config holds (radians).
void OptionalPositive3(bridge::YamlMap& map, const std::string& key, Eigen::Vector3d* value,
                       const std::string& axes, double scale = 1.0) {
  Eigen::Vector3d in_file = *value / scale;
  OptionalNumbers<3>(map, key, &in_file, "3 positive numbers " + axes, true);
  if (!(in_file.array() > 0.0).all()) map.Fail(key, "expected 3 positive numbers " + axes);
  *value = in_file * scale;
}

}  // namespace

ReferenceShaping ReadReferenceShaping(bridge::YamlMap& reference) {
  ReferenceShaping shaping;
  bridge::YamlMap map = reference.Map("shaping");
  std::string type = "second_order";
  map.OptionalChoice("type", &type, {"second_order", "none"});
  if (type == "none") {
    shaping.type = ReferenceShaping::Type::kNone;
    map.OptionalInRange("velocity_time_constant_s", &shaping.velocity_time_constant_s, 0.0, 10.0);
  } else {
    ReferenceShaperConfig& config = shaping.second_order;
    map.OptionalInRange("bandwidth_hz", &config.bandwidth_hz, 0.01, 20.0);
    OptionalPositive3(map, "max_velocity_mps", &config.max_velocity_mps, "[x, y, z] in W");
    OptionalPositive3(map, "max_acceleration_mps2", &config.max_acceleration_mps2, "[x, y, z] in W");
    constexpr double kDeg = M_PI / 180.0;
    OptionalPositive3(map, "max_rate_dps", &config.max_rate_radps, "[roll, pitch, yaw]", kDeg);
    OptionalPositive3(map, "max_angular_acceleration_dps2", &config.max_angular_acceleration_radps2,
                      "[roll, pitch, yaw]", kDeg);
  }
  map.Finish();
  return shaping;
}

IapControllerConfig ReadControllerConfig(bridge::YamlMap& params) {
  IapControllerConfig config;
  params.OptionalInRange("gravity_mps2", &config.gravity_mps2, 0.0, 100.0);

  ReadTrackerGains(params, &config.gains);

  bridge::YamlMap limits = params.Map("limits");
  limits.OptionalInRange("max_thrust_fraction", &config.max_thrust_fraction, 0.1, 1.0);
  double max_tilt_deg = config.max_tilt_rad * 180.0 / M_PI;
  limits.OptionalInRange("max_tilt_deg", &max_tilt_deg, 1.0, 89.0);
  config.max_tilt_rad = max_tilt_deg * M_PI / 180.0;
  limits.Finish();

  std::string yaw = "reference";
  params.OptionalChoice("sub_aircraft_yaw", &yaw, {"reference", "platform"});
  config.sub_aircraft_yaw = yaw == "reference" ? SubAircraftYaw::kReference : SubAircraftYaw::kPlatform;
  return config;
}

AdmittanceConfig ReadAdmittanceConfig(bridge::YamlMap& params) {
  AdmittanceConfig config;
  bridge::YamlMap map = params.Map("admittance");
  OptionalDiagonal(map, "mass", &config.mass);
  if (!(config.mass.array() > 0.0).all()) map.Fail("mass", "must be positive");
  OptionalDiagonal(map, "damping", &config.damping);
  OptionalDiagonal(map, "stiffness", &config.stiffness);
  map.OptionalInRange("max_offset_m", &config.max_offset_m, 0.0, 10.0);
  double max_offset_deg = config.max_offset_rad * 180.0 / M_PI;
  map.OptionalInRange("max_offset_deg", &max_offset_deg, 0.0, 90.0);
  config.max_offset_rad = max_offset_deg * M_PI / 180.0;
  map.Finish();
  return config;
}

DirectWrenchConfig ReadDirectWrenchConfig(bridge::YamlMap& params) {
  DirectWrenchConfig config;
  bridge::YamlMap map = params.Map("wrench_control");
  ReadTrackerGains(map, &config.gains);

  bridge::YamlMap wrench_gains = map.Map("wrench_gains");
  OptionalDiagonal(wrench_gains, "kp", &config.wrench_gains.kp);
  OptionalDiagonal(wrench_gains, "ki", &config.wrench_gains.ki);
  OptionalDiagonal(wrench_gains, "kd", &config.wrench_gains.kd);
  OptionalDiagonal(wrench_gains, "integral_limit", &config.wrench_gains.integral_limit);
  wrench_gains.OptionalInRange("derivative_time_constant_s", &config.wrench_gains.derivative_time_constant_s,
                               1e-4, 10.0);
  wrench_gains.Finish();

  Eigen::Vector3d force_N = config.command_wrench_P.head<3>(), torque_Nm = config.command_wrench_P.tail<3>();
  OptionalNumbers<3>(map, "command_force_N", &force_N, "3 numbers [x, y, z] in the platform frame", false);
  OptionalNumbers<3>(map, "command_torque_Nm", &torque_Nm, "3 numbers [x, y, z] in the platform frame",
                     false);
  config.command_wrench_P << force_N, torque_Nm;
  map.OptionalInRange("command_ramp_s", &config.command_ramp_s, 0.0, 600.0);

  bridge::YamlMap trigger = map.Map("trigger");
  trigger.OptionalInRange("force_threshold_N", &config.trigger.force_threshold_N, 0.0, 1000.0);
  trigger.OptionalInRange("hold_s", &config.trigger.hold_s, 0.0, 60.0);
  trigger.OptionalInRange("release_threshold_N", &config.trigger.release_threshold_N, 0.0, 1000.0);
  trigger.OptionalInRange("release_hold_s", &config.trigger.release_hold_s, 0.0, 60.0);
  if (config.trigger.release_threshold_N > 0.0 &&
      config.trigger.release_threshold_N >= config.trigger.force_threshold_N) {
    std::ostringstream what;
    what << "must be below force_threshold_N (" << config.trigger.force_threshold_N
         << " N) or 0 (never release), got " << config.trigger.release_threshold_N;
    trigger.Fail("release_threshold_N", what.str());
  }
  trigger.Finish();
  map.Finish();
  return config;
}

}  // namespace iapsim::control
