#include "control/wrench_control.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iapsim::control {

WrenchPid::WrenchPid(const WrenchPidGains& gains, double dt_s) : gains_(gains), dt_s_(dt_s) {
  if (!(dt_s > 0.0) || !(gains.derivative_time_constant_s > 0.0)) {
    throw std::invalid_argument("WrenchPid: dt_s and derivative_time_constant_s must be positive");
  }
  filter_alpha_ = 1.0 - std::exp(-dt_s / gains.derivative_time_constant_s);
}

Vector6d WrenchPid::Update(const Vector6d& measured_wrench_P, const Vector6d& command_wrench_P,
                           bool integrate) {
  if (!started_) {
    filtered_P_ = measured_wrench_P;
    started_ = true;
  }
  const Vector6d previous_P = filtered_P_;
  filtered_P_ += filter_alpha_ * (measured_wrench_P - filtered_P_);
  // e_w = F̄_e − F_e (see the header: the literal F_e − F̄_e is positive feedback on a contact)
  error_P_ = command_wrench_P - measured_wrench_P;
  // the command is constant between steps: ė_w = −dF_e/dt, taken on the filtered measurement
  const Vector6d error_rate_P = -(filtered_P_ - previous_P) / dt_s_;
  if (integrate) SetIntegralTerm(integral_term_ + gains_.ki.cwiseProduct(error_P_) * dt_s_);
  return gains_.kp.cwiseProduct(error_P_) + integral_term_ + gains_.kd.cwiseProduct(error_rate_P);
}

void WrenchPid::SetIntegralTerm(const Vector6d& integral_term) {
  integral_term_ = integral_term.cwiseMax(-gains_.integral_limit).cwiseMin(gains_.integral_limit);
}

Vector6d WrenchInP(const Eigen::Quaterniond& q_WP, const Vector6d& wrench_W) {
  const Eigen::Matrix3d R_PW = q_WP.normalized().toRotationMatrix().transpose();
  Vector6d wrench_P;
  wrench_P << R_PW * wrench_W.head<3>(), R_PW * wrench_W.tail<3>();
  return wrench_P;
}

Vector6d WrenchInW(const Eigen::Quaterniond& q_WP, const Vector6d& wrench_P) {
  return WrenchInP(q_WP.conjugate(), wrench_P);
}

DirectWrenchController::DirectWrenchController(const model::Vehicle& vehicle,
                                               const IapControllerConfig& baseline,
                                               const DirectWrenchConfig& config, double dt_s)
    : baseline_(vehicle, baseline),
      direct_(vehicle,
              [&] {
                IapControllerConfig direct = baseline;
                direct.gains = config.gains;
                return direct;
              }()),
      pid_(config.wrench_gains, dt_s),
      config_(config),
      kd_step_(config.gains.kd - baseline.gains.kd),
      dt_s_(dt_s) {}

bool DirectWrenchController::Update(const PoseReference& reference, const PlatformState& state,
                                    const Vector6d& measured_wrench_P) {
  if (!measured_wrench_P.allFinite()) return false;
  if (engaged_) {
    ramp_elapsed_s_ += dt_s_;
    if (restored_ < 1.0) {  // engaged again: the wrench integral moves back to where (21) left it
      const double progress = RampProgress();
      pid_.SetIntegralTerm(pid_.integral_term() + (progress - restored_) * integral_restore_P_);
      restored_ = progress;
    }
    // on the measurement itself, not the PID's further low-pass: every 50 ms of (21) pushing on nothing
    // turns the IAP (its yaw moment balanced the contact's); the integral holds while the contact seems lost
    const bool lost = measured_wrench_P.head<3>().norm() < config_.trigger.release_threshold_N;
    lost_s_ = lost ? lost_s_ + dt_s_ : 0.0;
    const Vector6d w_P =
        pid_.Update(measured_wrench_P, command_wrench_P(), !direct_.output().saturated && !lost);
    if (!lost || lost_s_ < config_.trigger.release_hold_s)
      return direct_.Update(reference, state, w_P, dt_s_);
    // released: the baseline resumes with the integral it had when it last flew free, its estimate of the
    // static disturbance without the contact (wind, model mismatch). (21)'s wrench integral, which holds
    // the push that balanced the contact, is kept for the next engagement: its loop (k_w^I 0.1/s) takes
    // some 40 s to build it up again from the bumpless value
    released_integral_P_ = pid_.integral_term();
    pid_.SetIntegralTerm(Vector6d::Zero());  // the next switch starts it as the first did
    engaged_ = false;
    ++releases_;
    contact_s_ = 0.0;
    lost_s_ = 0.0;
    return baseline_.Update(reference, state, Vector6d::Zero(), dt_s_);
  }

  // approach: (10) without the F_e term (zero in free flight; fed back at the first touch it would only
  // cancel the wall's reaction), the PID's filter kept warm for the trigger and the switch
  const Vector6d w0_P = pid_.Update(measured_wrench_P, config_.command_wrench_P, false);
  if (!baseline_.Update(reference, state, Vector6d::Zero(), dt_s_)) return false;
  const bool touching = pid_.filtered_wrench_P().head<3>().norm() > config_.trigger.force_threshold_N;
  contact_s_ = touching ? contact_s_ + dt_s_ : 0.0;
  if (!touching || contact_s_ < config_.trigger.hold_s) return true;

  // switch with bumpless transfer. U = T − w is affine in the PID's output w: a dry run of (21) with no
  // wrench integral (dt 0 integrates nothing) gives U_0, and k_w^I∫e_w = U_0 − U_baseline makes U continue.
  // The command starts at the wrench measured now and ramps to F̄_e, so the transfer holds nothing of F̄_e
  // (the slow wrench integral would otherwise take k_w^P F̄_e / (k_w^I ΔF) seconds to shed it). Only the
  // static part is carried over: the damping terms (the motion k^D of Tables II and V differ, and k_w^D acts
  // on the impact's force rate) are transients that would stay baked into the integral and push the IAP
  // into the wall long after the impact.
  ramp_start_P_ = measured_wrench_P;
  ramp_elapsed_s_ = 0.0;
  direct_.ResetIntegral();  // each engagement starts (21) as the first does (it is zero then)
  const Vector6d wrench_damping_P = w0_P - config_.wrench_gains.kp.cwiseProduct(pid_.error_P());
  direct_.Update(reference, state, wrench_damping_P, 0.0);
  const Vector6d damping_step_P = kd_step_.cwiseProduct(direct_.tracker().error().e_xi);
  pid_.SetIntegralTerm(direct_.output().wrench_P - baseline_.output().wrench_P + damping_step_P +
                       wrench_damping_P);
  // engaged again after a lost contact: over the command's ramp the integral moves on from the bumpless
  // value to where (21) left it, so U stays continuous and (21) is back where it was once the ramp is done
  integral_restore_P_ = released_integral_P_ - pid_.integral_term();
  restored_ = releases_ > 0 ? 0.0 : 1.0;
  engaged_ = true;
  return direct_.Update(reference, state, wrench_damping_P + pid_.integral_term(), dt_s_);
}

double DirectWrenchController::RampProgress() const {
  return config_.command_ramp_s > 0.0 ? std::min(1.0, ramp_elapsed_s_ / config_.command_ramp_s) : 1.0;
}

Vector6d DirectWrenchController::command_wrench_P() const {
  if (!engaged_) return config_.command_wrench_P;
  return ramp_start_P_ + RampProgress() * (config_.command_wrench_P - ramp_start_P_);
}

}  // namespace iapsim::control
