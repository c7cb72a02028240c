#include "vio/factors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "vio/so3.h"
#include "vio/stereo_rig.h"
#include "vio/testing/synthetic.h"

namespace iapsim::vio {
namespace {

using testing::KnownMotion;
using testing::RightEye;
using testing::SeedRig;
const Eigen::Vector3d kGravity_W = testing::GravityW();

std::shared_ptr<ImuPreintegration> Preintegrate(double t0, double t1, const ImuBiases& biases) {
  const double rate_hz = 200.0;
  const int samples = static_cast<int>(std::lround((t1 - t0) * rate_hz));
  auto preintegration =
      std::make_shared<ImuPreintegration>(KnownMotion::Sample(t0), biases, sensors::TableViNoise());
  for (int k = 1; k <= samples; ++k)
    preintegration->Integrate((t1 - t0) / samples, KnownMotion::Sample(t0 + k * (t1 - t0) / samples));
  return preintegration;
}

// The analytic Jacobians of `factor` against Ceres's numeric differentiation of its residual with
// respect to each block's tangent (PoseManifold::Plus for the blocks marked pose, addition otherwise).
void ExpectJacobiansMatchNumericDifferentiation(const ceres::CostFunction& factor,
                                                std::vector<std::vector<double>> blocks,
                                                const std::vector<bool>& is_pose) {
  struct TangentResidual {
    const ceres::CostFunction* factor;
    std::vector<std::vector<double>> blocks;
    std::vector<bool> is_pose;
    bool operator()(double const* const* deltas, double* residuals) const {
      std::vector<std::vector<double>> moved = blocks;
      std::vector<const double*> pointers;
      const PoseManifold manifold;
      for (std::size_t b = 0; b < blocks.size(); ++b) {
        if (is_pose[b]) {
          manifold.Plus(blocks[b].data(), deltas[b], moved[b].data());
        } else {
          for (std::size_t k = 0; k < blocks[b].size(); ++k) moved[b][k] += deltas[b][k];
        }
        pointers.push_back(moved[b].data());
      }
      return factor->Evaluate(pointers.data(), residuals, nullptr);
    }
  };
  auto* functor = new TangentResidual{&factor, blocks, is_pose};
  // Ridders' extrapolation: the tangent starts at 0, where central differences would step by √ε ≈ 1.5e-8 and
  // leave whitened IMU residuals (hundreds of sigmas) with round-off of 1e-6.
  ceres::DynamicNumericDiffCostFunction<TangentResidual, ceres::RIDDERS> numeric(functor);
  std::vector<std::vector<double>> zeros;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const int tangent = is_pose[b] ? kPoseTangentSize : static_cast<int>(blocks[b].size());
    numeric.AddParameterBlock(tangent);
    zeros.emplace_back(tangent, 0.0);
  }
  const int m = factor.num_residuals();
  numeric.SetNumResiduals(m);

  std::vector<const double*> zero_pointers, pointers;
  std::vector<std::vector<double>> numeric_jacobians, analytic_jacobians;
  std::vector<double*> numeric_pointers, analytic_pointers;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    zero_pointers.push_back(zeros[b].data());
    pointers.push_back(blocks[b].data());
    numeric_jacobians.emplace_back(m * zeros[b].size());
    analytic_jacobians.emplace_back(m * blocks[b].size());
  }
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    numeric_pointers.push_back(numeric_jacobians[b].data());
    analytic_pointers.push_back(analytic_jacobians[b].data());
  }
  std::vector<double> r_numeric(m), r_analytic(m);
  ASSERT_TRUE(numeric.Evaluate(zero_pointers.data(), r_numeric.data(), numeric_pointers.data()));
  ASSERT_TRUE(factor.Evaluate(pointers.data(), r_analytic.data(), analytic_pointers.data()));
  for (int i = 0; i < m; ++i) EXPECT_DOUBLE_EQ(r_numeric[i], r_analytic[i]);
  EXPECT_GT(Eigen::Map<Eigen::VectorXd>(r_analytic.data(), m).norm(), 1e-3) << "test at a non-zero residual";

  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const int tangent = static_cast<int>(zeros[b].size()), ambient = static_cast<int>(blocks[b].size());
    for (int i = 0; i < m; ++i) {
      for (int k = 0; k < tangent; ++k) {
        const double n = numeric_jacobians[b][i * tangent + k], a = analytic_jacobians[b][i * ambient + k];
        EXPECT_NEAR(a, n, 1e-6 * (1.0 + std::abs(n)))
            << "block " << b << " residual " << i << " tangent " << k;
      }
      if (is_pose[b]) {
        EXPECT_EQ(analytic_jacobians[b][i * ambient + kPoseTangentSize], 0.0);  // lifted
      }
    }
  }
}

std::vector<double> PoseBlock(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  std::vector<double> block(kPoseSize);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = q.toRotationMatrix();
  X.translation() = p;
  PoseToBlock(X, block.data());
  return block;
}

TEST(FactorsTest, ImuFactorJacobiansMatchNumericDifferentiation) {
  const ImuBiases linearised{{0.01, -0.02, 0.015}, {0.1, -0.05, 0.2}};
  const auto preintegration = Preintegrate(0.3, 0.55, linearised);
  const ImuFactor factor(preintegration, sensors::TableViNoise(), kGravity_W);
  const NavState i = KnownMotion::State(0.3), j = KnownMotion::State(0.55);
  // Away from the measurement (by millimetres: whitened, that is already hundreds of standard deviations),
  // and with biases moved from the linearisation point.
  const std::vector<double> sb_i{
      i.v_WI_W_mps.x(), i.v_WI_W_mps.y(), i.v_WI_W_mps.z(), 0.013, -0.018, 0.01, 0.12, -0.08, 0.17};
  const std::vector<double> sb_j{j.v_WI_W_mps.x() + 0.005,
                                 j.v_WI_W_mps.y(),
                                 j.v_WI_W_mps.z() - 0.003,
                                 0.014,
                                 -0.017,
                                 0.011,
                                 0.13,
                                 -0.07,
                                 0.18};
  ExpectJacobiansMatchNumericDifferentiation(
      factor,
      {PoseBlock(i.p_WI_m, i.q_WI), sb_i,
       PoseBlock(j.p_WI_m + Eigen::Vector3d(0.002, -0.001, 0.003),
                 j.q_WI * ExpQuaternion(Eigen::Vector3d(0.003, -0.002, 0.005))),
       sb_j},
      {true, false, true, false});
}

TEST(FactorsTest, ReprojectionAndStereoFactorJacobiansMatchNumericDifferentiation) {
  const StereoRig rig = SeedRig();
  const double sqrt_information = rig.intrinsics.fx / 1.5;
  const NavState i = KnownMotion::State(0.2), j = KnownMotion::State(0.7);
  const ReprojectionFactor temporal(Eigen::Vector2d(0.1, -0.2), Eigen::Vector2d(0.15, -0.18), rig.X_IL,
                                    rig.X_IL, sqrt_information);
  const ReprojectionFactor right_eye(Eigen::Vector2d(-0.3, 0.1), Eigen::Vector2d(-0.33, 0.12), rig.X_IL,
                                     RightEye(rig), sqrt_information);
  for (const ReprojectionFactor* factor : {&temporal, &right_eye}) {
    ExpectJacobiansMatchNumericDifferentiation(
        *factor, {PoseBlock(i.p_WI_m, i.q_WI), PoseBlock(j.p_WI_m, j.q_WI), {1.0 / 6.0}},
        {true, true, false});
  }
  const StereoFactor stereo(Eigen::Vector2d(0.2, 0.1), Eigen::Vector2d(0.17, 0.101), rig.baseline_m,
                            sqrt_information);
  ExpectJacobiansMatchNumericDifferentiation(stereo, {{1.0 / 5.0}}, {false});
}

TEST(FactorsTest, AnInvalidNoiseModelIsAClearError) {
  sensors::ImuNoise no_walk = sensors::TableViNoise();
  no_walk.gyroscope_random_walk = 0.0;
  EXPECT_THROW(ImuFactor(Preintegrate(0.0, 0.1, {}), no_walk, kGravity_W), std::invalid_argument);
}

// Ten keyframes of the known motion 0.1 s apart with exact IMU and exact stereo observations of 80 points:
// from poses off by 5 cm and 2°, velocities off by 0.1 m/s and depths off by 20 %, the IMU, reprojection and
// stereo factors together bring every pose back to within a millimetre and 0.01° (the first pose held: it
// fixes the four directions VIO cannot observe).
TEST(FactorsTest, IMUAndStereoFactorsRecoverAKnownTrajectory) {
  const StereoRig rig = SeedRig();
  const Eigen::Isometry3d X_IR = RightEye(rig);
  const double sqrt_information = rig.intrinsics.fx / 1.5;
  const int keyframes = 10;
  const double gap_s = 0.1;
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);

  std::vector<std::vector<double>> poses(keyframes, std::vector<double>(kPoseSize));
  std::vector<std::vector<double>> speed_biases(keyframes, std::vector<double>(kSpeedBiasSize, 0.0));
  std::vector<Eigen::Isometry3d> truth(keyframes);
  for (int k = 0; k < keyframes; ++k) {
    const NavState s = KnownMotion::State(k * gap_s);
    truth[k].linear() = s.q_WI.toRotationMatrix();
    truth[k].translation() = s.p_WI_m;
    Eigen::Isometry3d start = truth[k];
    if (k > 0) {
      start.translation() += 0.05 * Eigen::Vector3d(unit(random), unit(random), unit(random)).normalized();
      start.linear() =
          start.linear() *
          Exp(2.0 * M_PI / 180.0 * Eigen::Vector3d(unit(random), unit(random), unit(random)).normalized());
    }
    PoseToBlock(start, poses[k].data());
    for (int a = 0; a < 3; ++a) speed_biases[k][a] = s.v_WI_W_mps(a) + 0.1 * unit(random);
  }

  ceres::Problem problem;
  for (int k = 0; k < keyframes; ++k) {
    problem.AddParameterBlock(poses[k].data(), kPoseSize, new PoseManifold);
    problem.AddParameterBlock(speed_biases[k].data(), kSpeedBiasSize);
  }
  problem.SetParameterBlockConstant(poses[0].data());
  for (int k = 0; k + 1 < keyframes; ++k) {
    problem.AddResidualBlock(
        new ImuFactor(Preintegrate(k * gap_s, (k + 1) * gap_s, {}), sensors::TableViNoise(), kGravity_W),
        nullptr, poses[k].data(), speed_biases[k].data(), poses[k + 1].data(), speed_biases[k + 1].data());
  }

  // Points ahead of the whole motion; each anchored in the first keyframe whose left eye sees it.
  auto sees = [&](const Eigen::Isometry3d& X_WC, const Eigen::Vector3d& p_W, Eigen::Vector2d* xy) {
    const Eigen::Vector3d p_C = X_WC.inverse() * p_W;
    *xy = p_C.head<2>() / p_C.z();
    return p_C.z() > 0.5 && std::abs(xy->x()) < 0.95 && std::abs(xy->y()) < 0.7;
  };
  std::vector<double> inverse_depths;
  inverse_depths.reserve(80);
  int observations = 0;
  while (inverse_depths.size() < 80) {
    const Eigen::Vector3d p_W(7.0 + 2.0 * unit(random), 1.0 + 4.0 * unit(random), -2.0 + 2.0 * unit(random));
    Eigen::Vector2d anchor_xy;
    if (!sees(truth[0] * rig.X_IL, p_W, &anchor_xy)) continue;
    inverse_depths.push_back(1.2 / (truth[0] * rig.X_IL).inverse().operator*(p_W).z());  // 20 % too near
    double* lambda = &inverse_depths.back();
    Eigen::Vector2d xy;
    if (sees(truth[0] * X_IR, p_W, &xy)) {
      problem.AddResidualBlock(new StereoFactor(anchor_xy, xy, rig.baseline_m, sqrt_information), nullptr,
                               lambda);
    }
    for (int k = 1; k < keyframes; ++k) {
      for (const Eigen::Isometry3d* X_IC : {&rig.X_IL, &X_IR}) {
        if (!sees(truth[k] * *X_IC, p_W, &xy)) continue;
        problem.AddResidualBlock(new ReprojectionFactor(anchor_xy, xy, rig.X_IL, *X_IC, sqrt_information),
                                 new ceres::HuberLoss(1.0), poses[0].data(), poses[k].data(), lambda);
        ++observations;
      }
    }
  }
  ASSERT_GT(observations, 80 * 2 * (keyframes - 1) * 8 / 10);

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = 50;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.FullReport();
  for (int k = 0; k < keyframes; ++k) {
    const Eigen::Isometry3d X = PoseFromBlock(poses[k].data());
    EXPECT_LT((X.translation() - truth[k].translation()).norm(), 1e-3) << "keyframe " << k;
    EXPECT_LT(Log(Eigen::Matrix3d(truth[k].linear().transpose() * X.linear())).norm(), 0.01 * M_PI / 180.0)
        << "keyframe " << k;
    EXPECT_LT((Eigen::Vector3d(speed_biases[k].data()) - KnownMotion::State(k * gap_s).v_WI_W_mps).norm(),
              2e-3)
        << "keyframe " << k;
  }
}

}  // namespace
}  // namespace iapsim::vio
