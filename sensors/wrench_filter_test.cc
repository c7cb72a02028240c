#include "sensors/wrench_filter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace iapsim::sensors {
namespace {

// Unit-step response of ω²/(s² + 2ζωs + ω²), from rest
double AnalyticStep(double w, double zeta, double t) {
  if (zeta < 1.0) {
    const double wd = w * std::sqrt(1.0 - zeta * zeta);
    return 1.0 - std::exp(-zeta * w * t) *
                     (std::cos(wd * t) + zeta / std::sqrt(1.0 - zeta * zeta) * std::sin(wd * t));
  }
  if (zeta == 1.0) return 1.0 - std::exp(-w * t) * (1.0 + w * t);
  const double root = std::sqrt(zeta * zeta - 1.0);
  const double s1 = -w * (zeta - root), s2 = -w * (zeta + root);
  return 1.0 + (s2 * std::exp(s1 * t) - s1 * std::exp(s2 * t)) / (s1 - s2);
}

void ExpectStepMatches(double w, double zeta, double dt) {
  WrenchFilter filter({w, zeta}, dt);
  const Vector6d step = (Vector6d() << 1.0, -2.0, 3.0, 0.5, -0.25, 10.0).finished();
  for (int k = 1; k <= static_cast<int>(3.0 / dt); ++k) {
    const Vector6d y = filter.Update(step);
    const double expected = AnalyticStep(w, zeta, k * dt);
    for (int i = 0; i < 6; ++i)
      ASSERT_NEAR(y[i], step[i] * expected, 1e-12 * std::fabs(step[i])) << "k " << k;
  }
}

TEST(WrenchFilter, DefaultsAreThoseOfSectionVIE) {
  const WrenchFilterConfig config;
  EXPECT_EQ(config.cutoff_rad_s, 10.0);
  EXPECT_EQ(config.damping, 1.414);
}

TEST(WrenchFilter, OverdampedStepMatchesTheAnalyticResponse) { ExpectStepMatches(10.0, 1.414, 0.005); }
TEST(WrenchFilter, UnderdampedStepMatchesTheAnalyticResponse) { ExpectStepMatches(10.0, 0.3, 0.001); }
TEST(WrenchFilter, CriticallyDampedStepMatchesTheAnalyticResponse) { ExpectStepMatches(25.0, 1.0, 0.004); }

TEST(WrenchFilter, DcGainIsOne) {
  WrenchFilter filter(WrenchFilterConfig(), 0.005);
  const Vector6d input = (Vector6d() << 19.62, -3.0, 0.1, 0.0, 2.5, -7.0).finished();
  Vector6d y = Vector6d::Zero();
  for (int k = 0; k < 4000; ++k) y = filter.Update(input);  // 20 s: the slow pole (−4.1 rad/s) has settled
  EXPECT_LT((y - input).norm(), 1e-12 * input.norm());
  EXPECT_EQ(filter.output(), y);
}

TEST(WrenchFilter, RejectsNonPositiveSettings) {
  EXPECT_THROW(WrenchFilter({0.0, 1.0}, 0.005), std::invalid_argument);
  EXPECT_THROW(WrenchFilter({10.0, -1.0}, 0.005), std::invalid_argument);
  EXPECT_THROW(WrenchFilter({10.0, 1.0}, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::sensors
