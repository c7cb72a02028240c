#include "vio/factors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "vio/marginalisation.h"
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

TEST(FactorsTest, RangeFactorJacobiansMatchNumericDifferentiation) {
  const ImuBiases linearised{{0.01, -0.02, 0.015}, {0.1, -0.05, 0.2}};
  const auto since_keyframe = Preintegrate(0.3, 0.42, linearised);
  // A tag 10 cm beside the IMU, so that the lever arm's terms are exercised; the range 0.3 m off.
  const Eigen::Vector3d p_IT(0.02, 0.1, -0.05), p_WA(4.0, -3.0, -1.0);
  const NavState k = KnownMotion::State(0.3), r = KnownMotion::State(0.42);
  const double range = (r.p_WI_m + r.q_WI * p_IT - p_WA).norm() + 0.3;
  const RangeFactor factor(RangeFactor::SinceKeyframe(*since_keyframe), p_WA, range, 0.1, p_IT, kGravity_W);
  const std::vector<double> sb{
      k.v_WI_W_mps.x(), k.v_WI_W_mps.y(), k.v_WI_W_mps.z(), 0.013, -0.018, 0.01, 0.12, -0.08, 0.17};
  ExpectJacobiansMatchNumericDifferentiation(factor, {PoseBlock(k.p_WI_m, k.q_WI), sb}, {true, false});
  // Without biases the preintegrated prediction is the motion's own tag position: the residual is the 0.3 m.
  const RangeFactor unbiased(RangeFactor::SinceKeyframe(*Preintegrate(0.3, 0.42, {})), p_WA, range, 0.1, p_IT,
                             kGravity_W);
  std::vector<double> zero_sb{k.v_WI_W_mps.x(), k.v_WI_W_mps.y(), k.v_WI_W_mps.z(), 0, 0, 0, 0, 0, 0};
  const std::vector<double> pose = PoseBlock(k.p_WI_m, k.q_WI);
  const double* unbiased_blocks[] = {pose.data(), zero_sb.data()};
  double residual = 0.0;
  ASSERT_TRUE(unbiased.Evaluate(unbiased_blocks, &residual, nullptr));
  EXPECT_NEAR(residual, -0.3 / 0.1, 1e-4);
}

TEST(FactorsTest, AnInvalidNoiseModelIsAClearError) {
  sensors::ImuNoise no_walk = sensors::TableViNoise();
  no_walk.gyroscope_random_walk = 0.0;
  EXPECT_THROW(ImuFactor(Preintegrate(0.0, 0.1, {}), no_walk, kGravity_W), std::invalid_argument);
}

// Ten keyframes of the known motion 0.1 s apart with exact IMU and stereo observations (exact, or with
// Gaussian pixel noise) of 80 points anchored in the first keyframe, every block started away from the truth
// (keyframes after the first by 5 cm and 2°, velocities by 0.1 m/s, depths by 20 %). The blocks stay
// outside any problem so that a test can add them to several.
class SyntheticWindow {
 public:
  static constexpr int kKeyframes = 10;
  static constexpr double kGap_s = 0.1;

  struct Block {
    std::unique_ptr<ceres::CostFunction> cost;
    std::unique_ptr<ceres::LossFunction> loss;
    std::vector<double*> parameters;
  };

  explicit SyntheticWindow(double pixel_sigma_px) {
    const StereoRig rig = SeedRig();
    const Eigen::Isometry3d X_IR = RightEye(rig);
    const double sqrt_information = rig.intrinsics.fx / 1.5;
    std::mt19937_64 random(7);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::normal_distribution<double> pixel_noise(0.0, pixel_sigma_px / rig.intrinsics.fx);
    for (int k = 0; k < kKeyframes; ++k) {
      const NavState s = KnownMotion::State(k * kGap_s);
      truth.push_back(KnownMotion::Pose(k * kGap_s));
      Eigen::Isometry3d start = truth[k];
      if (k > 0) {
        start.translation() += 0.05 * Eigen::Vector3d(unit(random), unit(random), unit(random)).normalized();
        start.linear() =
            start.linear() *
            Exp(2.0 * M_PI / 180.0 * Eigen::Vector3d(unit(random), unit(random), unit(random)).normalized());
      }
      poses.emplace_back(kPoseSize);
      PoseToBlock(start, poses[k].data());
      speed_biases.emplace_back(kSpeedBiasSize, 0.0);
      for (int a = 0; a < 3; ++a) speed_biases[k][a] = s.v_WI_W_mps(a) + 0.1 * unit(random);
    }
    for (int k = 0; k + 1 < kKeyframes; ++k) {
      imu.push_back(
          {std::make_unique<ImuFactor>(Preintegrate(k * kGap_s, (k + 1) * kGap_s, {}),
                                       sensors::TableViNoise(), kGravity_W),
           nullptr,
           {poses[k].data(), speed_biases[k].data(), poses[k + 1].data(), speed_biases[k + 1].data()}});
    }
    // Points ahead of the whole motion, each seen by the first keyframe's left eye.
    auto sees = [&](const Eigen::Isometry3d& X_WC, const Eigen::Vector3d& p_W, Eigen::Vector2d* xy) {
      const Eigen::Vector3d p_C = X_WC.inverse() * p_W;
      *xy = p_C.head<2>() / p_C.z() + Eigen::Vector2d(pixel_noise(random), pixel_noise(random));
      return p_C.z() > 0.5 && std::abs(xy->x()) < 0.95 && std::abs(xy->y()) < 0.7;
    };
    inverse_depths.reserve(80);
    while (inverse_depths.size() < 80) {
      const Eigen::Vector3d p_W(7.0 + 2.0 * unit(random), 1.0 + 4.0 * unit(random),
                                -2.0 + 2.0 * unit(random));
      Eigen::Vector2d anchor_xy;
      if (!sees(truth[0] * rig.X_IL, p_W, &anchor_xy)) continue;
      inverse_depths.push_back(1.2 / ((truth[0] * rig.X_IL).inverse() * p_W).z());  // 20 % too near
      double* lambda = &inverse_depths.back();
      Eigen::Vector2d xy;
      if (sees(truth[0] * X_IR, p_W, &xy)) {
        visual.push_back({std::make_unique<StereoFactor>(anchor_xy, xy, rig.baseline_m, sqrt_information),
                          nullptr,
                          {lambda}});
      }
      for (int k = 1; k < kKeyframes; ++k) {
        for (const Eigen::Isometry3d* X_IC : {&rig.X_IL, &X_IR}) {
          if (!sees(truth[k] * *X_IC, p_W, &xy)) continue;
          visual.push_back(
              {std::make_unique<ReprojectionFactor>(anchor_xy, xy, rig.X_IL, *X_IC, sqrt_information),
               std::make_unique<ceres::HuberLoss>(1.0),
               {poses[0].data(), poses[k].data(), lambda}});
        }
      }
    }
  }

  static ceres::Problem::Options Borrowing() {
    ceres::Problem::Options options;
    options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    return options;
  }

  void AddStates(ceres::Problem* problem, int first = 0) {
    for (int k = first; k < kKeyframes; ++k) {
      problem->AddParameterBlock(poses[k].data(), kPoseSize, &manifold);
      problem->AddParameterBlock(speed_biases[k].data(), kSpeedBiasSize);
    }
  }
  static void Add(ceres::Problem* problem, const Block& block) {
    problem->AddResidualBlock(block.cost.get(), block.loss.get(), block.parameters);
  }

  std::vector<Eigen::Isometry3d> truth;
  std::vector<std::vector<double>> poses, speed_biases;
  std::vector<double> inverse_depths;
  std::vector<Block> imu, visual;
  PoseManifold manifold;
};

ceres::Solver::Summary SolveTightly(ceres::Problem* problem) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = 100;
  options.function_tolerance = 1e-16;
  options.gradient_tolerance = 1e-16;
  options.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  ceres::Solve(options, problem, &summary);
  return summary;
}

// With exact data the IMU, reprojection and stereo factors together bring every pose back to within a
// millimetre and 0.01° (the first pose held: it fixes the four directions VIO cannot observe). Ceres
// converges in 8 iterations from a cost of 7e5.
TEST(FactorsTest, IMUAndStereoFactorsRecoverAKnownTrajectory) {
  SyntheticWindow w(0.0);
  ceres::Problem problem(SyntheticWindow::Borrowing());
  w.AddStates(&problem);
  problem.SetParameterBlockConstant(w.poses[0].data());
  for (const auto& block : w.imu) SyntheticWindow::Add(&problem, block);
  for (const auto& block : w.visual) SyntheticWindow::Add(&problem, block);
  ASSERT_GT(w.visual.size(), 80u * 2 * (SyntheticWindow::kKeyframes - 1) * 8 / 10);
  const ceres::Solver::Summary summary = SolveTightly(&problem);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.FullReport();
  for (int k = 0; k < SyntheticWindow::kKeyframes; ++k) {
    const Eigen::Isometry3d X = PoseFromBlock(w.poses[k].data());
    EXPECT_LT((X.translation() - w.truth[k].translation()).norm(), 1e-3) << "keyframe " << k;
    EXPECT_LT(Log(Eigen::Matrix3d(w.truth[k].linear().transpose() * X.linear())).norm(), 0.01 * M_PI / 180.0)
        << "keyframe " << k;
    EXPECT_LT((Eigen::Vector3d(w.speed_biases[k].data()) -
               KnownMotion::State(k * SyntheticWindow::kGap_s).v_WI_W_mps)
                  .norm(),
              2e-3)
        << "keyframe " << k;
  }
}

TEST(FactorsTest, StatePriorJacobiansMatchNumericDifferentiation) {
  const NavState prior = KnownMotion::State(0.4);
  const StatePriorFactor factor(prior, {{0.01, 0.0, -0.01}, {0.1, 0.2, 0.0}},
                                {0.01, 0.02, 0.03, 0.1, 0.01, 0.1});
  const NavState at = KnownMotion::State(0.6);
  ExpectJacobiansMatchNumericDifferentiation(
      factor, {PoseBlock(at.p_WI_m, at.q_WI), {0.1, 0.2, 0.3, 0.011, 0.002, -0.004, 0.05, 0.1, 0.02}},
      {true, false});
}

// The joints of two sub-aircraft on the platform of KnownMotion, the first with its IMU 5 cm from its joint
// and an attitude of its own (a spherical joint leaves it free), at time t.
struct TwoJoints {
  Eigen::Vector3d d_i{0.6, 0.2, -0.05}, d_o{-0.4, 0.5, 0.0};  // in P
  Eigen::Vector3d p_IJ{0.01, -0.02, 0.05};
  Eigen::Vector3d w_I{0.3, -0.2, 0.5};  // the sub-aircraft's own rate
  NavState i;                           // sub-aircraft i's IMU
  PeerJoint o;                          // o's joint, exact
  double link_m() const { return (d_i - d_o).norm(); }
  explicit TwoJoints(double t) {
    const Eigen::Isometry3d X_WP = KnownMotion::Pose(t);
    const Eigen::Vector3d w_P = KnownMotion::Kinematics(t).w_WB_B_radps;
    const auto joint = [&](const Eigen::Vector3d& d) {
      return PeerJoint{X_WP * d, KnownMotion::Velocity(t) + X_WP.linear() * w_P.cross(d)};
    };
    const PeerJoint J_i = joint(d_i);
    o = joint(d_o);
    i.q_WI = ExpQuaternion(Eigen::Vector3d(0.1, -0.15, 2.0));
    i.p_WI_m = J_i.p_WJ_m - i.q_WI * p_IJ;
    i.v_WI_W_mps = J_i.v_WJ_W_mps - i.q_WI * w_I.cross(p_IJ);
  }
  std::vector<double> SpeedBias() const {
    return {i.v_WI_W_mps.x(), i.v_WI_W_mps.y(), i.v_WI_W_mps.z(), 0, 0, 0, 0, 0, 0};
  }
};

std::vector<double> Residuals(const ceres::CostFunction& factor,
                              const std::vector<std::vector<double>>& blocks) {
  std::vector<const double*> pointers;
  for (const auto& b : blocks) pointers.push_back(b.data());
  std::vector<double> r(factor.num_residuals());
  EXPECT_TRUE(factor.Evaluate(pointers.data(), r.data(), nullptr));
  return r;
}

// Two joints of a rigid body in motion satisfy both constraints exactly, with the other's drift undone by the
// drift block; an error along the link shows in r_kp in units of σ_l.
TEST(FactorsTest, KinematicFactorIsZeroOnARigidPlatformAndUndoesADrift) {
  for (double t : {0.0, 0.7, 2.3}) {
    const TwoJoints w(t);
    const Eigen::Vector3d centre(0.5, -1.0, -2.0);
    const KinematicFactor exact(w.p_IJ, w.w_I, w.o, centre, w.link_m(), 0.04, 0.1);
    const std::vector<double> pose = PoseBlock(w.i.p_WI_m, w.i.q_WI);
    for (double r : Residuals(exact, {pose, w.SpeedBias(), {0, 0, 0, 0}})) EXPECT_NEAR(r, 0.0, 1e-12);
    // The other's odometry has drifted: its truth is Rz(0.2) (x − c) + c + (0.3, −0.1, 0.05) of what it
    // shares.
    const Eigen::Matrix3d Rz = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d dp(0.3, -0.1, 0.05);
    const PeerJoint drifted{Rz.transpose() * (w.o.p_WJ_m - dp - centre) + centre,
                            Rz.transpose() * w.o.v_WJ_W_mps};
    const KinematicFactor after_drift(w.p_IJ, w.w_I, drifted, centre, w.link_m(), 0.04, 0.1);
    for (double r : Residuals(after_drift, {pose, w.SpeedBias(), {0.3, -0.1, 0.05, 0.2}}))
      EXPECT_NEAR(r, 0.0, 1e-12);
    const std::vector<double> undone = Residuals(after_drift, {pose, w.SpeedBias(), {0, 0, 0, 0}});
    EXPECT_GT(std::hypot(undone[0], undone[1]), 0.5);
    // 1 cm further apart along the link: r_kp = 0.01 / 0.04; r_kv still zero (a parallel shift moves
    // nothing).
    const Eigen::Vector3d along = (w.i.p_WI_m + w.i.q_WI * w.p_IJ - w.o.p_WJ_m).normalized();
    const std::vector<double> apart = PoseBlock(w.i.p_WI_m + 0.01 * along, w.i.q_WI);
    const std::vector<double> r = Residuals(exact, {apart, w.SpeedBias(), {0, 0, 0, 0}});
    EXPECT_NEAR(r[0], 0.25, 1e-9);
    EXPECT_NEAR(r[1], 0.0, 1e-12);
  }
}

TEST(FactorsTest, PhysicalFactorJacobiansMatchNumericDifferentiation) {
  const TwoJoints w(0.9);
  const KinematicFactor kinematic(w.p_IJ, w.w_I, w.o, Eigen::Vector3d(0.5, 1.0, -2.0), w.link_m() + 0.03,
                                  0.04, 0.1);
  std::vector<double> sb = w.SpeedBias();
  sb[0] += 0.1;
  sb[3] = 0.02;
  sb[5] = -0.01;
  ExpectJacobiansMatchNumericDifferentiation(
      kinematic, {PoseBlock(w.i.p_WI_m, w.i.q_WI), sb, {0.05, -0.02, 0.01, 0.15}}, {true, false, false});
  const AttitudeFactor attitude(w.i.q_WI * ExpQuaternion(Eigen::Vector3d(0.02, -0.01, 0.3)), 0.01);
  ExpectJacobiansMatchNumericDifferentiation(attitude, {PoseBlock(w.i.p_WI_m, w.i.q_WI)}, {true});
  const DriftPriorFactor drift(Eigen::Vector4d(0.01, 0.02, -0.03, 0.05), 0.05, 0.1);
  ExpectJacobiansMatchNumericDifferentiation(drift, {{0.0, 0.1, 0.0, -0.2}}, {false});
}

// r_kq sees the tilt and not the yaw: a measured attitude turned about W's z leaves it at zero; one tilted by
// σ_att gives a residual of norm 1.
TEST(FactorsTest, AttitudeFactorSeesTiltNotYaw) {
  const Eigen::Quaterniond q_WI = ExpQuaternion(Eigen::Vector3d(0.2, -0.1, 1.0));
  const std::vector<double> pose = PoseBlock(Eigen::Vector3d::Zero(), q_WI);
  const AttitudeFactor yawed(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()) * q_WI, 0.01);
  for (double r : Residuals(yawed, {pose})) EXPECT_NEAR(r, 0.0, 1e-12);
  const AttitudeFactor tilted(Eigen::AngleAxisd(0.01, Eigen::Vector3d(1, 1, 0).normalized()) * q_WI, 0.01);
  const std::vector<double> r = Residuals(tilted, {pose});
  EXPECT_NEAR(Eigen::Vector3d(r[0], r[1], r[2]).norm(), 1.0, 1e-4);
}

// Marginalising the first keyframe (its pose, velocity and biases and the depths anchored in it) at the
// batch optimum must leave that optimum where it was: the prior's gradient there is the marginalised
// residuals' reduced gradient, so the remaining problem, started elsewhere, comes back to the same states.
// With pixel noise, so that the optimum is not the truth and every residual is non-zero.
TEST(FactorsTest, MarginalisingTheFirstKeyframeKeepsTheBatchOptimum) {
  SyntheticWindow w(0.5);
  const StatePriorFactor first_state(KnownMotion::State(0.0), {}, {});
  ceres::Problem batch(SyntheticWindow::Borrowing());
  w.AddStates(&batch);
  batch.AddResidualBlock(const_cast<StatePriorFactor*>(&first_state), nullptr, w.poses[0].data(),
                         w.speed_biases[0].data());
  for (const auto& block : w.imu) SyntheticWindow::Add(&batch, block);
  for (const auto& block : w.visual) SyntheticWindow::Add(&batch, block);
  ASSERT_TRUE(SolveTightly(&batch).IsSolutionUsable());
  const auto optimum_poses = w.poses;
  const auto optimum_speed_biases = w.speed_biases;

  std::vector<LinearisedBlock> touching{
      {&first_state, nullptr, {w.poses[0].data(), w.speed_biases[0].data()}},
      {w.imu[0].cost.get(), nullptr, w.imu[0].parameters}};
  for (const auto& block : w.visual)
    touching.push_back({block.cost.get(), block.loss.get(), block.parameters});
  std::vector<ParameterInfo> parameters;
  for (int k = 0; k < SyntheticWindow::kKeyframes; ++k) {
    parameters.push_back({w.poses[k].data(), kPoseSize, true});
    parameters.push_back({w.speed_biases[k].data(), kSpeedBiasSize, false});
  }
  std::vector<double*> marginalised{w.poses[0].data(), w.speed_biases[0].data()};
  for (double& lambda : w.inverse_depths) {
    parameters.push_back({&lambda, 1, false});
    marginalised.push_back(&lambda);
  }
  const auto prior = std::make_shared<MarginalPrior>(Marginalise(touching, parameters, marginalised));
  ASSERT_EQ(prior->blocks.size(), 10u);  // the other nine poses and the second keyframe's speed and biases

  // Away from the optimum by a centimetre, half a degree and 5 cm/s.
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int k = 1; k < SyntheticWindow::kKeyframes; ++k) {
    double delta[6];
    for (int a = 0; a < 3; ++a) delta[a] = 0.01 * unit(random);
    for (int a = 3; a < 6; ++a) delta[a] = 0.5 * M_PI / 180.0 * unit(random);
    std::vector<double> moved(kPoseSize);
    w.manifold.Plus(w.poses[k].data(), delta, moved.data());
    w.poses[k] = moved;
    for (int a = 0; a < 3; ++a) w.speed_biases[k][a] += 0.05 * unit(random);
  }
  const MarginalPriorFactor prior_factor(prior);
  std::vector<std::vector<double>> prior_blocks;
  std::vector<bool> prior_is_pose;
  for (const ParameterInfo& block : prior->blocks) {
    prior_blocks.emplace_back(block.values, block.values + block.ambient_size);
    prior_is_pose.push_back(block.is_pose);
  }
  ExpectJacobiansMatchNumericDifferentiation(prior_factor, prior_blocks, prior_is_pose);

  ceres::Problem reduced(SyntheticWindow::Borrowing());
  w.AddStates(&reduced, 1);
  std::vector<double*> prior_parameters;
  for (const ParameterInfo& block : prior->blocks) prior_parameters.push_back(block.values);
  reduced.AddResidualBlock(const_cast<MarginalPriorFactor*>(&prior_factor), nullptr, prior_parameters);
  for (std::size_t k = 1; k < w.imu.size(); ++k) SyntheticWindow::Add(&reduced, w.imu[k]);
  ASSERT_TRUE(SolveTightly(&reduced).IsSolutionUsable());
  for (int k = 1; k < SyntheticWindow::kKeyframes; ++k) {
    const Eigen::Isometry3d X = PoseFromBlock(w.poses[k].data()),
                            X_opt = PoseFromBlock(optimum_poses[k].data());
    EXPECT_LT((X.translation() - X_opt.translation()).norm(), 1e-6) << "keyframe " << k;
    EXPECT_LT(Log(Eigen::Matrix3d(X_opt.linear().transpose() * X.linear())).norm(), 1e-6) << "keyframe " << k;
    for (int a = 0; a < kSpeedBiasSize; ++a)
      EXPECT_NEAR(w.speed_biases[k][a], optimum_speed_biases[k][a], 1e-6);
  }
  // The batch optimum is not the truth (pixel noise), so agreeing with it is not agreeing with the truth.
  EXPECT_GT((PoseFromBlock(optimum_poses[5].data()).translation() - w.truth[5].translation()).norm(), 1e-5);

  // And the prior carries the curvature: what remains is as uncertain as in the batch (the Schur complement
  // is the inverse of the marginal covariance), checked with Ceres's own covariance of both problems.
  const double* pose5 = w.poses[5].data();
  const double* speed_bias9 = w.speed_biases[9].data();
  auto covariance = [&](ceres::Problem* problem, const double* block, int size) {
    ceres::Covariance::Options options;
    options.algorithm_type = ceres::DENSE_SVD;
    ceres::Covariance c(options);
    const std::vector<std::pair<const double*, const double*>> pairs{{block, block}};
    EXPECT_TRUE(c.Compute(pairs, problem));
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> row_major(size, size);
    c.GetCovarianceBlockInTangentSpace(block, block, row_major.data());
    return Eigen::MatrixXd(row_major);
  };
  const Eigen::MatrixXd pose_batch = covariance(&batch, pose5, kPoseTangentSize);
  const Eigen::MatrixXd pose_reduced = covariance(&reduced, pose5, kPoseTangentSize);
  EXPECT_LT((pose_batch - pose_reduced).norm(), 1e-6 * pose_batch.norm());  // measured: 1e-9
  const Eigen::MatrixXd speed_bias_batch = covariance(&batch, speed_bias9, kSpeedBiasSize);
  const Eigen::MatrixXd speed_bias_reduced = covariance(&reduced, speed_bias9, kSpeedBiasSize);
  EXPECT_LT((speed_bias_batch - speed_bias_reduced).norm(), 1e-6 * speed_bias_batch.norm());
}

}  // namespace
}  // namespace iapsim::vio
