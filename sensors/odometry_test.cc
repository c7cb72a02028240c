#include "sensors/odometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sensors/attitude_estimator.h"

namespace iapsim::sensors {
namespace {

OdometryState Moving() {
  OdometryState truth;
  truth.p_WB_m = {1.0, -2.0, -3.0};
  truth.q_WB = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
               Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
               Eigen::AngleAxisd(-0.1, Eigen::Vector3d::UnitX());
  truth.v_WB_B_mps = {0.5, 0.1, -0.2};
  truth.w_WB_B_radps = {0.05, -0.3, 0.2};
  return truth;
}

// the small rotation e with q̂ = q·Exp(e)
Eigen::Vector3d AttitudeError_B(const Eigen::Quaterniond& estimate, const Eigen::Quaterniond& truth) {
  const Eigen::AngleAxisd error(truth.conjugate() * estimate);
  return error.angle() * error.axis();
}

TEST(Odometry, WithoutNoiseItIsTheTruth) {
  OdometryModel model(OdometryConfig{}, 3);
  const OdometryState truth = Moving();
  for (int k = 0; k < 10; ++k) {
    const OdometryState estimate = model.Sample(truth, 0.005);
    EXPECT_EQ(estimate.p_WB_m, truth.p_WB_m);
    EXPECT_NEAR(estimate.q_WB.angularDistance(truth.q_WB), 0.0, 1e-15);
    EXPECT_EQ(estimate.v_WB_B_mps, truth.v_WB_B_mps);
    EXPECT_EQ(estimate.w_WB_B_radps, truth.w_WB_B_radps);
  }
}

// A first-order Gauss–Markov error keeps its σ and has the autocorrelation e^(−|lag|/τ) (lags of 1 and 40
// samples, τ = 0.2 s at 200 Hz: 0.975 and 0.368); with τ = 0 the samples are independent.
TEST(Odometry, GaussMarkovErrorsHaveTheirSigmaAndCorrelationTime) {
  for (const double tau_s : {0.0, 0.2}) {
    OdometryConfig config;
    config.noise.position_sigma_m = 0.02;
    config.noise.attitude_sigma_rad = 0.01;
    config.noise.velocity_sigma_mps = 0.05;
    config.noise.correlation_time_s = tau_s;
    OdometryModel model(config, 11);
    const OdometryState truth = Moving();
    const double dt_s = 0.005;
    const int n = 400000;  // 2000 s: 10⁴ correlation times
    std::vector<double> position, attitude, velocity;
    for (int k = 0; k < n; ++k) {
      const OdometryState estimate = model.Sample(truth, dt_s);
      position.push_back(estimate.p_WB_m.y() - truth.p_WB_m.y());
      attitude.push_back(AttitudeError_B(estimate.q_WB, truth.q_WB).x());
      velocity.push_back(estimate.v_WB_B_mps.z() - truth.v_WB_B_mps.z());
    }
    const auto correlation = [&](const std::vector<double>& x, int lag) {
      double sum = 0.0;
      for (int k = lag; k < n; ++k) sum += x[k] * x[k - lag];
      return sum / (n - lag);
    };
    for (const auto& [series, sigma] : {std::pair{&position, 0.02}, {&attitude, 0.01}, {&velocity, 0.05}}) {
      const double variance = correlation(*series, 0);
      EXPECT_NEAR(std::sqrt(variance) / sigma, 1.0, 0.03) << "tau " << tau_s;
      const double expected_1 = tau_s > 0.0 ? std::exp(-dt_s / tau_s) : 0.0;
      const double expected_40 = tau_s > 0.0 ? std::exp(-40 * dt_s / tau_s) : 0.0;
      EXPECT_NEAR(correlation(*series, 1) / variance, expected_1, 0.01) << "tau " << tau_s;
      EXPECT_NEAR(correlation(*series, 40) / variance, expected_40, 0.04) << "tau " << tau_s;
    }
  }
}

// Drift is a random walk: over 2000 seeds its variance after 10 s is q²·10 s, whatever the sample rate, and
// yaw drift turns the estimate about W's z only (its roll and pitch stay the truth's).
TEST(Odometry, DriftIsARandomWalkOfPositionAndYaw) {
  OdometryConfig config;
  config.noise.position_drift_m_per_sqrt_s = 0.01;
  config.noise.yaw_drift_rad_per_sqrt_s = 0.004;
  const OdometryState truth = Moving();
  for (const double dt_s : {0.005, 0.05}) {
    double position_sum = 0.0, yaw_sum = 0.0;
    const int seeds = 2000;
    for (int seed = 0; seed < seeds; ++seed) {
      OdometryModel model(config, seed);
      OdometryState estimate;
      for (int k = 0; k <= std::lround(10.0 / dt_s); ++k) estimate = model.Sample(truth, dt_s);
      position_sum += model.position_drift_W_m().squaredNorm() / 3.0;
      yaw_sum += model.yaw_drift_rad() * model.yaw_drift_rad();
      EXPECT_NEAR((estimate.p_WB_m - truth.p_WB_m - model.position_drift_W_m()).norm(), 0.0, 1e-12);
      const Eigen::Vector3d rpy = RollPitchYaw_rad(estimate.q_WB) - RollPitchYaw_rad(truth.q_WB);
      EXPECT_NEAR(rpy.x(), 0.0, 1e-9);
      EXPECT_NEAR(rpy.y(), 0.0, 1e-9);
      EXPECT_NEAR(WrapToPi(rpy.z()), model.yaw_drift_rad(), 1e-9);
    }
    // a mean of 2000 (6000) squared draws has a relative standard deviation of 3.2 % (1.8 %)
    EXPECT_NEAR(position_sum / seeds / (0.01 * 0.01 * 10.0), 1.0, 0.06) << dt_s;
    EXPECT_NEAR(yaw_sum / seeds / (0.004 * 0.004 * 10.0), 1.0, 0.1) << dt_s;
  }
}

TEST(Odometry, AngularRateNoiseIsTheGyroscopesWhiteNoise) {
  OdometryConfig config;
  config.noise.angular_rate_noise_density = 1.5e-3;  // Table VI's gyroscope: 0.0212 rad/s per 200 Hz sample
  OdometryModel model(config, 5);
  const OdometryState truth = Moving();
  double sum = 0.0, lag_sum = 0.0, previous = 0.0;
  const int n = 100000;
  for (int k = 0; k < n; ++k) {
    const double e = model.Sample(truth, 0.005).w_WB_B_radps.z() - truth.w_WB_B_radps.z();
    sum += e * e;
    lag_sum += e * previous;
    previous = e;
  }
  EXPECT_NEAR(std::sqrt(sum / n), 0.0212, 0.0212 * 0.01);
  EXPECT_NEAR(lag_sum / sum, 0.0, 0.01);
}

TEST(Odometry, ASeedRepeatsItsDrawsAndAnotherDoesNot) {
  OdometryConfig config;
  config.noise.position_sigma_m = 0.01;
  config.noise.correlation_time_s = 0.1;
  config.noise.yaw_drift_rad_per_sqrt_s = 0.01;
  OdometryModel a(config, 7), b(config, 7), c(config, 8);
  const OdometryState truth = Moving();
  for (int k = 0; k < 100; ++k) {
    const OdometryState ea = a.Sample(truth, 0.005), eb = b.Sample(truth, 0.005), ec = c.Sample(truth, 0.005);
    EXPECT_EQ(ea.p_WB_m, eb.p_WB_m);
    EXPECT_EQ(ea.q_WB.coeffs(), eb.q_WB.coeffs());
    EXPECT_NE(ea.p_WB_m, ec.p_WB_m);
  }
  EXPECT_THROW(a.Sample(truth, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::sensors
