#include "vio/imu_preintegration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "vio/so3.h"
#include "vio/testing/synthetic.h"

namespace iapsim::vio {
namespace {

using testing::KnownMotion;
const Eigen::Vector3d kGravity_W = testing::GravityW();

ImuPreintegration Integrate(double t0, double duration_s, double rate_hz, const ImuBiases& biases = {},
                            const sensors::ImuNoise& noise = sensors::TableViNoise()) {
  const int samples = static_cast<int>(std::lround(duration_s * rate_hz));
  const double dt = duration_s / samples;
  ImuPreintegration preintegration(KnownMotion::Sample(t0), biases, noise);
  for (int k = 1; k <= samples; ++k) preintegration.Integrate(dt, KnownMotion::Sample(t0 + k * dt));
  return preintegration;
}

struct PredictionError {
  double rotation_rad, velocity_mps, position_m;
};

PredictionError ErrorOverOneSecond(double rate_hz) {
  const double t0 = 0.3, t1 = 1.3;
  const ImuPreintegration preintegration = Integrate(t0, t1 - t0, rate_hz);
  const NavState predicted = preintegration.Predict(KnownMotion::State(t0), {}, kGravity_W);
  const NavState truth = KnownMotion::State(t1);
  return {Log(Eigen::Quaterniond(truth.q_WI.conjugate() * predicted.q_WI)).norm(),
          (predicted.v_WI_W_mps - truth.v_WI_W_mps).norm(), (predicted.p_WI_m - truth.p_WI_m).norm()};
}

TEST(ImuPreintegrationTest, PredictsAKnownMotionAndConvergesAtSecondOrder) {
  const PredictionError at_200_hz = ErrorOverOneSecond(200.0);
  const PredictionError at_1000_hz = ErrorOverOneSecond(1000.0);
  // The paper's IMU rate: micrometres over a 1 s keyframe gap (measured 0.6 µrad, 4.4 µm/s, 1.8 µm), far
  // below a stereo camera's depth noise.
  EXPECT_LT(at_200_hz.rotation_rad, 2e-6);
  EXPECT_LT(at_200_hz.velocity_mps, 1e-5);
  EXPECT_LT(at_200_hz.position_m, 5e-6);
  // The midpoint rule is second order: five times the rate, about 25 times less error.
  EXPECT_GT(at_200_hz.rotation_rad / at_1000_hz.rotation_rad, 15.0);
  EXPECT_GT(at_200_hz.velocity_mps / at_1000_hz.velocity_mps, 15.0);
  EXPECT_GT(at_200_hz.position_m / at_1000_hz.position_m, 15.0);
}

TEST(ImuPreintegrationTest, ResidualIsZeroOnItsOwnPredictionAndSeesAnOffset) {
  const ImuBiases biases{{0.01, -0.02, 0.005}, {0.1, 0.05, -0.2}};
  const ImuPreintegration preintegration = Integrate(0.0, 0.25, 200.0, biases);
  const NavState state_i = KnownMotion::State(0.0);
  NavState state_j = preintegration.Predict(state_i, biases, kGravity_W);
  EXPECT_LT(preintegration.Residual(state_i, state_j, biases, kGravity_W).norm(), 1e-12);
  state_j.p_WI_m += state_i.q_WI * Eigen::Vector3d(0.01, 0.0, 0.0);
  const Vector9d r = preintegration.Residual(state_i, state_j, biases, kGravity_W);
  EXPECT_NEAR(r(6), 0.01, 1e-12);
  EXPECT_LT(r.head<6>().norm(), 1e-12);
}

// [δφ, δv, δp] of `perturbed` against `nominal`, in the preintegration's error convention.
Vector9d DeltaError(const ImuDelta& nominal, const ImuDelta& perturbed) {
  Vector9d e;
  e << Log(Eigen::Matrix3d(nominal.delta_R.transpose() * perturbed.delta_R)),
      perturbed.delta_v_mps - nominal.delta_v_mps, perturbed.delta_p_m - nominal.delta_p_m;
  return e;
}

TEST(ImuPreintegrationTest, BiasJacobiansMatchCentralDifferencesOfTheIntegration) {
  const ImuBiases biases{{0.02, -0.01, 0.03}, {0.2, -0.1, 0.15}};
  ImuPreintegration preintegration = Integrate(0.2, 0.5, 200.0, biases);
  const Matrix93d J_bg = preintegration.jacobian_gyroscope_bias();
  const Matrix93d J_ba = preintegration.jacobian_accelerometer_bias();
  const ImuDelta nominal = preintegration.delta();
  const double eps = 1e-6;
  for (int bias = 0; bias < 2; ++bias) {
    for (int axis = 0; axis < 3; ++axis) {
      ImuBiases plus = biases, minus = biases;
      Eigen::Vector3d& p = bias == 0 ? plus.gyroscope_radps : plus.accelerometer_mps2;
      Eigen::Vector3d& m = bias == 0 ? minus.gyroscope_radps : minus.accelerometer_mps2;
      p(axis) += eps;
      m(axis) -= eps;
      preintegration.Repropagate(plus);
      const Vector9d e_plus = DeltaError(nominal, preintegration.delta());
      preintegration.Repropagate(minus);
      const Vector9d e_minus = DeltaError(nominal, preintegration.delta());
      const Vector9d numeric = (e_plus - e_minus) / (2.0 * eps);
      const Vector9d analytic = bias == 0 ? Vector9d(J_bg.col(axis)) : Vector9d(J_ba.col(axis));
      EXPECT_LT((numeric - analytic).norm(), 1e-6 * (1.0 + analytic.norm()))
          << "bias " << bias << " axis " << axis << "\nnumeric " << numeric.transpose() << "\nanalytic "
          << analytic.transpose();
    }
  }
}

TEST(ImuPreintegrationTest, FirstOrderBiasCorrectionAgreesWithIntegratingAgain) {
  const ImuBiases linearised{};
  const ImuBiases moved{{0.003, -0.002, 0.004}, {0.05, -0.04, 0.03}};
  ImuPreintegration preintegration = Integrate(0.0, 0.5, 200.0, linearised);
  const ImuDelta corrected = preintegration.Corrected(moved);
  preintegration.Repropagate(moved);
  const Vector9d error = DeltaError(preintegration.delta(), corrected);
  // Second order in the bias change: (4e-3 rad/s · 0.5 s)² ≈ 4e-6 rad, and ~1e-5 m.
  EXPECT_LT(error.head<3>().norm(), 1e-5);
  EXPECT_LT(error.segment<3>(3).norm(), 1e-4);
  EXPECT_LT(error.tail<3>().norm(), 3e-5);
  EXPECT_GT(DeltaError(preintegration.delta(), Integrate(0.0, 0.5, 200.0).delta()).norm(), 1e-3);  // it moved
}

// The covariance against a Monte Carlo of the noisy IMU the sensors process samples (Table VI's densities at
// 200 Hz, biases held constant): the standard deviation of each error component within 10 %.
TEST(ImuPreintegrationTest, CovarianceMatchesAMonteCarloOfTheNoisyImu) {
  sensors::ImuConfig config;
  config.noise.gyroscope_random_walk = 0.0;
  config.noise.accelerometer_random_walk = 0.0;
  const double t0 = 0.1, rate_hz = 200.0;
  const int samples = 100;
  const double dt = 1.0 / rate_hz;
  const ImuDelta nominal = Integrate(t0, samples * dt, rate_hz).delta();
  Matrix9d predicted = Matrix9d::Zero();
  Matrix9d empirical = Matrix9d::Zero();
  const int trials = 2000;
  for (int trial = 0; trial < trials; ++trial) {
    sensors::ImuModel imu(config, 1000 + trial);
    ImuPreintegration preintegration(imu.Sample(KnownMotion::Kinematics(t0), dt), {}, config.noise);
    for (int k = 1; k <= samples; ++k)
      preintegration.Integrate(dt, imu.Sample(KnownMotion::Kinematics(t0 + k * dt), dt));
    const Vector9d e = DeltaError(nominal, preintegration.delta());
    empirical += e * e.transpose() / trials;
    predicted = preintegration.covariance();
  }
  for (int i = 0; i < 9; ++i) {
    EXPECT_NEAR(std::sqrt(empirical(i, i)) / std::sqrt(predicted(i, i)), 1.0, 0.1) << "component " << i;
  }
  // Cross terms too: velocity and position errors are strongly correlated along each axis.
  for (int axis = 0; axis < 3; ++axis) {
    const double predicted_correlation =
        predicted(3 + axis, 6 + axis) /
        std::sqrt(predicted(3 + axis, 3 + axis) * predicted(6 + axis, 6 + axis));
    const double empirical_correlation =
        empirical(3 + axis, 6 + axis) /
        std::sqrt(empirical(3 + axis, 3 + axis) * empirical(6 + axis, 6 + axis));
    EXPECT_GT(predicted_correlation, 0.5);
    EXPECT_NEAR(empirical_correlation, predicted_correlation, 0.05) << "axis " << axis;
  }
}

TEST(So3Test, ExpLogAndTheRightJacobianAgreeWithTheirDefinitions) {
  const Eigen::Vector3d phi(0.4, -1.2, 0.7);
  EXPECT_LT((Log(Exp(phi)) - phi).norm(), 1e-12);
  EXPECT_LT((Log(Exp(Eigen::Vector3d(1e-9, 0, 0))) - Eigen::Vector3d(1e-9, 0, 0)).norm(), 1e-20);
  const Eigen::Vector3d delta(1e-6, -2e-6, 0.5e-6);
  const Eigen::Matrix3d left = Exp(phi + delta);
  const Eigen::Matrix3d right = Exp(phi) * Exp(RightJacobian(phi) * delta);
  EXPECT_LT((left - right).norm(), 1e-11);
  EXPECT_LT((RightJacobian(phi) * RightJacobianInverse(phi) - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_LT((Skew(phi) * delta - phi.cross(delta)).norm(), 1e-18);
}

}  // namespace
}  // namespace iapsim::vio
