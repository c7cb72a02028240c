#include "sensors/sensor_config.h"

#include <gtest/gtest.h>

#include <string>

namespace iapsim::sensors {
namespace {

const std::string kSensorsDir = std::string(IAPSIM_SOURCE_DIR) + "/configs/sensors";
// a params file said to sit next to the shipped anchor files, so that relative anchors_file names resolve
const std::string kParamsFile = kSensorsDir + "/params.yaml";

SensorsConfig Read(const std::string& yaml) {
  bridge::YamlMap params(YAML::Load(yaml), kParamsFile);
  SensorsConfig config = ReadSensorsConfig(params);
  params.Finish();
  return config;
}

// the ConfigError's message, which must name the file and the key path
std::string ErrorOf(const std::string& yaml) {
  try {
    Read(yaml);
  } catch (const bridge::ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SensorConfig, DefaultsAreThePapers) {
  const SensorsConfig config = Read("{}");
  const ImuNoise table_vi = TableViNoise();
  EXPECT_EQ(config.imu.noise.gyroscope_noise_density, table_vi.gyroscope_noise_density);
  EXPECT_EQ(config.imu.noise.accelerometer_random_walk, table_vi.accelerometer_random_walk);
  EXPECT_EQ(config.imu.rate_hz, 200.0);
  EXPECT_EQ(config.uwb.noise.sigma_m, 0.7071);
  EXPECT_TRUE(config.uwb.anchors.empty());
  EXPECT_EQ(config.wrench_filter.cutoff_rad_s, 10.0);
  EXPECT_EQ(config.wrench_filter.damping, 1.414);
  EXPECT_EQ(config.attitude_estimator.imu_noise.gyroscope_random_walk, table_vi.gyroscope_random_walk);
  EXPECT_FALSE(config.heading.has_value());
  EXPECT_FALSE(config.odometry.has_value());
  EXPECT_FALSE(config.velocity.has_value());
  EXPECT_FALSE(config.attitude_estimator.velocity_aided);
  EXPECT_FALSE(config.platform_imu.has_value());
  EXPECT_EQ(Read("odometry: {}").odometry->noise.position_sigma_m, 0.0);  // the truth until told otherwise
}

TEST(SensorConfig, ReadsEveryKey) {
  const SensorsConfig config = Read(R"(
gravity_mps2: 9.8
imu:
  gyroscope_noise_density: 1.0e-3
  gyroscope_random_walk: 2.0e-5
  accelerometer_noise_density: 0.01
  accelerometer_random_walk: 4.0e-4
  rate_hz: 400
  mounting: {position_m: [0.1, 0, -0.02], rpy_deg: [0, 0, 90]}
  initial_gyroscope_bias_radps: [0.01, 0, 0]
  initial_gyroscope_bias_sigma_radps: 0.002
  initial_accelerometer_bias_mps2: [0, 0.1, 0]
  initial_accelerometer_bias_sigma_mps2: 0.05
  seed_offset: 7
uwb:
  anchors: [{name: a, position_m: [1, 2, -3]}, {name: b, position_m: [4, 5, -6]}]
  sigma_m: 0.1
  outlier_probability: 0.01
  outlier_magnitude_m: 5
  nlos_probability: 0.05
  nlos_bias_m: 0.3
  dropout_probability: 0.02
  rate_hz: 50
  tag_to_tag: false
wrench_filter: {cutoff_rad_s: 20, damping: 0.7}
attitude_estimator:
  imu_noise: {table_vi: true}
  initial_tilt_sigma_deg: 10
  initial_yaw_sigma_deg: 45
  initial_gyroscope_bias_sigma_radps: 0.02
  initial_accelerometer_bias_sigma_mps2: 0.3
  acceleration_sigma_mps2: 1.0
  acceleration_correlation_s: 2.0
  acceleration_gate_mps2: 3.0
  initial_velocity_sigma_mps: 0.3
heading: {sigma_deg: 5, rate_hz: 20}
velocity: {sigma_mps: 0.05, rate_hz: 40}
odometry:
  position_sigma_m: 0.02
  attitude_sigma_deg: 0.5
  velocity_sigma_mps: 0.05
  correlation_time_s: 0.2
  angular_rate_noise_density: 1.5e-3
  position_drift_m_per_sqrt_s: 0.01
  yaw_drift_deg_per_sqrt_s: 0.1
  rate_hz: 100
)");
  EXPECT_EQ(config.imu.noise.gyroscope_noise_density, 1.0e-3);
  EXPECT_EQ(config.imu.noise.accelerometer_random_walk, 4.0e-4);
  EXPECT_EQ(config.imu.rate_hz, 400.0);
  EXPECT_EQ(config.imu.gravity_mps2, 9.8);
  EXPECT_EQ(config.imu.p_BI_m, Eigen::Vector3d(0.1, 0.0, -0.02));
  EXPECT_LT((config.imu.q_BI * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 1e-15);
  EXPECT_EQ(config.imu.initial_gyroscope_bias_radps, Eigen::Vector3d(0.01, 0.0, 0.0));
  EXPECT_EQ(config.imu.initial_accelerometer_bias_sigma_mps2, 0.05);
  EXPECT_EQ(config.imu.seed_offset, 7u);
  ASSERT_EQ(config.uwb.anchors.size(), 2u);
  EXPECT_EQ(config.uwb.anchors[1].name, "b");
  EXPECT_EQ(config.uwb.anchors[1].p_WA_m, Eigen::Vector3d(4.0, 5.0, -6.0));
  EXPECT_EQ(config.uwb.noise.sigma_m, 0.1);
  EXPECT_EQ(config.uwb.noise.outlier_magnitude_m, 5.0);
  EXPECT_EQ(config.uwb.noise.nlos_bias_m, 0.3);
  EXPECT_EQ(config.uwb.noise.dropout_probability, 0.02);
  EXPECT_EQ(config.uwb.rate_hz, 50.0);
  EXPECT_FALSE(config.uwb.tag_to_tag);
  EXPECT_EQ(config.wrench_filter.cutoff_rad_s, 20.0);
  EXPECT_EQ(config.wrench_filter.damping, 0.7);
  const AttitudeEstimatorConfig& estimator = config.attitude_estimator;
  EXPECT_EQ(estimator.imu_noise.gyroscope_noise_density, TableViNoise().gyroscope_noise_density);
  EXPECT_TRUE(estimator.q_BI.isApprox(config.imu.q_BI));  // the IMU's mounting, and its gravity
  EXPECT_EQ(estimator.gravity_mps2, 9.8);
  EXPECT_NEAR(estimator.initial_yaw_sigma_rad, 45.0 * M_PI / 180.0, 1e-15);
  EXPECT_EQ(estimator.acceleration_correlation_s, 2.0);
  EXPECT_EQ(estimator.acceleration_gate_mps2, 3.0);
  EXPECT_EQ(estimator.initial_velocity_sigma_mps, 0.3);
  EXPECT_TRUE(estimator.velocity_aided);  // a velocity section makes it so
  ASSERT_TRUE(config.velocity.has_value());
  EXPECT_EQ(config.velocity->sigma_mps, 0.05);
  EXPECT_EQ(config.velocity->rate_hz, 40.0);
  ASSERT_TRUE(config.heading.has_value());
  EXPECT_NEAR(config.heading->sigma_rad, 5.0 * M_PI / 180.0, 1e-15);
  EXPECT_EQ(config.heading->rate_hz, 20.0);
  ASSERT_TRUE(config.odometry.has_value());
  const OdometryNoise& odometry = config.odometry->noise;
  EXPECT_EQ(odometry.position_sigma_m, 0.02);
  EXPECT_NEAR(odometry.attitude_sigma_rad, 0.5 * M_PI / 180.0, 1e-15);
  EXPECT_EQ(odometry.velocity_sigma_mps, 0.05);
  EXPECT_EQ(odometry.correlation_time_s, 0.2);
  EXPECT_EQ(odometry.angular_rate_noise_density, 1.5e-3);
  EXPECT_EQ(odometry.position_drift_m_per_sqrt_s, 0.01);
  EXPECT_NEAR(odometry.yaw_drift_rad_per_sqrt_s, 0.1 * M_PI / 180.0, 1e-15);
  EXPECT_EQ(config.odometry->rate_hz, 100.0);
}

TEST(SensorConfig, EstimatorAssumesTheImuNoiseUnlessTold) {
  const SensorsConfig config = Read("imu: {gyroscope_noise_density: 0.004}");
  EXPECT_EQ(config.imu.noise.gyroscope_noise_density, 0.004);
  EXPECT_EQ(config.imu.noise.accelerometer_noise_density, 0.0);  // given densities replace Table VI whole
  EXPECT_EQ(config.attitude_estimator.imu_noise.gyroscope_noise_density, 0.004);
}

// The platform's EKF is the sub-aircraft's (aided as they are) on a model of the platform's own IMU, which
// samples on the sub-aircraft's IMUs' schedule.
TEST(SensorConfig, ThePlatformsEstimatorHasTheSubAircraftSettingsAndItsOwnImu) {
  const SensorsConfig config = Read(R"(
imu: {rate_hz: 400}
attitude_estimator: {acceleration_correlation_s: 2.0}
velocity: {sigma_mps: 0.1}
platform_imu: {gyroscope_noise_density: 0.004, mounting: {rpy_deg: [0, 0, 90]}})");
  ASSERT_TRUE(config.platform_imu.has_value());
  ASSERT_TRUE(config.platform_attitude_estimator.has_value());
  EXPECT_EQ(config.platform_imu->rate_hz, 400.0);
  const AttitudeEstimatorConfig& platform = *config.platform_attitude_estimator;
  EXPECT_EQ(platform.imu_noise.gyroscope_noise_density, 0.004);
  EXPECT_EQ(config.attitude_estimator.imu_noise.gyroscope_noise_density,
            TableViNoise().gyroscope_noise_density);
  EXPECT_LT(platform.q_BI.angularDistance(
                Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()))),
            1e-12);
  EXPECT_EQ(platform.acceleration_correlation_s, 2.0);
  EXPECT_TRUE(platform.velocity_aided);
  EXPECT_FALSE(config.odometry.has_value());
  EXPECT_TRUE(Read("platform_imu: {}\nodometry: {attitude_source: platform_imu}")
                  .odometry->attitude_from_platform_imu);
  EXPECT_FALSE(Read("odometry: {attitude_source: model}").odometry->attitude_from_platform_imu);
  EXPECT_NE(ErrorOf("odometry: {attitude_source: platform_imu}")
                .find("odometry.attitude_source: platform_imu needs a platform_imu section"),
            std::string::npos);
  EXPECT_NE(ErrorOf("odometry: {attitude_source: ekf}")
                .find("odometry.attitude_source: expected model or platform_imu"),
            std::string::npos);
  EXPECT_NE(ErrorOf("imu: {rate_hz: 400}\nplatform_imu: {rate_hz: 200}")
                .find("platform_imu.rate_hz: must be the imu section's"),
            std::string::npos);
}

TEST(SensorConfig, ShippedAnchorFilesHoldTablesXAndXi) {
  const auto table_x = LoadUwbAnchors(kSensorsDir + "/uwb_anchors_table_x.yaml");
  ASSERT_EQ(table_x.size(), 4u);
  EXPECT_EQ(table_x[0].name, "anchor1");
  EXPECT_EQ(table_x[0].p_WA_m, Eigen::Vector3d(-8.17, -4.35, -1.38));
  EXPECT_EQ(table_x[1].p_WA_m, Eigen::Vector3d(2.93, -6.65, -3.3));
  const SensorsConfig config = Read("uwb: {anchors_file: uwb_anchors_table_xi.yaml}");
  ASSERT_EQ(config.uwb.anchors.size(), 4u);
  EXPECT_EQ(config.uwb.anchors[3].p_WA_m, Eigen::Vector3d(-34.48, 31.17, -1.14));
}

TEST(SensorConfig, ErrorsNameTheFileLineAndKey) {
  const auto expect_error = [](const std::string& yaml, const std::string& where) {
    const std::string message = ErrorOf(yaml);
    EXPECT_NE(message.find(kParamsFile + ":"), std::string::npos) << message;
    EXPECT_NE(message.find(where), std::string::npos) << message;
  };
  expect_error("imu: {table_vi: true, gyroscope_noise_density: 0.001}", "imu.table_vi");
  expect_error("imu: {gyroscope_noise_density: -1}", "imu.gyroscope_noise_density: must be in");
  expect_error("imu:\n  mounting: {position_m: [0, 0]}", "imu.mounting.position_m: expected 3 numbers");
  expect_error("imu:\n  mounting: {position_m: [0, 0]}", "params.yaml:2:");
  expect_error("imu: {rate_hzz: 100}", "imu.rate_hzz: unknown key (did you mean 'rate_hz'?)");
  expect_error("uwb: {dropout_probability: 1.5}", "uwb.dropout_probability");
  expect_error("uwb: {anchors: [{name: a, position_m: [0, 0, 0]}, {name: b}]}", "uwb.anchors[1].position_m");
  expect_error("uwb: {anchors: [{name: a, position_m: [0, 0, 0]}, {name: a, position_m: [1, 0, 0]}]}",
               "uwb.anchors[1].name: 'a' is used twice");
  expect_error("uwb: {anchors: [], anchors_file: uwb_anchors_table_x.yaml}", "uwb.anchors_file: give either");
  expect_error("uwb: {anchors_file: nowhere.yaml}", "uwb.anchors_file: no file");
  expect_error("wrench_filter: {damping: 0}", "wrench_filter.damping");
  expect_error("attitude_estimator: {imu_noise: {table_vi: yes please}}",
               "attitude_estimator.imu_noise.table_vi");
  expect_error("heading: {sigma_deg: 0}", "heading.sigma_deg: must be positive");
  expect_error("velocity: {sigma_mps: 0}", "velocity.sigma_mps: must be positive");
  expect_error("odometry: {correlation_time_s: -1}", "odometry.correlation_time_s: must be in");
  expect_error("odometry: {position_drift: 0.01}", "odometry.position_drift: unknown key");
}

}  // namespace
}  // namespace iapsim::sensors
