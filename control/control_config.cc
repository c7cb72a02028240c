#include "control/control_config.h"

#include <cmath>
#include <string>
#include <vector>

namespace iapsim::control {
namespace {

// Six non-negative numbers under `key` (the diagonal of a gain matrix), kept as they are when absent.
void OptionalDiagonal(bridge::YamlMap& map, const std::string& key, Vector6d* value) {
  if (!map.Has(key)) {
    map.SetResolved(key, YAML::Node(std::vector<double>(value->data(), value->data() + 6)));
    return;
  }
  const YAML::Node node = map.Raw(key);
  std::vector<double> numbers;
  if (!node.IsSequence() || node.size() != 6 || !YAML::convert<std::vector<double>>::decode(node, numbers)) {
    map.Fail(key, "expected 6 numbers [x, y, z, roll, pitch, yaw]");
  }
  for (double v : numbers) {
    if (!std::isfinite(v) || v < 0.0) map.Fail(key, "gains must be finite and non-negative");
  }
  *value = Eigen::Map<const Vector6d>(numbers.data());
  map.SetResolved(key, node);
}

}  // namespace

IapControllerConfig ReadControllerConfig(bridge::YamlMap& params) {
  IapControllerConfig config;
  params.OptionalInRange("gravity_mps2", &config.gravity_mps2, 0.0, 100.0);

  bridge::YamlMap gains = params.Map("gains");
  OptionalDiagonal(gains, "kp", &config.gains.kp);
  OptionalDiagonal(gains, "ki", &config.gains.ki);
  OptionalDiagonal(gains, "kd", &config.gains.kd);
  OptionalDiagonal(gains, "integral_limit", &config.gains.integral_limit);
  gains.Finish();

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

}  // namespace iapsim::control
