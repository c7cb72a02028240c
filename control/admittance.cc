#include "control/admittance.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unsupported/Eigen/MatrixFunctions>

namespace iapsim::control {

Admittance::Admittance(const AdmittanceConfig& config, double dt_s) : config_(config) {
  if (!(dt_s > 0.0) || !(config.mass.array() > 0.0).all() || !(config.damping.array() >= 0.0).all() ||
      !(config.stiffness.array() >= 0.0).all() || !(config.max_offset_m >= 0.0) || !(config.max_offset_rad >= 0.0)) {
    throw std::invalid_argument(
        "Admittance: dt_s and masses must be positive, damping, stiffness and offset limits non-negative");
  }
  offset_limit_ << Eigen::Vector3d::Constant(config.max_offset_m), Eigen::Vector3d::Constant(config.max_offset_rad);
  for (int i = 0; i < 6; ++i) {
    // ẋ = Ax + Bu with x = (e, ė), u = F; exp([A B; 0 0]·Δt) = [Φ Γ; 0 1] is the exact zero-order-hold map
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    M(0, 1) = 1.0;
    M(1, 0) = -config.stiffness[i] / config.mass[i];
    M(1, 1) = -config.damping[i] / config.mass[i];
    M(1, 2) = 1.0 / config.mass[i];
    const Eigen::Matrix3d E = (M * dt_s).exp();
    Phi_.row(i) << E(0, 0), E(0, 1), E(1, 0), E(1, 1);
    Gamma_.row(i) << E(0, 2), E(1, 2);
  }
}

void Admittance::Reset() {
  offset_.setZero();
  offset_rate_.setZero();
  offset_accel_.setZero();
}

PoseReference Admittance::Update(const PoseReference& nominal, const Vector6d& wrench_W) {
  if (!wrench_W.allFinite()) {
    ++rejected_;
  } else {
    // (19) per axis. The paper drives the Euler-angle offsets with the torque about W's axes directly; the
    // torque conjugate to the Euler angles would be Eᵀ R̄ᵀ τ_W (E: Euler rates to body rates). The two agree
    // near level flight, which is where the seed uses this law (a horizontal pole, §VI-E); kept as written.
    const Vector6d e = offset_, de = offset_rate_;
    offset_ = Phi_.col(0).cwiseProduct(e) + Phi_.col(1).cwiseProduct(de) + Gamma_.col(0).cwiseProduct(wrench_W);
    offset_rate_ =
        Phi_.col(2).cwiseProduct(e) + Phi_.col(3).cwiseProduct(de) + Gamma_.col(1).cwiseProduct(wrench_W);
    // a limit holds the offset at the edge, stopped there
    bool saturated = false;
    for (int i = 0; i < 6; ++i) {
      if (std::abs(offset_[i]) > offset_limit_[i]) {
        offset_[i] = std::copysign(offset_limit_[i], offset_[i]);
        offset_rate_[i] = 0.0;
        saturated = true;
      }
    }
    if (saturated) ++saturated_;
    offset_accel_ = (wrench_W - config_.damping.cwiseProduct(offset_rate_) - config_.stiffness.cwiseProduct(offset_))
                        .cwiseQuotient(config_.mass);
  }

  Eigen::Vector3d rpy_rad, rpy_rate_radps, rpy_accel_radps2;
  EulerFromReference(nominal, &rpy_rad, &rpy_rate_radps, &rpy_accel_radps2);
  PoseReference revised = ReferenceFromEuler(
      nominal.p_WP_m + offset_.head<3>(), nominal.v_WP_W_mps + offset_rate_.head<3>(),
      nominal.a_WP_W_mps2 + offset_accel_.head<3>(), rpy_rad + offset_.tail<3>(),
      rpy_rate_radps + offset_rate_.tail<3>(), rpy_accel_radps2 + offset_accel_.tail<3>());
  revised.five_dof = nominal.five_dof;
  return revised;
}

void EulerFromReference(const PoseReference& reference, Eigen::Vector3d* rpy_rad, Eigen::Vector3d* rpy_rate_radps,
                        Eigen::Vector3d* rpy_accel_radps2) {
  const Eigen::Matrix3d R = reference.q_WP.normalized().toRotationMatrix();
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double pitch = -std::asin(std::clamp(R(2, 0), -1.0, 1.0));
  *rpy_rad << roll, pitch, std::atan2(R(1, 0), R(0, 0));
  const double sr = std::sin(roll), cr = std::cos(roll);
  const double sp = std::sin(pitch), cp = std::cos(pitch);
  // ω = E·γ̇ (as in ReferenceFromEuler), so γ̇ = E⁻¹ω and γ̈ = E⁻¹(dω/dt − Ė·γ̇)
  Eigen::Matrix3d E;
  E << 1.0, 0.0, -sp,    //
      0.0, cr, sr * cp,  //
      0.0, -sr, cr * cp;
  *rpy_rate_radps = E.inverse() * reference.w_WP_P_radps;
  const double droll = rpy_rate_radps->x(), dpitch = rpy_rate_radps->y();
  Eigen::Matrix3d dE;
  dE << 0.0, 0.0, -cp * dpitch,                              //
      0.0, -sr * droll, cr * cp * droll - sr * sp * dpitch,  //
      0.0, -cr * droll, -sr * cp * droll - cr * sp * dpitch;
  *rpy_accel_radps2 = E.inverse() * (reference.dw_WP_P_radps2 - dE * *rpy_rate_radps);
}

}  // namespace iapsim::control
