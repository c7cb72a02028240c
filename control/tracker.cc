#include "control/tracker.h"

namespace iapsim::control {
namespace {

Eigen::Vector3d Vee(const Eigen::Matrix3d& skew) {
  return Eigen::Vector3d(skew(2, 1), skew(0, 2), skew(1, 0));
}

// r_0 of (11): the unit direction of the joint line in P (e1 for the paper's two- and three-line IAPs),
// oriented along +x where it has an x component. Only meaningful for collinear joints.
Eigen::Vector3d JointLine_P(const model::Vehicle& vehicle) {
  Eigen::Vector3d line = Eigen::Vector3d::Zero();
  for (const auto& sub : vehicle.sub_aircraft) {
    const Eigen::Vector3d d = sub.joint_P_m - vehicle.sub_aircraft.front().joint_P_m;
    if (d.norm() > line.norm()) line = d;
  }
  line.normalize();
  return line.x() < 0.0 ? Eigen::Vector3d(-line) : line;
}

}  // namespace

Tracker::Tracker(const model::Vehicle& vehicle, const TrackerGains& gains, double gravity_mps2)
    : allocation_(vehicle),
      gains_(gains),
      mass_kg_(vehicle.TotalMass_kg()),
      J_P_kgm2_(vehicle.LumpedInertia_P_kgm2()),
      d_0_P_m_(vehicle.CenterOfMass_P_m()),
      gravity_mps2_(gravity_mps2) {
  if (!fully_actuated()) {
    line_P_ = JointLine_P(vehicle);
    const Eigen::Vector3d& d_1 = vehicle.sub_aircraft.front().joint_P_m;
    line_point_P_m_ = d_1 - line_P_.dot(d_1) * line_P_;  // the line's point nearest P's origin
  }
}

Vector6d Tracker::Update(const PoseReference& reference, const PlatformState& state,
                         const Vector6d& external_wrench_P, double dt_s, bool integrate) {
  const Eigen::Matrix3d R = state.q_WP.normalized().toRotationMatrix();
  const Eigen::Matrix3d R_ref = reference.q_WP.normalized().toRotationMatrix();
  const Eigen::Vector3d& w = state.w_WP_P_radps;

  // ξ̄ (nominal twist in the actual frame P) and its time derivative, linear part: v̄ = Rᵀṗ̄.
  const Eigen::Vector3d v_ref_P = R.transpose() * reference.v_WP_W_mps;
  const Eigen::Vector3d dv_ref_P = R.transpose() * reference.a_WP_W_mps2 - w.cross(v_ref_P);

  Eigen::Vector3d e_R, w_ref_P, dw_ref_P;
  if (fully_actuated()) {
    // (10): e_R = ½(R̄ᵀR − RᵀR̄)^∨ and ω̄ carried into P by RᵀR̄.
    const Eigen::Matrix3d R_rel = R.transpose() * R_ref;
    e_R = 0.5 * Vee(R_ref.transpose() * R - R_rel);
    w_ref_P = R_rel * reference.w_WP_P_radps;
    dw_ref_P = R_rel * reference.dw_WP_P_radps2 - w.cross(w_ref_P);
  } else {
    // (16): only the direction r̄ = R̄ r_0 is tracked. The error −r_0^ Rᵀr̄ is (16)'s attitude block; the
    // nominal rate is the least rate that turns r̄ (r̄ × dr̄/dt), so the free roll about r_0 gets no command.
    const Eigen::Vector3d& r0 = line_P_;
    const Eigen::Vector3d& w_ref = reference.w_WP_P_radps;
    const Eigen::Vector3d r_ref_W = R_ref * r0;
    const Eigen::Vector3d dr_ref_W = R_ref * w_ref.cross(r0);
    const Eigen::Vector3d ddr_ref_W =
        R_ref * (reference.dw_WP_P_radps2.cross(r0) + w_ref.cross(w_ref.cross(r0)));
    e_R = -r0.cross(R.transpose() * r_ref_W);
    w_ref_P = R.transpose() * r_ref_W.cross(dr_ref_W);
    dw_ref_P = R.transpose() * r_ref_W.cross(ddr_ref_W) - w.cross(w_ref_P);
  }

  error_.e_T << R.transpose() * (state.p_WP_m - reference.p_WP_m), e_R;
  error_.e_xi << state.v_WP_P_mps - v_ref_P, w - w_ref_P;
  if (!fully_actuated()) {
    // u_u = 0: nothing acts about the joint line, so its rate error is no error of this law.
    error_.e_xi.tail<3>() -= line_P_.dot(error_.e_xi.tail<3>()) * line_P_;
  }
  const bool in_world = gains_.position_integral_frame == PositionIntegralFrame::kWorld;
  if (integrate) {
    Vector6d e_integrated = error_.e_T;
    if (in_world) e_integrated.head<3>() = state.p_WP_m - reference.p_WP_m;
    integral_ =
        (integral_ + e_integrated * dt_s).cwiseMax(-gains_.integral_limit).cwiseMin(gains_.integral_limit);
  }
  Vector6d integral_term_P = gains_.ki.cwiseProduct(integral_);
  if (in_world) integral_term_P.head<3>() = R.transpose() * integral_term_P.head<3>();

  const Eigen::Vector3d weight_P = mass_kg_ * gravity_mps2_ * (R.transpose() * Eigen::Vector3d::UnitZ());
  Vector6d G;
  G << weight_P, d_0_P_m_.cross(weight_P);
  Vector6d feedforward;  // Mξ̄̇ + Cξ̄ with C = diag((mω)^, −(Jω)^)
  feedforward << mass_kg_ * (dv_ref_P + w.cross(v_ref_P)),
      J_P_kgm2_ * dw_ref_P - (J_P_kgm2_ * w).cross(w_ref_P);
  Vector6d U = feedforward - gains_.kp.cwiseProduct(error_.e_T) - integral_term_P -
               gains_.kd.cwiseProduct(error_.e_xi) - G - external_wrench_P;
  if (!fully_actuated()) {
    // u_u = 0 of (13): drop the moment about the joint line itself, taken about a point on the line, which
    // is exactly what the joints cannot carry. (Dropping the moment about an axis through P's origin
    // instead would leave a part of it that B⁺ turns into sideways force, which pumps the free roll.)
    Eigen::Vector3d torque_line_Nm = U.tail<3>() - line_point_P_m_.cross(U.head<3>());
    torque_line_Nm -= line_P_.dot(torque_line_Nm) * line_P_;
    U.tail<3>() = torque_line_Nm + line_point_P_m_.cross(U.head<3>());
  }
  return U;
}

}  // namespace iapsim::control
