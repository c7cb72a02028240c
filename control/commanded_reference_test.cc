#include "control/commanded_reference.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace iapsim::control {
namespace {

ReferenceShaping Unshaped(double velocity_time_constant_s) {
  ReferenceShaping shaping;
  shaping.type = ReferenceShaping::Type::kNone;
  shaping.velocity_time_constant_s = velocity_time_constant_s;
  return shaping;
}

TEST(CommandedPoseReference, EstimatesTheCommandedVelocityAndRate) {
  CommandedPoseReference reference(Unshaped(0.1));
  EXPECT_TRUE(reference.empty());
  const Eigen::Vector3d v_W(0.5, -0.2, 0.1);
  const double yaw_rate = 0.3;
  for (int k = 0; k <= 100; ++k) {  // 50 Hz for 2 s: 20 time constants
    const double t = 0.02 * k;
    ASSERT_TRUE(reference.Add(t, v_W * t, Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rate * t, Eigen::Vector3d::UnitZ())), false));
  }
  const PoseReference now = reference.Update(PoseReference(), 0.005);  // unshaped: the command itself
  EXPECT_LT((now.p_WP_m - reference.command().p_WP_m).norm(), 1e-15);
  EXPECT_LT((now.p_WP_m - v_W * 2.0).norm(), 1e-12);  // the last command itself
  EXPECT_LT((now.v_WP_W_mps - v_W).norm(), 1e-6);
  EXPECT_LT((now.w_WP_P_radps - Eigen::Vector3d(0, 0, yaw_rate)).norm(), 1e-6);
  EXPECT_LT(now.a_WP_W_mps2.norm(), 1e-5);  // constant velocity (the start-up transient decays)
}

TEST(CommandedPoseReference, EstimatesAConstantAcceleration) {
  CommandedPoseReference reference(Unshaped(0.05));
  const Eigen::Vector3d a_W(0.4, 0.0, -0.2);
  for (int k = 0; k <= 200; ++k) {
    const double t = 0.01 * k;
    ASSERT_TRUE(reference.Add(t, 0.5 * a_W * t * t, Eigen::Quaterniond::Identity(), false));
  }
  EXPECT_LT((reference.command().a_WP_W_mps2 - a_W).norm(), 1e-3);
  // the velocity lags the true a·t by about the filter's time constant
  EXPECT_LT((reference.command().v_WP_W_mps - a_W * 2.0).norm(), a_W.norm() * 0.07);
}

TEST(CommandedPoseReference, SmoothsAStep) {
  CommandedPoseReference reference(Unshaped(0.1));
  ASSERT_TRUE(reference.Add(0.0, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), false));
  ASSERT_TRUE(reference.Add(0.02, Eigen::Vector3d(1, 0, 0), Eigen::Quaterniond::Identity(), false));
  // a 1 m jump in one 20 ms sample reads as 50 m/s unfiltered; the low-pass passes dt/(tau+dt) of it
  EXPECT_NEAR(reference.command().v_WP_W_mps.x(), 50.0 * 0.02 / 0.12, 1e-9);
}

TEST(CommandedPoseReference, RejectsBadAndOutOfOrderCommands) {
  CommandedPoseReference reference(Unshaped(0.1));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(reference.Add(0.0, Eigen::Vector3d(nan, 0, 0), Eigen::Quaterniond::Identity(), false));
  EXPECT_FALSE(reference.Add(0.0, Eigen::Vector3d::Zero(), Eigen::Quaterniond(0, 0, 0, 0), false));
  EXPECT_TRUE(reference.empty());
  ASSERT_TRUE(reference.Add(1.0, Eigen::Vector3d(1, 2, 3), Eigen::Quaterniond::Identity(), true));
  EXPECT_FALSE(reference.Add(1.0, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), false));
  EXPECT_FALSE(reference.Add(0.5, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), false));
  EXPECT_EQ(reference.command().p_WP_m, Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(reference.command().five_dof);
}

}  // namespace
}  // namespace iapsim::control

namespace iapsim::control {
namespace {

// Shaped, the flown reference starts where the IAP held and reaches the command; the lag it reports is the
// distance and angle between them: for a step small enough to stay inside the limits, the critically damped
// error e(t) = Δ (1 + ωt) e^(−ωt), whose mean square over T is Δ² · 1.25 / (ω T).
TEST(CommandedPoseReference, ShapedStartsFromTheHoldAndReportsItsLag) {
  CommandedPoseReference reference{ReferenceShaping()};  // 1 Hz
  const double omega = 2.0 * M_PI, dt = 0.005, step_m = 0.02, step_rad = 0.03;
  PoseReference hold;
  hold.p_WP_m = Eigen::Vector3d(0, 0, -2);
  const Eigen::Quaterniond yawed(Eigen::AngleAxisd(step_rad, Eigen::Vector3d::UnitZ()));
  ASSERT_TRUE(reference.Add(0.0, Eigen::Vector3d(step_m, 0, -2), yawed, false));
  const PoseReference first = reference.Update(hold, dt);
  EXPECT_EQ(first.p_WP_m, hold.p_WP_m);
  PoseReference now;
  const int updates = 2000;  // 10 s
  for (int k = 1; k < updates; ++k) now = reference.Update(hold, dt);
  EXPECT_LT((now.p_WP_m - Eigen::Vector3d(step_m, 0, -2)).norm(), 1e-7);
  EXPECT_LT(now.q_WP.angularDistance(yawed), 1e-7);
  const ReferenceLag lag = reference.lag();
  EXPECT_NEAR(lag.max_m, step_m, 1e-12);  // the largest was at the start
  EXPECT_NEAR(lag.max_deg, step_rad * 180.0 / M_PI, 1e-9);
  const double rms_over_step = std::sqrt(1.25 / (omega * updates * dt));
  EXPECT_NEAR(lag.rms_m / step_m, rms_over_step, 0.03 * rms_over_step);
  EXPECT_NEAR(lag.rms_deg / (step_rad * 180.0 / M_PI), rms_over_step, 0.03 * rms_over_step);
}

}  // namespace
}  // namespace iapsim::control
