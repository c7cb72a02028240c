#include "control/admittance.h"

#include <gtest/gtest.h>

#include <cmath>

#include "control/control_config.h"

namespace iapsim::control {
namespace {

// e(t) of M ë + D ė + K e = F from rest, F switched on at 0
double StepResponse(double M, double D, double K, double F, double t) {
  const double wn = std::sqrt(K / M), zeta = D / (2.0 * std::sqrt(K * M)), e_inf = F / K;
  if (std::abs(zeta - 1.0) < 1e-12) return e_inf * (1.0 - std::exp(-wn * t) * (1.0 + wn * t));
  if (zeta < 1.0) {
    const double wd = wn * std::sqrt(1.0 - zeta * zeta);
    return e_inf * (1.0 - std::exp(-zeta * wn * t) * (std::cos(wd * t) + zeta * wn / wd * std::sin(wd * t)));
  }
  const double r1 = -wn * (zeta - std::sqrt(zeta * zeta - 1.0)), r2 = -wn * (zeta + std::sqrt(zeta * zeta - 1.0));
  return e_inf * (1.0 + (r2 * std::exp(r1 * t) - r1 * std::exp(r2 * t)) / (r1 - r2));
}

PoseReference Moving(double t) {  // a smooth nominal motion with every derivative non-zero
  const Eigen::Vector3d p(std::sin(t), 0.5 * t * t, -2.0 + std::cos(2 * t));
  const Eigen::Vector3d v(std::cos(t), t, -2 * std::sin(2 * t));
  const Eigen::Vector3d a(-std::sin(t), 1.0, -4 * std::cos(2 * t));
  const Eigen::Vector3d rpy(0.2 * std::sin(t), 0.1 + 0.1 * t, 0.5 * std::cos(t));
  const Eigen::Vector3d drpy(0.2 * std::cos(t), 0.1, -0.5 * std::sin(t));
  const Eigen::Vector3d ddrpy(-0.2 * std::sin(t), 0.0, -0.5 * std::cos(t));
  return ReferenceFromEuler(p, v, a, rpy, drpy, ddrpy);
}

TEST(Admittance, StepResponseIsTheAnalyticMassDamperSpring) {
  AdmittanceConfig config;
  config.mass << 1, 1, 1, 2, 0.5, 1;
  // over-damped (Table IV, ζ 1.414), critically damped, under-damped; the same three again for the angles
  config.damping << 28.28, 20, 5, 2 * std::sqrt(2 * 25.0) * 1.5, 2 * std::sqrt(0.5 * 25.0), 3;
  config.stiffness << 100, 100, 100, 25, 25, 100;
  config.max_offset_m = config.max_offset_rad = 100.0;
  const double dt_s = 0.005;
  Admittance admittance(config, dt_s);
  const Vector6d wrench_W = (Vector6d() << 2, -3, 1, 0.5, -0.25, 0.4).finished();
  double max_error = 0.0;
  for (int k = 1; k <= 2000; ++k) {
    admittance.Update(PoseReference(), wrench_W);
    for (int i = 0; i < 6; ++i) {
      const double expected = StepResponse(config.mass[i], config.damping[i], config.stiffness[i], wrench_W[i], k * dt_s);
      max_error = std::max(max_error, std::abs(admittance.offset()[i] - expected));
    }
  }
  EXPECT_LT(max_error, 1e-12);
  // and it settles at F/K
  EXPECT_TRUE(admittance.offset().isApprox(wrench_W.cwiseQuotient(config.stiffness), 1e-6));
  EXPECT_EQ(admittance.saturated_updates(), 0u);
}

TEST(Admittance, NoWrenchLeavesTheReferenceUnchanged) {
  Admittance admittance(AdmittanceConfig(), 0.005);
  for (double t = 0.0; t < 2.0; t += 0.005) {
    const PoseReference nominal = Moving(t);
    const PoseReference revised = admittance.Update(nominal, Vector6d::Zero());
    EXPECT_TRUE(revised.p_WP_m.isApprox(nominal.p_WP_m, 1e-12));
    EXPECT_TRUE(revised.v_WP_W_mps.isApprox(nominal.v_WP_W_mps, 1e-12));
    EXPECT_TRUE(revised.a_WP_W_mps2.isApprox(nominal.a_WP_W_mps2, 1e-12));
    EXPECT_LT(revised.q_WP.angularDistance(nominal.q_WP), 1e-12);
    EXPECT_LT((revised.w_WP_P_radps - nominal.w_WP_P_radps).norm(), 1e-12);
    EXPECT_LT((revised.dw_WP_P_radps2 - nominal.dw_WP_P_radps2).norm(), 1e-12);
  }
}

TEST(Admittance, RevisedDerivativesMatchFiniteDifferences) {
  const double dt_s = 1e-4;
  Admittance admittance(AdmittanceConfig(), dt_s);
  std::vector<PoseReference> revised;
  for (int k = 0; k < 3000; ++k) {
    const double t = k * dt_s;
    const Vector6d wrench_W = (Vector6d() << 5 * std::sin(3 * t), 4, -2 * std::cos(t), 1, 3 * std::sin(5 * t), -2)
                                  .finished();
    revised.push_back(admittance.Update(Moving(t), wrench_W));
  }
  double v_error = 0, a_error = 0, w_error = 0, dw_error = 0;
  for (size_t k = 1; k + 1 < revised.size(); ++k) {
    const PoseReference &before = revised[k - 1], &now = revised[k], &after = revised[k + 1];
    v_error = std::max(v_error, ((after.p_WP_m - before.p_WP_m) / (2 * dt_s) - now.v_WP_W_mps).norm());
    a_error = std::max(a_error, ((after.v_WP_W_mps - before.v_WP_W_mps) / (2 * dt_s) - now.a_WP_W_mps2).norm());
    const Eigen::AngleAxisd turn(before.q_WP.conjugate() * after.q_WP);  // in the body frame
    w_error = std::max(w_error, (turn.angle() * turn.axis() / (2 * dt_s) - now.w_WP_P_radps).norm());
    dw_error = std::max(
        dw_error, ((after.w_WP_P_radps - before.w_WP_P_radps) / (2 * dt_s) - now.dw_WP_P_radps2).norm());
  }
  // O(dt²) for the smooth parts; the input held over each step leaves an O(dt·dF/dt / M) kink in ë
  EXPECT_LT(v_error, 1e-6);
  EXPECT_LT(w_error, 1e-6);
  EXPECT_LT(a_error, 2e-3);
  EXPECT_LT(dw_error, 2e-3);
  EXPECT_GT(admittance.offset().norm(), 0.01);  // it did move the reference
}

TEST(Admittance, OffsetsSaturateAndAreCounted) {
  AdmittanceConfig config;
  config.max_offset_m = 0.1;
  config.max_offset_rad = 0.2;
  Admittance admittance(config, 0.005);
  PoseReference revised;
  for (int k = 0; k < 400; ++k) revised = admittance.Update(PoseReference(), Vector6d::Constant(1000.0));
  EXPECT_NEAR(revised.p_WP_m.x(), 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(admittance.offset()[4], 0.2);
  EXPECT_EQ(admittance.offset_rate()[0], 0.0);
  EXPECT_GT(admittance.saturated_updates(), 300u);
  admittance.Update(PoseReference(), Vector6d::Constant(NAN));
  EXPECT_EQ(admittance.rejected_updates(), 1u);
  EXPECT_THROW(Admittance(config, 0.0), std::invalid_argument);
}

TEST(Admittance, EulerFromReferenceInvertsReferenceFromEuler) {
  const PoseReference reference = Moving(0.7);
  Eigen::Vector3d rpy, drpy, ddrpy;
  EulerFromReference(reference, &rpy, &drpy, &ddrpy);
  EXPECT_TRUE(rpy.isApprox(Eigen::Vector3d(0.2 * std::sin(0.7), 0.17, 0.5 * std::cos(0.7)), 1e-12));
  EXPECT_TRUE(drpy.isApprox(Eigen::Vector3d(0.2 * std::cos(0.7), 0.1, -0.5 * std::sin(0.7)), 1e-12));
  EXPECT_TRUE(ddrpy.isApprox(Eigen::Vector3d(-0.2 * std::sin(0.7), 0.0, -0.5 * std::cos(0.7)), 1e-12));
}

TEST(Admittance, ReadsItsSection) {
  bridge::YamlMap params(YAML::Load("admittance: {stiffness: [1, 2, 3, 4, 5, 6], max_offset_deg: 10}"), "s.yaml");
  const AdmittanceConfig config = ReadAdmittanceConfig(params);
  EXPECT_EQ(config.stiffness[5], 6.0);
  EXPECT_EQ(config.damping[4], 14.14);  // Table IV
  EXPECT_NEAR(config.max_offset_rad, 10 * M_PI / 180, 1e-15);
  bridge::YamlMap bad(YAML::Load("admittance: {mass: [1, 1, 0, 1, 1, 1]}"), "s.yaml");
  EXPECT_THROW(ReadAdmittanceConfig(bad), bridge::ConfigError);
  bridge::YamlMap unknown(YAML::Load("admittance: {springs: 3}"), "s.yaml");
  EXPECT_THROW(ReadAdmittanceConfig(unknown), bridge::ConfigError);
}

}  // namespace
}  // namespace iapsim::control
