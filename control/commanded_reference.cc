#include "control/commanded_reference.h"

#include <algorithm>
#include <cmath>

namespace iapsim::control {

CommandedPoseReference::CommandedPoseReference(const ReferenceShaping& shaping) : shaping_(shaping) {
  if (shaping_.type == ReferenceShaping::Type::kSecondOrder) shaper_.emplace(shaping_.second_order);
}

bool CommandedPoseReference::Add(double t_s, const Eigen::Vector3d& p_WP_m, const Eigen::Quaterniond& q_WP,
                                 bool five_dof) {
  if (!std::isfinite(t_s) || !p_WP_m.allFinite() || !q_WP.coeffs().allFinite() ||
      std::abs(q_WP.norm() - 1.0) > 1e-3 || (last_t_s_ && t_s <= *last_t_s_)) {
    return false;
  }
  const Eigen::Quaterniond q = q_WP.normalized();
  if (last_t_s_) {
    const double dt_s = t_s - *last_t_s_;
    const Eigen::Vector3d v_W = (p_WP_m - command_.p_WP_m) / dt_s;
    // ω̄ in the reference frame: R̄_prevᵀ R̄ = exp(ω̄ dt)
    const Eigen::AngleAxisd turn(command_.q_WP.conjugate() * q);
    const Eigen::Vector3d w_P = turn.angle() * turn.axis() / dt_s;
    const double alpha = dt_s / (shaping_.velocity_time_constant_s + dt_s);
    const Eigen::Vector3d v_before_W = command_.v_WP_W_mps;
    command_.v_WP_W_mps += alpha * (v_W - command_.v_WP_W_mps);
    // the acceleration the same way, from the filtered velocity (the tracker's feed-forward of m·a)
    command_.a_WP_W_mps2 += alpha * ((command_.v_WP_W_mps - v_before_W) / dt_s - command_.a_WP_W_mps2);
    command_.w_WP_P_radps += alpha * (w_P - command_.w_WP_P_radps);
  }
  command_.p_WP_m = p_WP_m;
  command_.q_WP = q;
  command_.five_dof = five_dof;
  last_t_s_ = t_s;
  return true;
}

PoseReference CommandedPoseReference::Update(const PoseReference& start, double dt_s) {
  PoseReference reference = command_;
  if (shaper_) {
    if (updates_ == 0) shaper_->Reset(start.p_WP_m, start.q_WP);
    reference = shaper_->Step(command_.p_WP_m, command_.q_WP, dt_s);
    reference.five_dof = command_.five_dof;
  }
  const double lag_m = (reference.p_WP_m - command_.p_WP_m).norm();
  const double lag_rad = reference.q_WP.angularDistance(command_.q_WP);
  ++updates_;
  lag_max_m_ = std::max(lag_max_m_, lag_m);
  lag_sum_sq_m2_ += lag_m * lag_m;
  lag_max_rad_ = std::max(lag_max_rad_, lag_rad);
  lag_sum_sq_rad2_ += lag_rad * lag_rad;
  return reference;
}

ReferenceLag CommandedPoseReference::lag() const {
  ReferenceLag lag;
  if (updates_ == 0) return lag;
  const double n = static_cast<double>(updates_);
  lag.max_m = lag_max_m_;
  lag.rms_m = std::sqrt(lag_sum_sq_m2_ / n);
  lag.max_deg = lag_max_rad_ * 180.0 / M_PI;
  lag.rms_deg = std::sqrt(lag_sum_sq_rad2_ / n) * 180.0 / M_PI;
  return lag;
}

}  // namespace iapsim::control
