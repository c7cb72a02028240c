#include "sensors/sensor_config.h"

#include <cmath>
#include <set>

#include "model/vehicle.h"

namespace iapsim::sensors {
namespace {

using bridge::YamlMap;

constexpr double kDegToRad = M_PI / 180.0;
constexpr double kMaxRate_hz = 1e6;

// table_vi: true (the default when no density is given) or the four Kalibr densities (absent ones are 0)
ImuNoise ReadImuNoise(YamlMap& map) {
  const std::vector<std::string> density_keys = {"gyroscope_noise_density", "gyroscope_random_walk",
                                                 "accelerometer_noise_density", "accelerometer_random_walk"};
  bool any_density = false;
  for (const auto& key : density_keys) any_density = any_density || map.Has(key);
  bool table_vi = !any_density;
  map.Optional("table_vi", &table_vi);
  if (table_vi) {
    if (any_density) map.Fail("table_vi", "true sets the noise densities: remove it or the density keys");
    return TableViNoise();
  }
  ImuNoise noise;
  map.OptionalInRange(density_keys[0], &noise.gyroscope_noise_density, 0.0, 10.0);
  map.OptionalInRange(density_keys[1], &noise.gyroscope_random_walk, 0.0, 10.0);
  map.OptionalInRange(density_keys[2], &noise.accelerometer_noise_density, 0.0, 100.0);
  map.OptionalInRange(density_keys[3], &noise.accelerometer_random_walk, 0.0, 100.0);
  return noise;
}

ImuConfig ReadImu(YamlMap& map, double gravity_mps2) {
  ImuConfig imu;
  imu.gravity_mps2 = gravity_mps2;
  imu.noise = ReadImuNoise(map);
  map.OptionalInRange("rate_hz", &imu.rate_hz, 1e-3, kMaxRate_hz);
  YamlMap mounting = map.Map("mounting");
  model::OptionalVector3(mounting, "position_m", &imu.p_BI_m);
  Eigen::Vector3d rpy_rad = Eigen::Vector3d::Zero();
  model::OptionalVector3(mounting, "rpy_deg", &rpy_rad, kDegToRad);
  imu.q_BI = Eigen::Quaterniond(model::RotationFromRpy(rpy_rad));
  mounting.Finish();
  model::OptionalVector3(map, "initial_gyroscope_bias_radps", &imu.initial_gyroscope_bias_radps);
  map.OptionalInRange("initial_gyroscope_bias_sigma_radps", &imu.initial_gyroscope_bias_sigma_radps, 0.0,
                      10.0);
  model::OptionalVector3(map, "initial_accelerometer_bias_mps2", &imu.initial_accelerometer_bias_mps2);
  map.OptionalInRange("initial_accelerometer_bias_sigma_mps2", &imu.initial_accelerometer_bias_sigma_mps2,
                      0.0, 100.0);
  map.Optional("seed_offset", &imu.seed_offset);
  map.Finish();
  return imu;
}

std::vector<UwbAnchor> ReadAnchorList(YamlMap& map, const std::string& key) {
  const YAML::Node list = map.Raw(key);
  if (!list.IsSequence()) map.Fail(key, "expected a list of {name, position_m}");
  std::vector<UwbAnchor> anchors;
  std::set<std::string> names;
  for (size_t i = 0; i < list.size(); ++i) {
    YamlMap entry(list[i], map.file(), map.PathOf(key) + "[" + std::to_string(i) + "]");
    UwbAnchor anchor;
    entry.Required("name", &anchor.name);
    if (!names.insert(anchor.name).second) entry.Fail("name", "'" + anchor.name + "' is used twice");
    if (!entry.Has("position_m")) entry.Fail("position_m", "is required");
    model::OptionalVector3(entry, "position_m", &anchor.p_WA_m);
    entry.Finish();
    anchors.push_back(anchor);
  }
  return anchors;
}

UwbConfig ReadUwb(YamlMap& map) {
  UwbConfig uwb;
  if (map.Has("anchors") && map.Has("anchors_file")) {
    map.Fail("anchors_file", "give either anchors or anchors_file, not both");
  }
  if (map.Has("anchors")) uwb.anchors = ReadAnchorList(map, "anchors");
  if (map.Has("anchors_file"))
    uwb.anchors = LoadUwbAnchors(bridge::ReadFilePath(map, "anchors_file", map.file()));
  UwbNoise& noise = uwb.noise;
  map.OptionalInRange("sigma_m", &noise.sigma_m, 0.0, 100.0);
  map.OptionalInRange("outlier_probability", &noise.outlier_probability, 0.0, 1.0);
  map.OptionalInRange("outlier_magnitude_m", &noise.outlier_magnitude_m, 0.0, 1e4);
  map.OptionalInRange("nlos_probability", &noise.nlos_probability, 0.0, 1.0);
  map.OptionalInRange("nlos_bias_m", &noise.nlos_bias_m, 0.0, 1e4);
  map.OptionalInRange("dropout_probability", &noise.dropout_probability, 0.0, 1.0);
  map.OptionalInRange("rate_hz", &uwb.rate_hz, 1e-3, kMaxRate_hz);
  map.Optional("tag_to_tag", &uwb.tag_to_tag);
  map.Finish();
  return uwb;
}

WrenchFilterConfig ReadWrenchFilter(YamlMap& map) {
  WrenchFilterConfig filter;
  map.OptionalInRange("cutoff_rad_s", &filter.cutoff_rad_s, 1e-6, 1e6);
  map.OptionalInRange("damping", &filter.damping, 1e-6, 100.0);
  map.Finish();
  return filter;
}

// an angle kept in radians in the struct and read in degrees
void OptionalDegrees(YamlMap& map, const std::string& key, double* value_rad, double max_deg) {
  double value_deg = *value_rad / kDegToRad;
  map.OptionalInRange(key, &value_deg, 0.0, max_deg);
  *value_rad = value_deg * kDegToRad;
}

AttitudeEstimatorConfig ReadAttitudeEstimator(YamlMap& map, const ImuConfig& imu) {
  AttitudeEstimatorConfig estimator;
  estimator.imu_noise = imu.noise;
  estimator.q_BI = imu.q_BI;
  estimator.gravity_mps2 = imu.gravity_mps2;
  if (map.Has("imu_noise")) {
    YamlMap noise = map.Map("imu_noise");
    estimator.imu_noise = ReadImuNoise(noise);
    noise.Finish();
  }
  OptionalDegrees(map, "initial_tilt_sigma_deg", &estimator.initial_tilt_sigma_rad, 90.0);
  OptionalDegrees(map, "initial_yaw_sigma_deg", &estimator.initial_yaw_sigma_rad, 180.0);
  map.OptionalInRange("initial_gyroscope_bias_sigma_radps", &estimator.initial_gyroscope_bias_sigma_radps,
                      0.0, 10.0);
  map.OptionalInRange("initial_accelerometer_bias_sigma_mps2",
                      &estimator.initial_accelerometer_bias_sigma_mps2, 0.0, 100.0);
  map.OptionalInRange("acceleration_sigma_mps2", &estimator.acceleration_sigma_mps2, 0.0, 100.0);
  map.OptionalInRange("acceleration_correlation_s", &estimator.acceleration_correlation_s, 0.0, 1e4);
  map.OptionalInRange("acceleration_gate_mps2", &estimator.acceleration_gate_mps2, 0.0, 100.0);
  map.OptionalInRange("initial_velocity_sigma_mps", &estimator.initial_velocity_sigma_mps, 0.0, 100.0);
  map.Finish();
  return estimator;
}

HeadingSensorConfig ReadHeading(YamlMap& map) {
  HeadingSensorConfig heading;
  OptionalDegrees(map, "sigma_deg", &heading.sigma_rad, 180.0);
  if (!(heading.sigma_rad > 0.0)) map.Fail("sigma_deg", "must be positive");
  map.OptionalInRange("rate_hz", &heading.rate_hz, 1e-3, kMaxRate_hz);
  map.Finish();
  return heading;
}

VelocitySensorConfig ReadVelocity(YamlMap& map) {
  VelocitySensorConfig velocity;
  map.OptionalInRange("sigma_mps", &velocity.sigma_mps, 0.0, 100.0);
  if (!(velocity.sigma_mps > 0.0)) map.Fail("sigma_mps", "must be positive");
  map.OptionalInRange("rate_hz", &velocity.rate_hz, 1e-3, kMaxRate_hz);
  map.Finish();
  return velocity;
}

OdometryConfig ReadOdometry(YamlMap& map) {
  OdometryConfig odometry;
  OdometryNoise& n = odometry.noise;
  map.OptionalInRange("position_sigma_m", &n.position_sigma_m, 0.0, 100.0);
  OptionalDegrees(map, "attitude_sigma_deg", &n.attitude_sigma_rad, 30.0);
  map.OptionalInRange("velocity_sigma_mps", &n.velocity_sigma_mps, 0.0, 100.0);
  map.OptionalInRange("correlation_time_s", &n.correlation_time_s, 0.0, 1e6);
  map.OptionalInRange("angular_rate_noise_density", &n.angular_rate_noise_density, 0.0, 10.0);
  map.OptionalInRange("position_drift_m_per_sqrt_s", &n.position_drift_m_per_sqrt_s, 0.0, 10.0);
  OptionalDegrees(map, "yaw_drift_deg_per_sqrt_s", &n.yaw_drift_rad_per_sqrt_s, 30.0);
  map.OptionalInRange("rate_hz", &odometry.rate_hz, 1e-3, kMaxRate_hz);
  std::string attitude_source = "model";
  map.Optional("attitude_source", &attitude_source);
  if (attitude_source != "model" && attitude_source != "platform_imu") {
    map.Fail("attitude_source", "expected model or platform_imu, got '" + attitude_source + "'");
  }
  odometry.attitude_from_platform_imu = attitude_source == "platform_imu";
  map.Finish();
  return odometry;
}

}  // namespace

SensorsConfig ReadSensorsConfig(YamlMap& params) {
  SensorsConfig config;
  double gravity_mps2 = config.imu.gravity_mps2;
  params.OptionalInRange("gravity_mps2", &gravity_mps2, 0.0, 100.0);
  YamlMap imu = params.Map("imu");
  config.imu = ReadImu(imu, gravity_mps2);
  YamlMap uwb = params.Map("uwb");
  config.uwb = ReadUwb(uwb);
  YamlMap filter = params.Map("wrench_filter");
  config.wrench_filter = ReadWrenchFilter(filter);
  YamlMap estimator = params.Map("attitude_estimator");
  config.attitude_estimator = ReadAttitudeEstimator(estimator, config.imu);
  if (params.Has("heading")) {
    YamlMap heading = params.Map("heading");
    config.heading = ReadHeading(heading);
  }
  if (params.Has("velocity")) {
    YamlMap velocity = params.Map("velocity");
    config.velocity = ReadVelocity(velocity);
    config.attitude_estimator.velocity_aided = true;
  }
  if (params.Has("odometry")) {
    YamlMap odometry = params.Map("odometry");
    config.odometry = ReadOdometry(odometry);
    if (config.odometry->attitude_from_platform_imu && !params.Has("platform_imu")) {
      odometry.Fail("attitude_source", "platform_imu needs a platform_imu section");
    }
  }
  if (params.Has("platform_imu")) {
    YamlMap platform = params.Map("platform_imu");
    const bool rate_given = platform.Has("rate_hz");
    config.platform_imu = ReadImu(platform, gravity_mps2);
    if (!rate_given) config.platform_imu->rate_hz = config.imu.rate_hz;
    if (config.platform_imu->rate_hz != config.imu.rate_hz) {
      platform.Fail("rate_hz", "must be the imu section's " + std::to_string(config.imu.rate_hz) +
                                   " Hz: the platform's EKF takes its aiding on the sub-aircraft's schedule");
    }
    // the sub-aircraft's filter settings (velocity-aided where they are), with this IMU's noise and mounting
    config.platform_attitude_estimator = config.attitude_estimator;
    config.platform_attitude_estimator->imu_noise = config.platform_imu->noise;
    config.platform_attitude_estimator->q_BI = config.platform_imu->q_BI;
  }
  return config;
}

std::vector<UwbAnchor> LoadUwbAnchors(const std::string& path) {
  YamlMap file(bridge::LoadYamlFile(path), path);
  if (!file.Has("anchors")) file.Fail("anchors", "is required (a list of {name, position_m})");
  std::vector<UwbAnchor> anchors = ReadAnchorList(file, "anchors");
  file.Finish();
  return anchors;
}

}  // namespace iapsim::sensors
