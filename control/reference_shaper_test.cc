#include "control/reference_shaper.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace iapsim::control {
namespace {

constexpr double kDt = 0.005;  // the control rate, 200 Hz

Eigen::Quaterniond Yaw(double rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitZ()));
}

// Inside its limits the shaper is the critically damped filter x(t) = Δ (1 − (1 + ωt) e^(−ωt)), on each
// position axis and on the rotation angle, and never overshoots.
TEST(ReferenceShaper, SmallStepsFollowTheCriticallyDampedResponse) {
  ReferenceShaperConfig config;
  config.bandwidth_hz = 0.8;
  ReferenceShaper shaper(config);
  shaper.Reset(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  const double omega = 2.0 * M_PI * config.bandwidth_hz;
  const Eigen::Vector3d step_m(0.03, -0.02, 0.01);  // peak speed Δω/e, start acceleration Δω²: inside
  const double yaw_rad = 0.02;
  double worst_m = 0.0, worst_rad = 0.0;
  for (int k = 0; k <= 1000; ++k) {
    const double t = k * kDt;
    const PoseReference r = shaper.Step(step_m, Yaw(yaw_rad), kDt);
    const double fraction = 1.0 - (1.0 + omega * t) * std::exp(-omega * t);
    worst_m = std::max(worst_m, (r.p_WP_m - fraction * step_m).norm());
    worst_rad = std::max(
        worst_rad, std::abs(r.q_WP.angularDistance(Eigen::Quaterniond::Identity()) - fraction * yaw_rad));
    EXPECT_LE(r.p_WP_m.x(), step_m.x() + 1e-12);
    EXPECT_GE(r.p_WP_m.y(), step_m.y() - 1e-12);
  }
  // the discretisation (acceleration held over each 5 ms) is the only difference: ωdt = 0.025
  EXPECT_LT(worst_m, 0.01 * step_m.norm());
  EXPECT_LT(worst_rad, 0.01 * yaw_rad);
}

// A ramp (a stick held at a constant speed) is followed at the constant lag 2v/ω of a type-1 loop with
// both poles at −ω, at the ramp's speed and with no acceleration.
TEST(ReferenceShaper, FollowsARampAtTheLagOfItsBandwidth) {
  ReferenceShaperConfig config;
  ReferenceShaper shaper(config);
  shaper.Reset(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  const double omega = 2.0 * M_PI * config.bandwidth_hz, speed = 0.3;
  PoseReference r;
  for (int k = 0; k <= 2000; ++k)
    r = shaper.Step(Eigen::Vector3d(speed * k * kDt, 0, 0), Eigen::Quaterniond::Identity(), kDt);
  EXPECT_NEAR(speed * 2000 * kDt - r.p_WP_m.x(), 2.0 * speed / omega, 0.01 * 2.0 * speed / omega);
  EXPECT_NEAR(r.v_WP_W_mps.x(), speed, 1e-6);
  EXPECT_NEAR(r.a_WP_W_mps2.x(), 0.0, 1e-6);
}

// The reference's velocity, acceleration, rate and angular acceleration are the derivatives of its pose:
// one step's change of position is v dt + a dt²/2 exactly, of velocity a dt, and the rotation between two
// steps is Exp(ω̄ dt + α dt²/2).
TEST(ReferenceShaper, DerivativesAreExact) {
  ReferenceShaper shaper{ReferenceShaperConfig()};
  shaper.Reset(Eigen::Vector3d(0, 0, -2), Eigen::Quaterniond::Identity());
  const Eigen::Quaterniond target =
      Yaw(0.5) * Eigen::Quaterniond(Eigen::AngleAxisd(0.15, Eigen::Vector3d(1, 1, 0).normalized()));
  PoseReference before = shaper.Step(Eigen::Vector3d(1.5, -0.7, -2.4), target, kDt);
  for (int k = 1; k < 800; ++k) {
    const PoseReference now = shaper.Step(Eigen::Vector3d(1.5, -0.7, -2.4), target, kDt);
    const Eigen::Vector3d expected_m =
        before.p_WP_m + before.v_WP_W_mps * kDt + 0.5 * before.a_WP_W_mps2 * kDt * kDt;
    ASSERT_LT((now.p_WP_m - expected_m).norm(), 1e-12) << k;
    ASSERT_LT((now.v_WP_W_mps - (before.v_WP_W_mps + before.a_WP_W_mps2 * kDt)).norm(), 1e-12) << k;
    const Eigen::Vector3d turn = before.w_WP_P_radps * kDt + 0.5 * before.dw_WP_P_radps2 * kDt * kDt;
    const Eigen::Quaterniond expected_q =
        before.q_WP * Eigen::Quaterniond(Eigen::AngleAxisd(turn.norm(), turn.normalized()));
    ASSERT_LT(now.q_WP.angularDistance(expected_q), 1e-9) << k;
    ASSERT_LT((now.w_WP_P_radps - (before.w_WP_P_radps + before.dw_WP_P_radps2 * kDt)).norm(), 1e-12) << k;
    before = now;
  }
}

// A large step (a pilot's 1.5 m switch, a 20° yaw) is flown within every rate and acceleration limit, per
// axis, and arrives without overshoot (the limits satisfy v_max <= 2 a_max / ω).
TEST(ReferenceShaper, LargeStepsStayWithinTheLimitsAndDoNotOvershoot) {
  ReferenceShaperConfig config;
  config.bandwidth_hz = 0.8;
  config.max_velocity_mps = Eigen::Vector3d(0.75, 0.6, 0.35);
  config.max_acceleration_mps2 = Eigen::Vector3d(2.0, 1.6, 1.0);
  config.max_rate_radps = Eigen::Vector3d(0.35, 0.35, 0.6);
  config.max_angular_acceleration_radps2 = Eigen::Vector3d(1.0, 1.0, 1.6);
  const double omega = 2.0 * M_PI * config.bandwidth_hz;
  ASSERT_TRUE((config.max_velocity_mps.array() <= 2.0 * config.max_acceleration_mps2.array() / omega).all());
  ASSERT_TRUE(
      (config.max_rate_radps.array() <= 2.0 * config.max_angular_acceleration_radps2.array() / omega).all());
  ReferenceShaper shaper(config);
  shaper.Reset(Eigen::Vector3d(0, 0, -2), Eigen::Quaterniond::Identity());
  const Eigen::Vector3d target_m(1.5, -1.0, -2.8);
  const double yaw_rad = 20.0 * M_PI / 180.0;
  Eigen::Vector3d peak_v = Eigen::Vector3d::Zero(), peak_a = Eigen::Vector3d::Zero();
  Eigen::Vector3d peak_w = Eigen::Vector3d::Zero(), peak_dw = Eigen::Vector3d::Zero();
  double max_yaw = 0.0;
  PoseReference r;
  for (int k = 0; k < 3000; ++k) {  // 15 s
    r = shaper.Step(target_m, Yaw(yaw_rad), kDt);
    peak_v = peak_v.cwiseMax(r.v_WP_W_mps.cwiseAbs());
    peak_a = peak_a.cwiseMax(r.a_WP_W_mps2.cwiseAbs());
    peak_w = peak_w.cwiseMax(r.w_WP_P_radps.cwiseAbs());
    peak_dw = peak_dw.cwiseMax(r.dw_WP_P_radps2.cwiseAbs());
    max_yaw = std::max(max_yaw, 2.0 * std::atan2(r.q_WP.z(), r.q_WP.w()));
    // each axis moves one way only: no overshoot
    ASSERT_LE(r.p_WP_m.x(), target_m.x() + 1e-9);
    ASSERT_GE(r.p_WP_m.y(), target_m.y() - 1e-9);
    ASSERT_GE(r.p_WP_m.z(), target_m.z() - 1e-9);
  }
  EXPECT_TRUE((peak_v.array() <= config.max_velocity_mps.array() + 1e-12).all()) << peak_v.transpose();
  EXPECT_TRUE((peak_a.array() <= config.max_acceleration_mps2.array() + 1e-12).all()) << peak_a.transpose();
  EXPECT_TRUE((peak_w.array() <= config.max_rate_radps.array() + 1e-12).all()) << peak_w.transpose();
  EXPECT_TRUE((peak_dw.array() <= config.max_angular_acceleration_radps2.array() + 1e-12).all());
  // the limits bound the motion, so they were reached: a 1.5 m move at 0.75 m/s, 20° at up to 34°/s
  EXPECT_NEAR(peak_v.x(), config.max_velocity_mps.x(), 1e-3);
  EXPECT_NEAR(peak_dw.z(), config.max_angular_acceleration_radps2.z(), 1e-12);
  EXPECT_LE(max_yaw, yaw_rad + 1e-9);
  EXPECT_LT((r.p_WP_m - target_m).norm(), 1e-6);
  EXPECT_LT(r.q_WP.angularDistance(Yaw(yaw_rad)), 1e-6);
}

// The defaults keep the promise of no overshoot.
TEST(ReferenceShaper, DefaultLimitsDoNotOvershoot) {
  const ReferenceShaperConfig config;
  const double omega = 2.0 * M_PI * config.bandwidth_hz;
  EXPECT_TRUE((config.max_velocity_mps.array() <= 2.0 * config.max_acceleration_mps2.array() / omega).all());
  EXPECT_TRUE(
      (config.max_rate_radps.array() <= 2.0 * config.max_angular_acceleration_radps2.array() / omega).all());
}

TEST(ReferenceShaper, RejectsSettingsThatAreNotPositive) {
  ReferenceShaperConfig config;
  config.bandwidth_hz = 0.0;
  EXPECT_THROW(ReferenceShaper{config}, std::invalid_argument);
  config = ReferenceShaperConfig();
  config.max_angular_acceleration_radps2.y() = -1.0;
  EXPECT_THROW(ReferenceShaper{config}, std::invalid_argument);
  config = ReferenceShaperConfig();
  config.max_velocity_mps.x() = std::nan("");
  EXPECT_THROW(ReferenceShaper{config}, std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::control
