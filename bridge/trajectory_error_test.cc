#include "bridge/trajectory_error.h"

#include <gtest/gtest.h>

#include <cmath>

namespace iapsim::bridge {
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

// By hand: the truth moves 1 m along x per second; the estimate moves 1.1 m per second and is turned 90°
// about z (a frame RPE must not care about): every 1 s pair has a translation error of 0.1 m and no rotation
// error. Pairs need both stamps matched: 4 stamps, 3 pairs.
TEST(TrajectoryErrorTest, RpeOnAHandComputablePair) {
  std::vector<StampedIsometry> truth, estimate;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (int k = 0; k < 4; ++k) {
    StampedIsometry q, p;
    q.t_ns = p.t_ns = k * 1'000'000'000LL;
    q.X.translation() = Eigen::Vector3d(1.0 * k, 0, 0);
    p.X.linear() = turn;
    p.X.translation() = turn * Eigen::Vector3d(1.1 * k, 0, 0) + Eigen::Vector3d(5, 5, 5);
    truth.push_back(q);
    estimate.push_back(p);
  }
  const RelativePoseError rpe = ComputeRpe(estimate, truth, 1'000'000'000LL);
  EXPECT_EQ(rpe.pairs, 3u);
  EXPECT_NEAR(rpe.translation_rmse_m, 0.1, 1e-12);
  EXPECT_NEAR(rpe.rotation_rmse_deg, 0.0, 1e-9);
  EXPECT_EQ(ComputeRpe(estimate, truth, 2'500'000'000LL).pairs, 0u);
}

}  // namespace
}  // namespace iapsim::bridge
