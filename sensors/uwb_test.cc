#include "sensors/uwb.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace iapsim::sensors {
namespace {

const Eigen::Vector3d kAnchor_m(-8.17, -4.35, -1.38);
const Eigen::Vector3d kTag_m(1.0, 2.0, -2.5);

TEST(Uwb, WithoutNoiseRangesAreTheGeometry) {
  UwbNoise noise;
  noise.sigma_m = 0.0;
  UwbModel uwb(noise, 1);
  std::mt19937_64 random(9);
  std::uniform_real_distribution<double> coordinate(-20.0, 20.0);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d a(coordinate(random), coordinate(random), coordinate(random));
    const Eigen::Vector3d b(coordinate(random), coordinate(random), coordinate(random));
    const UwbRange range = uwb.Measure(a, b);
    ASSERT_TRUE(range.received);
    ASSERT_EQ(range.range_m, (b - a).norm());
  }
}

TEST(Uwb, NoiseMeanAndSigmaMatchTheConfiguration) {
  const UwbNoise noise;  // Table VI: σ = 0.7071 m
  UwbModel uwb(noise, 11);
  const int n = 200000;
  const double truth_m = (kTag_m - kAnchor_m).norm();
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < n; ++i) {
    const double error = uwb.Measure(kAnchor_m, kTag_m).range_m - truth_m;
    sum += error;
    sum2 += error * error;
  }
  const double mean = sum / n;
  const double sigma = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 4.0 * noise.sigma_m / std::sqrt(n));
  EXPECT_NEAR(sigma, kTableViUwbSigma_m, 0.01 * kTableViUwbSigma_m);
}

TEST(Uwb, OutliersNlosAndDropoutsOccurAtTheirRatesAndSizes) {
  UwbNoise noise;
  noise.sigma_m = 0.0;  // so that every error is one of the effects
  noise.outlier_probability = 0.05;
  noise.outlier_magnitude_m = 3.0;
  noise.nlos_probability = 0.2;
  noise.nlos_bias_m = 0.4;
  noise.dropout_probability = 0.1;
  UwbModel uwb(noise, 12);
  const int n = 100000;
  const double truth_m = (kTag_m - kAnchor_m).norm();
  int outliers = 0, nlos = 0, dropped = 0, clean_nlos = 0;
  double outlier_error2 = 0.0;
  for (int i = 0; i < n; ++i) {
    const UwbRange r = uwb.Measure(kAnchor_m, kTag_m);
    outliers += r.outlier;
    nlos += r.nlos;
    dropped += !r.received;
    const double error = r.range_m - truth_m - (r.nlos ? noise.nlos_bias_m : 0.0);
    if (r.outlier) {
      ASSERT_LE(std::fabs(error), noise.outlier_magnitude_m + 1e-12);
      outlier_error2 += error * error;
    } else {
      ASSERT_NEAR(error, 0.0, 1e-12);
      clean_nlos += r.nlos;
    }
  }
  // counts within 4 binomial standard deviations
  const auto expect_rate = [n](int count, double p, const char* what) {
    EXPECT_NEAR(count, n * p, 4.0 * std::sqrt(n * p * (1.0 - p))) << what;
  };
  expect_rate(outliers, noise.outlier_probability, "outliers");
  expect_rate(nlos, noise.nlos_probability, "nlos");
  expect_rate(dropped, noise.dropout_probability, "dropouts");
  EXPECT_GT(clean_nlos, 0);
  // an outlier's error is uniform in ±magnitude: variance magnitude²/3
  EXPECT_NEAR(outlier_error2 / outliers, 3.0 * 3.0 / 3.0, 0.06 * 3.0);
}

TEST(Uwb, ChangingOneProbabilityLeavesTheOtherEffectsAlone) {
  UwbNoise plain;
  UwbNoise with_dropouts = plain;
  with_dropouts.dropout_probability = 0.3;
  UwbModel a(plain, 5), b(with_dropouts, 5);
  for (int i = 0; i < 1000; ++i) {
    const UwbRange ra = a.Measure(kAnchor_m, kTag_m), rb = b.Measure(kAnchor_m, kTag_m);
    ASSERT_EQ(ra.range_m, rb.range_m);
  }
}

}  // namespace
}  // namespace iapsim::sensors
