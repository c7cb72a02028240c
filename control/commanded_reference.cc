#include "control/commanded_reference.h"

#include <cmath>

namespace iapsim::control {

bool CommandedPoseReference::Add(double t_s, const Eigen::Vector3d& p_WP_m, const Eigen::Quaterniond& q_WP,
                                 bool five_dof) {
  if (!std::isfinite(t_s) || !p_WP_m.allFinite() || !q_WP.coeffs().allFinite() ||
      std::abs(q_WP.norm() - 1.0) > 1e-3 || (last_t_s_ && t_s <= *last_t_s_)) {
    return false;
  }
  const Eigen::Quaterniond q = q_WP.normalized();
  if (last_t_s_) {
    const double dt_s = t_s - *last_t_s_;
    const Eigen::Vector3d v_W = (p_WP_m - reference_.p_WP_m) / dt_s;
    // ω̄ in the reference frame: R̄_prevᵀ R̄ = exp(ω̄ dt)
    const Eigen::AngleAxisd turn(reference_.q_WP.conjugate() * q);
    const Eigen::Vector3d w_P = turn.angle() * turn.axis() / dt_s;
    const double alpha = dt_s / (tau_s_ + dt_s);
    const Eigen::Vector3d v_before_W = reference_.v_WP_W_mps;
    reference_.v_WP_W_mps += alpha * (v_W - reference_.v_WP_W_mps);
    // the acceleration the same way, from the filtered velocity (the tracker's feed-forward of m·a)
    reference_.a_WP_W_mps2 += alpha * ((reference_.v_WP_W_mps - v_before_W) / dt_s - reference_.a_WP_W_mps2);
    reference_.w_WP_P_radps += alpha * (w_P - reference_.w_WP_P_radps);
  }
  reference_.p_WP_m = p_WP_m;
  reference_.q_WP = q;
  reference_.five_dof = five_dof;
  last_t_s_ = t_s;
  return true;
}

}  // namespace iapsim::control
