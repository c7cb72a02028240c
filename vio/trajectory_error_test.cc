#include "vio/trajectory_error.h"

#include <gtest/gtest.h>

#include <cmath>

namespace iapsim::vio {
namespace {

// By hand: the estimate is the truth with errors (+3, 0, 0) cm, (0, −4, 0) cm and none at three stamps; a
// fourth stamp the truth does not have is counted apart. RMSE = √((9 + 16 + 0) / 3) cm = √(25/3) cm.
TEST(TrajectoryErrorTest, AteAsItIsOnAHandComputablePair) {
  const std::vector<StampedPosition> truth{{0, {0, 0, 0}}, {10, {1, 0, 0}}, {20, {1, 1, 0}}, {30, {0, 1, 0}}};
  const std::vector<StampedPosition> estimate{
      {0, {0.03, 0, 0}}, {10, {1, -0.04, 0}}, {20, {1, 1, 0}}, {25, {9, 9, 9}}};
  const AbsoluteTrajectoryError ate = ComputeAte(estimate, truth, false);
  EXPECT_EQ(ate.matched, 3u);
  EXPECT_EQ(ate.unmatched, 1u);
  EXPECT_NEAR(ate.rmse_m, std::sqrt(25.0 / 3.0) * 0.01, 1e-15);
  EXPECT_NEAR(ate.mean_m, 0.07 / 3.0, 1e-15);
  EXPECT_NEAR(ate.max_m, 0.04, 1e-15);
}

// A trajectory turned by 30° about z and moved by (1, 2, 3) m: the alignment finds that transform and the
// aligned error is zero, while the error as it is is not.
TEST(TrajectoryErrorTest, UmeyamaAlignmentRemovesARigidTransform) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI / 6.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(1, 2, 3);
  std::vector<StampedPosition> truth, estimate;
  for (int k = 0; k < 50; ++k) {
    const double t = 0.1 * k;
    const Eigen::Vector3d p(std::sin(t), std::cos(0.7 * t), 0.1 * t);
    truth.push_back({k, p});
    estimate.push_back({k, T.inverse() * p});
  }
  const AbsoluteTrajectoryError aligned = ComputeAte(estimate, truth, true);
  EXPECT_LT(aligned.rmse_m, 1e-12);
  EXPECT_LT((aligned.alignment.matrix() - T.matrix()).norm(), 1e-12);
  EXPECT_GT(ComputeAte(estimate, truth, false).rmse_m, 1.0);
}

}  // namespace
}  // namespace iapsim::vio
