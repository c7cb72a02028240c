#include "control/commanded_reference.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace iapsim::control {
namespace {

TEST(CommandedPoseReference, EstimatesTheCommandedVelocityAndRate) {
  CommandedPoseReference reference(0.1);
  EXPECT_TRUE(reference.empty());
  const Eigen::Vector3d v_W(0.5, -0.2, 0.1);
  const double yaw_rate = 0.3;
  for (int k = 0; k <= 100; ++k) {  // 50 Hz for 2 s: 20 time constants
    const double t = 0.02 * k;
    ASSERT_TRUE(reference.Add(t, v_W * t, Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rate * t, Eigen::Vector3d::UnitZ())), false));
  }
  const PoseReference& now = reference.current();
  EXPECT_LT((now.p_WP_m - v_W * 2.0).norm(), 1e-12);  // the last command itself
  EXPECT_LT((now.v_WP_W_mps - v_W).norm(), 1e-6);
  EXPECT_LT((now.w_WP_P_radps - Eigen::Vector3d(0, 0, yaw_rate)).norm(), 1e-6);
  EXPECT_LT(now.a_WP_W_mps2.norm(), 1e-5);  // constant velocity (the start-up transient decays)
}

TEST(CommandedPoseReference, EstimatesAConstantAcceleration) {
  CommandedPoseReference reference(0.05);
  const Eigen::Vector3d a_W(0.4, 0.0, -0.2);
  for (int k = 0; k <= 200; ++k) {
    const double t = 0.01 * k;
    ASSERT_TRUE(reference.Add(t, 0.5 * a_W * t * t, Eigen::Quaterniond::Identity(), false));
  }
  EXPECT_LT((reference.current().a_WP_W_mps2 - a_W).norm(), 1e-3);
  // the velocity lags the true a·t by about the filter's time constant
  EXPECT_LT((reference.current().v_WP_W_mps - a_W * 2.0).norm(), a_W.norm() * 0.07);
}

TEST(CommandedPoseReference, SmoothsAStep) {
  CommandedPoseReference reference(0.1);
  ASSERT_TRUE(reference.Add(0.0, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), false));
  ASSERT_TRUE(reference.Add(0.02, Eigen::Vector3d(1, 0, 0), Eigen::Quaterniond::Identity(), false));
  // a 1 m jump in one 20 ms sample reads as 50 m/s unfiltered; the low-pass passes dt/(tau+dt) of it
  EXPECT_NEAR(reference.current().v_WP_W_mps.x(), 50.0 * 0.02 / 0.12, 1e-9);
}

TEST(CommandedPoseReference, RejectsBadAndOutOfOrderCommands) {
  CommandedPoseReference reference(0.1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(reference.Add(0.0, Eigen::Vector3d(nan, 0, 0), Eigen::Quaterniond::Identity(), false));
  EXPECT_FALSE(reference.Add(0.0, Eigen::Vector3d::Zero(), Eigen::Quaterniond(0, 0, 0, 0), false));
  EXPECT_TRUE(reference.empty());
  ASSERT_TRUE(reference.Add(1.0, Eigen::Vector3d(1, 2, 3), Eigen::Quaterniond::Identity(), true));
  EXPECT_FALSE(reference.Add(1.0, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), false));
  EXPECT_FALSE(reference.Add(0.5, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), false));
  EXPECT_EQ(reference.current().p_WP_m, Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(reference.current().five_dof);
}

}  // namespace
}  // namespace iapsim::control
