#include "sensors/imu.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace iapsim::sensors {
namespace {

constexpr double kGravity = 9.81;
constexpr double kDt = 0.005;

ImuConfig NoiseFree() {
  ImuConfig config;
  config.noise = ImuNoise();
  return config;
}

Eigen::Quaterniond Rpy(double roll, double pitch, double yaw) {
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
}

TEST(Imu, LevelAtRestReadsMinusGAlongZ) {
  ImuModel imu(NoiseFree(), 1);
  const ImuSample sample = imu.Sample(BodyKinematics(), kDt);
  EXPECT_EQ(sample.f_I_mps2, Eigen::Vector3d(0.0, 0.0, -kGravity));
  EXPECT_EQ(sample.w_I_radps, Eigen::Vector3d::Zero());
}

TEST(Imu, TiltedAtRestReadsGravityInTheBody) {
  BodyKinematics truth;
  truth.q_WB = Rpy(0.3, -0.2, 1.0);
  const ImuSample sample =
      IdealImuSample(truth, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), kGravity);
  // f = −g (−sin θ, sin φ cos θ, cos φ cos θ)
  const Eigen::Vector3d expected =
      -kGravity *
      Eigen::Vector3d(-std::sin(-0.2), std::sin(0.3) * std::cos(-0.2), std::cos(0.3) * std::cos(-0.2));
  EXPECT_LT((sample.f_I_mps2 - expected).norm(), 1e-14);
}

TEST(Imu, FreeFallReadsZero) {
  BodyKinematics truth;
  truth.q_WB = Rpy(0.5, 0.4, -2.0);
  truth.a_WB_W_mps2 = {0.0, 0.0, kGravity};
  ImuModel imu(NoiseFree(), 1);
  EXPECT_LT(imu.Sample(truth, kDt).f_I_mps2.norm(), 1e-14);
}

TEST(Imu, OffsetImuOnASpinningBodyReadsTheCentripetalTerm) {
  ImuConfig config = NoiseFree();
  config.p_BI_m = {0.3, 0.0, 0.0};
  BodyKinematics truth;
  truth.w_WB_B_radps = {0.0, 0.0, 2.0};  // constant yaw rate, level
  const ImuSample sample = ImuModel(config, 1).Sample(truth, kDt);
  // ω×(ω×r) points to the axis: −ω²r
  EXPECT_NEAR(sample.f_I_mps2.x(), -2.0 * 2.0 * 0.3, 1e-14);
  EXPECT_NEAR(sample.f_I_mps2.y(), 0.0, 1e-14);
  EXPECT_NEAR(sample.f_I_mps2.z(), -kGravity, 1e-14);
  EXPECT_EQ(sample.w_I_radps, truth.w_WB_B_radps);
}

TEST(Imu, OffsetImuOnAnAcceleratingRotationReadsTheEulerTerm) {
  ImuConfig config = NoiseFree();
  config.p_BI_m = {0.3, 0.0, -0.1};
  BodyKinematics truth;
  truth.alpha_WB_B_radps2 = {0.0, 0.0, 5.0};
  const ImuSample sample = ImuModel(config, 1).Sample(truth, kDt);
  // α×r = (0, 5·0.3, 0)
  EXPECT_LT((sample.f_I_mps2 - Eigen::Vector3d(0.0, 1.5, -kGravity)).norm(), 1e-14);
}

TEST(Imu, RotatedMountingReadsInItsOwnAxes) {
  ImuConfig config = NoiseFree();
  config.q_BI = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());  // I's x along B's y
  BodyKinematics truth;
  truth.w_WB_B_radps = {0.0, 1.0, 0.0};
  truth.a_WB_W_mps2 = {0.0, 2.0, 0.0};
  const ImuSample sample = ImuModel(config, 1).Sample(truth, kDt);
  EXPECT_LT((sample.w_I_radps - Eigen::Vector3d(1.0, 0.0, 0.0)).norm(), 1e-14);
  EXPECT_LT((sample.f_I_mps2 - Eigen::Vector3d(2.0, 0.0, -kGravity)).norm(), 1e-14);
}

TEST(Imu, TableViIsTheStandardDeviationPerSampleAt200Hz) {
  const ImuNoise n = TableViNoise();
  const double dt = 1.0 / kTableViRate_hz;
  EXPECT_NEAR(n.gyroscope_noise_density / std::sqrt(dt), 0.0212, 1e-15);
  EXPECT_NEAR(n.gyroscope_random_walk * std::sqrt(dt), 1.4e-5, 1e-18);
  EXPECT_NEAR(n.accelerometer_noise_density / std::sqrt(dt), 0.2828, 1e-15);
  EXPECT_NEAR(n.accelerometer_random_walk * std::sqrt(dt), 1.4e-3, 1e-17);
  // the table is round densities at 200 Hz, to its printed digits
  EXPECT_NEAR(1.5e-3 / std::sqrt(dt), 0.0212, 0.00005);
  EXPECT_NEAR(2.0e-4 * std::sqrt(dt), 1.4e-5, 0.05e-5);
  EXPECT_NEAR(2.0e-2 / std::sqrt(dt), 0.2828, 0.00005);
  EXPECT_NEAR(2.0e-2 * std::sqrt(dt), 1.4e-3, 0.05e-3);
}

TEST(Imu, AtRestReadsGravityWithinTheWhiteNoiseOfItsDensity) {
  ImuConfig config;  // Table VI white noise, no bias walk
  config.noise.gyroscope_random_walk = 0.0;
  config.noise.accelerometer_random_walk = 0.0;
  ImuModel imu(config, 7);
  const int n = 100000;
  const double dt = 0.002;  // 500 Hz: σ per sample = density/√Δt
  Eigen::Vector3d f_sum = Eigen::Vector3d::Zero(), f_sum2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_sum = Eigen::Vector3d::Zero(), w_sum2 = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    const ImuSample s = imu.Sample(BodyKinematics(), dt);
    const Eigen::Vector3d f_error = s.f_I_mps2 - Eigen::Vector3d(0.0, 0.0, -kGravity);
    f_sum += f_error;
    f_sum2 += f_error.cwiseAbs2();
    w_sum += s.w_I_radps;
    w_sum2 += s.w_I_radps.cwiseAbs2();
  }
  const double f_sigma = config.noise.accelerometer_noise_density / std::sqrt(dt);
  const double w_sigma = config.noise.gyroscope_noise_density / std::sqrt(dt);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(f_sum[axis] / n, 0.0, 4.0 * f_sigma / std::sqrt(n));
    EXPECT_NEAR(w_sum[axis] / n, 0.0, 4.0 * w_sigma / std::sqrt(n));
    EXPECT_NEAR(std::sqrt(f_sum2[axis] / n), f_sigma, 0.02 * f_sigma);
    EXPECT_NEAR(std::sqrt(w_sum2[axis] / n), w_sigma, 0.02 * w_sigma);
  }
}

TEST(Imu, InitialBiasIsTheConfiguredMeanPlusItsSpread) {
  ImuConfig config = NoiseFree();
  config.initial_gyroscope_bias_radps = {0.01, -0.02, 0.03};
  config.initial_accelerometer_bias_mps2 = {0.1, 0.2, -0.3};
  ImuModel fixed(config, 3);
  EXPECT_EQ(fixed.gyroscope_bias_radps(), config.initial_gyroscope_bias_radps);
  const ImuSample s = fixed.Sample(BodyKinematics(), kDt);
  EXPECT_LT((s.w_I_radps - config.initial_gyroscope_bias_radps).norm(), 1e-15);
  EXPECT_LT((s.f_I_mps2 - Eigen::Vector3d(0.1, 0.2, -0.3 - kGravity)).norm(), 1e-14);

  config.initial_gyroscope_bias_sigma_radps = 0.05;
  double sum2 = 0.0;
  const int instances = 4000;
  for (int seed = 0; seed < instances; ++seed) {
    sum2 +=
        (ImuModel(config, seed).gyroscope_bias_radps() - config.initial_gyroscope_bias_radps).squaredNorm();
  }
  EXPECT_NEAR(std::sqrt(sum2 / (3 * instances)), 0.05, 0.05 * 0.03);
}

TEST(Imu, TheGyroscopeAloneHasItsDensitysNoiseItsBiasWalkAndItsMounting) {
  ImuConfig config;  // Table VI
  config.q_BI = Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitZ());
  config.noise.gyroscope_random_walk = 0.0;
  ImuModel white(config, 5);
  const int n = 100000;
  const double dt = 0.001;
  const Eigen::Vector3d w_B(0.3, -0.1, 0.2), w_I = config.q_BI.conjugate() * w_B;  // (−0.1, −0.3, 0.2)
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d error = white.SampleGyroscope(w_B, dt) - w_I;
    sum += error;
    sum2 += error.cwiseAbs2();
  }
  const double sigma = config.noise.gyroscope_noise_density / std::sqrt(dt);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(sum[axis] / n, 0.0, 4.0 * sigma / std::sqrt(n));
    EXPECT_NEAR(std::sqrt(sum2[axis] / n), sigma, 0.02 * sigma);
  }
  // the bias walks by random_walk·√t: its spread over many seeds after 1 s
  ImuConfig walking = NoiseFree();
  walking.noise.gyroscope_random_walk = 0.01;
  double bias2 = 0.0;
  const int instances = 2000;
  for (int seed = 0; seed < instances; ++seed) {
    ImuModel imu(walking, seed);
    for (int i = 0; i < 100; ++i) imu.SampleGyroscope(Eigen::Vector3d::Zero(), 0.01);
    bias2 += imu.gyroscope_bias_radps().squaredNorm();
  }
  EXPECT_NEAR(std::sqrt(bias2 / (3 * instances)), 0.01, 0.01 * 0.04);
}

// The accelerometer's bias (issue 24: a 10 % error in its random walk or its initial spread must fail):
// over many seeds its initial spread is the configured sigma, and its walk's variance grows as
// random_walk² · t (checked at 0.25 s and 1 s, so both the density and the √t law are tested). 3 axes ×
// 3000 seeds give the spread to about 0.8 % (1 / √(2 · 9000)); the bound is 4 %.
TEST(Imu, TheAccelerometerBiasStartsWithItsSpreadAndWalksByItsDensity) {
  ImuConfig config = NoiseFree();
  config.initial_accelerometer_bias_mps2 = {0.1, -0.2, 0.05};
  config.initial_accelerometer_bias_sigma_mps2 = 0.03;
  const int instances = 3000;
  double initial2 = 0.0;
  for (int seed = 0; seed < instances; ++seed) {
    initial2 += (ImuModel(config, seed).accelerometer_bias_mps2() - config.initial_accelerometer_bias_mps2)
                    .squaredNorm();
  }
  EXPECT_NEAR(std::sqrt(initial2 / (3 * instances)), 0.03, 0.03 * 0.04);

  ImuConfig walking = NoiseFree();
  walking.noise.accelerometer_random_walk = 0.02;  // m/s³/√Hz
  double quarter2 = 0.0, second2 = 0.0;
  for (int seed = 0; seed < instances; ++seed) {
    ImuModel imu(walking, seed);
    for (int i = 1; i <= 200; ++i) {  // 1 s at 200 Hz
      imu.Sample(BodyKinematics(), kDt);
      if (i == 50) quarter2 += imu.accelerometer_bias_mps2().squaredNorm();
    }
    second2 += imu.accelerometer_bias_mps2().squaredNorm();
    // the gyroscope's bias does not walk: only the accelerometer's was configured to
    ASSERT_EQ(imu.gyroscope_bias_radps(), Eigen::Vector3d::Zero());
  }
  EXPECT_NEAR(std::sqrt(quarter2 / (3 * instances)), 0.02 * std::sqrt(0.25), 0.02 * std::sqrt(0.25) * 0.04);
  EXPECT_NEAR(std::sqrt(second2 / (3 * instances)), 0.02, 0.02 * 0.04);
}

// A flight controller's IMU in PX4's 5 ms integration intervals: one mean accelerometer reading has the
// spread of the mean of the five 1 ms readings it stands for (density / √T, not / √dt), on the mounted axes;
// the gyroscope's readings within the interval have the per-sample spread of SampleGyroscope; and both biases
// walk by their densities over the intervals, the √t law of sample-by-sample walking.
TEST(Imu, AnIntegrationIntervalsMeansHaveTheSpreadOfTheirSamplesAndTheBiasesWalkAlike) {
  ImuConfig config;  // Table VI
  config.q_BI = Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitZ());
  config.noise.accelerometer_random_walk = 0.0;
  config.noise.gyroscope_random_walk = 0.0;
  ImuModel interval_imu(config, 5), sample_imu(config, 6);
  const int n = 40000;
  const double interval = 0.005, dt = 0.001;
  const Eigen::Vector3d f_B(0.3, -0.1, 9.81), f_I = config.q_BI.conjugate() * f_B;  // (−0.1, −0.3, 9.81)
  const Eigen::Vector3d w_B(0.3, -0.1, 0.2), w_I = config.q_BI.conjugate() * w_B;
  const BodyKinematics hover;  // level at rest: f = −g along z
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero(),
                  sample_sum2 = Eigen::Vector3d::Zero(), gyro_sum2 = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 5; ++k) {
      gyro_sum2 += (interval_imu.SampleGyroscopeInInterval(w_B, dt) - w_I).cwiseAbs2() / 5.0;
    }
    const Eigen::Vector3d error = interval_imu.EndInterval(f_B, interval) - f_I;
    sum += error;
    sum2 += error.cwiseAbs2();
    Eigen::Vector3d sample_mean = Eigen::Vector3d::Zero();
    for (int k = 0; k < 5; ++k) sample_mean += sample_imu.Sample(hover, dt).f_I_mps2 / 5.0;
    sample_sum2 += (sample_mean - config.q_BI.conjugate() * Eigen::Vector3d(0.0, 0.0, -kGravity)).cwiseAbs2();
  }
  const double sigma = config.noise.accelerometer_noise_density / std::sqrt(interval);
  const double gyro_sigma = config.noise.gyroscope_noise_density / std::sqrt(dt);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(sum[axis] / n, 0.0, 4.0 * sigma / std::sqrt(n));
    EXPECT_NEAR(std::sqrt(sum2[axis] / n), sigma, 0.03 * sigma);
    EXPECT_NEAR(std::sqrt(sample_sum2[axis] / n), sigma, 0.03 * sigma);
    EXPECT_NEAR(std::sqrt(gyro_sum2[axis] / n), gyro_sigma, 0.02 * gyro_sigma);
  }

  ImuConfig walking = NoiseFree();
  walking.noise.accelerometer_random_walk = 0.02;  // m/s³/√Hz
  walking.noise.gyroscope_random_walk = 0.01;      // rad/s²/√Hz
  double accelerometer2 = 0.0, gyroscope2 = 0.0;
  const int instances = 3000;
  for (int seed = 0; seed < instances; ++seed) {
    ImuModel imu(walking, seed);
    for (int i = 0; i < 200; ++i) {  // 1 s
      for (int k = 0; k < 5; ++k) {
        ASSERT_EQ(imu.SampleGyroscopeInInterval(Eigen::Vector3d::Zero(), dt), imu.gyroscope_bias_radps());
      }
      imu.EndInterval(Eigen::Vector3d::Zero(), interval);
    }
    accelerometer2 += imu.accelerometer_bias_mps2().squaredNorm();
    gyroscope2 += imu.gyroscope_bias_radps().squaredNorm();
  }
  EXPECT_NEAR(std::sqrt(accelerometer2 / (3 * instances)), 0.02, 0.02 * 0.04);
  EXPECT_NEAR(std::sqrt(gyroscope2 / (3 * instances)), 0.01, 0.01 * 0.04);
  EXPECT_THROW(ImuModel(config, 1).EndInterval(f_B, 0.0), std::invalid_argument);
  EXPECT_THROW(ImuModel(config, 1).SampleGyroscopeInInterval(w_B, 0.0), std::invalid_argument);
}

TEST(Imu, SameSeedSameSamplesOtherSeedOthers) {
  const ImuConfig config;
  ImuModel a(config, 42), b(config, 42), c(config, 43);
  for (int i = 0; i < 100; ++i) {
    const ImuSample sa = a.Sample(BodyKinematics(), kDt);
    const ImuSample sb = b.Sample(BodyKinematics(), kDt);
    const ImuSample sc = c.Sample(BodyKinematics(), kDt);
    ASSERT_EQ(sa.f_I_mps2, sb.f_I_mps2);
    ASSERT_EQ(sa.w_I_radps, sb.w_I_radps);
    ASSERT_NE(sa.w_I_radps, sc.w_I_radps);
  }
  ImuConfig offset = config;
  offset.seed_offset = 1;
  EXPECT_EQ(ImuModel(offset, 42).Sample(BodyKinematics(), kDt).w_I_radps,
            ImuModel(config, 43).Sample(BodyKinematics(), kDt).w_I_radps);
}

}  // namespace
}  // namespace iapsim::sensors
