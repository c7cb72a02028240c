#include "control/reference_shaper.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace iapsim::control {
namespace {

bool PositiveFinite(const Eigen::Vector3d& v) { return v.allFinite() && (v.array() > 0.0).all(); }

// The rotation vector of q (angle ≤ π).
Eigen::Vector3d Log(Eigen::Quaterniond q) {
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  const Eigen::AngleAxisd turn(q);
  return turn.angle() * turn.axis();
}

Eigen::Quaterniond Exp(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  if (angle < 1e-12) return Eigen::Quaterniond(1.0, 0.5 * r.x(), 0.5 * r.y(), 0.5 * r.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, r / angle));
}

// The cascade of the header per axis: the acceleration toward `error` from `rate`.
Eigen::Vector3d Acceleration(const Eigen::Vector3d& error, const Eigen::Vector3d& rate, double omega,
                             const Eigen::Vector3d& max_rate, const Eigen::Vector3d& max_acceleration) {
  const Eigen::Vector3d rate_wanted = (0.5 * omega * error).cwiseMax(-max_rate).cwiseMin(max_rate);
  return (2.0 * omega * (rate_wanted - rate)).cwiseMax(-max_acceleration).cwiseMin(max_acceleration);
}

}  // namespace

ReferenceShaper::ReferenceShaper(const ReferenceShaperConfig& config)
    : config_(config), omega_radps_(2.0 * M_PI * config.bandwidth_hz) {
  if (!(config.bandwidth_hz > 0.0) || !std::isfinite(config.bandwidth_hz)) {
    throw std::invalid_argument("bandwidth_hz: must be positive, got " + std::to_string(config.bandwidth_hz));
  }
  if (!PositiveFinite(config.max_velocity_mps) || !PositiveFinite(config.max_acceleration_mps2) ||
      !PositiveFinite(config.max_rate_radps) || !PositiveFinite(config.max_angular_acceleration_radps2)) {
    throw std::invalid_argument("every rate and acceleration limit must be positive and finite");
  }
}

void ReferenceShaper::Reset(const Eigen::Vector3d& p_WP_m, const Eigen::Quaterniond& q_WP) {
  p_WP_m_ = p_WP_m;
  v_WP_W_mps_.setZero();
  q_WP_ = q_WP.normalized();
  w_WP_P_radps_.setZero();
}

PoseReference ReferenceShaper::Step(const Eigen::Vector3d& p_command_WP_m,
                                    const Eigen::Quaterniond& q_command_WP, double dt_s) {
  PoseReference reference;
  reference.p_WP_m = p_WP_m_;
  reference.v_WP_W_mps = v_WP_W_mps_;
  reference.a_WP_W_mps2 = Acceleration(p_command_WP_m - p_WP_m_, v_WP_W_mps_, omega_radps_,
                                       config_.max_velocity_mps, config_.max_acceleration_mps2);
  reference.q_WP = q_WP_;
  reference.w_WP_P_radps = w_WP_P_radps_;
  reference.dw_WP_P_radps2 =
      Acceleration(Log(q_WP_.conjugate() * q_command_WP.normalized()), w_WP_P_radps_, omega_radps_,
                   config_.max_rate_radps, config_.max_angular_acceleration_radps2);

  p_WP_m_ += v_WP_W_mps_ * dt_s + 0.5 * reference.a_WP_W_mps2 * dt_s * dt_s;
  v_WP_W_mps_ += reference.a_WP_W_mps2 * dt_s;
  q_WP_ = (q_WP_ * Exp(w_WP_P_radps_ * dt_s + 0.5 * reference.dw_WP_P_radps2 * dt_s * dt_s)).normalized();
  w_WP_P_radps_ += reference.dw_WP_P_radps2 * dt_s;
  return reference;
}

}  // namespace iapsim::control
