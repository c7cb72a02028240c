#include "sensors/allan.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "sensors/imu.h"

namespace iapsim::sensors {
namespace {

TEST(Allan, TwoSampleVarianceOfATinySeriesByHand) {
  // m = 1, τ = 1 s: σ² = Σ(y[k+1] − y[k])² / (2(n − 1))
  const std::vector<double> y = {1.0, 3.0, 2.0, 5.0, 4.0};
  const auto points = OverlappingAllanDeviation(y, 1.0);
  ASSERT_EQ(points.size(), 2u);  // m = 1, 2
  EXPECT_DOUBLE_EQ(points[0].tau_s, 1.0);
  EXPECT_NEAR(points[0].deviation, std::sqrt((4.0 + 1.0 + 9.0 + 1.0) / 8.0), 1e-12);
  // m = 2: averages of pairs (2, 2.5, 3.5, 4.5), differences two apart: 1.5, 2
  EXPECT_NEAR(points[1].deviation, std::sqrt((1.5 * 1.5 + 2.0 * 2.0) / 4.0), 1e-12);
}

TEST(Allan, WhiteNoiseFallsAsOneOverRootTau) {
  std::mt19937_64 random(5);
  std::normal_distribution<double> normal;
  const double rate_hz = 100.0, density = 0.01;
  std::vector<double> y(200000);
  for (double& v : y) v = 3.0 + density * std::sqrt(rate_hz) * normal(random);
  const auto points = OverlappingAllanDeviation(y, rate_hz);
  for (const auto& p : points) {
    if (p.clusters < 1000) continue;  // where the estimate is within a few percent
    EXPECT_NEAR(p.deviation * std::sqrt(p.tau_s), density, 0.1 * density) << "tau " << p.tau_s;
  }
}

TEST(Allan, FitIsExactOnTheModelCurve) {
  std::vector<AllanPoint> points;
  for (double tau = 0.01; tau < 1000.0; tau *= 1.5) {
    points.push_back({tau, std::sqrt(0.002 * 0.002 / tau + 3e-4 * 3e-4 * tau / 3.0), 1e5 / tau});
  }
  const AllanNoiseFit fit = FitWhiteNoiseAndRandomWalk(points);
  EXPECT_NEAR(fit.noise_density, 0.002, 1e-12);
  EXPECT_NEAR(fit.random_walk, 3e-4, 1e-12);
}

TEST(Allan, FitOfPureWhiteNoiseHasNoRandomWalk) {
  std::vector<AllanPoint> points;
  for (double tau = 0.01; tau < 100.0; tau *= 2.0) points.push_back({tau, 0.002 / std::sqrt(tau), 1e4 / tau});
  const AllanNoiseFit fit = FitWhiteNoiseAndRandomWalk(points);
  EXPECT_NEAR(fit.noise_density, 0.002, 1e-12);
  EXPECT_NEAR(fit.random_walk, 0.0, 1e-9);
}

// The acceptance test of issue 5: a static IMU with Table VI noise, 3 hours at 200 Hz; the fit of every
// axis is within 10% of the configured densities.
TEST(Allan, StaticImuRecoversTheConfiguredNoiseDensityAndRandomWalk) {
  const ImuConfig config;  // Table VI
  ImuModel imu(config, 2024);
  const double rate_hz = 200.0;
  const size_t count = static_cast<size_t>(3 * 3600 * rate_hz);
  std::vector<std::vector<double>> axes(6, std::vector<double>(count));
  for (size_t i = 0; i < count; ++i) {
    const ImuSample s = imu.Sample(BodyKinematics(), 1.0 / rate_hz);
    for (int a = 0; a < 3; ++a) {
      axes[a][i] = s.w_I_radps[a];
      axes[3 + a][i] = s.f_I_mps2[a];
    }
  }
  const char* names[] = {"gyro x", "gyro y", "gyro z", "accel x", "accel y", "accel z"};
  for (int a = 0; a < 6; ++a) {
    const AllanNoiseFit fit = FitWhiteNoiseAndRandomWalk(OverlappingAllanDeviation(axes[a], rate_hz, 8));
    const bool gyro = a < 3;
    const double density =
        gyro ? config.noise.gyroscope_noise_density : config.noise.accelerometer_noise_density;
    const double walk = gyro ? config.noise.gyroscope_random_walk : config.noise.accelerometer_random_walk;
    EXPECT_NEAR(fit.noise_density / density, 1.0, 0.10) << names[a];
    EXPECT_NEAR(fit.random_walk / walk, 1.0, 0.10) << names[a];
    std::printf(
        "%-8s noise density %.4e (configured %.4e, %+.2f%%)  random walk %.4e (configured %.4e, %+.2f%%)\n",
        names[a], fit.noise_density, density, 100.0 * (fit.noise_density / density - 1.0), fit.random_walk,
        walk, 100.0 * (fit.random_walk / walk - 1.0));
  }
}

}  // namespace
}  // namespace iapsim::sensors
