#include "rl/docking_expert.h"

#include <algorithm>
#include <cmath>

namespace iapsim::rl {

DockingExpert::DockingExpert(const DockingEnv& env, const DockingExpertGains& gains)
    : gains_(gains),
      period_s_(1.0 / env.config().control_rate_hz),
      max_acceleration_mps2_(env.config().max_acceleration_mps2),
      R_WT_(env.target_q_WP().toRotationMatrix()) {}

void DockingExpert::Reset() {
  phase_ = Phase::kAlign;
  filtered_ = false;
  relative_m_.setZero();
  approach_y_m_ = 0.0;
  push_integral_ = 0.0;
  push_s_ = 0.0;
}

Action DockingExpert::Act(const Observation& observation) {
  const auto a = observation.segment<kObservationPerQuadrotor>(0);
  const auto b = observation.segment<kObservationPerQuadrotor>(kObservationPerQuadrotor);
  const Eigen::Vector3d error_a_m = a.segment<3>(0), velocity_a_mps = a.segment<3>(3);
  const Eigen::Vector3d error_b_m = b.segment<3>(0), velocity_b_mps = b.segment<3>(3);
  const double force_y_N = observation[2 * kObservationPerQuadrotor + 1];  // on B, in B's P

  // B relative to where it docks on A as A is now, in the targets' frame T (y: the docking axis, toward A)
  const Eigen::Vector3d relative_T_m = R_WT_.transpose() * (error_b_m - error_a_m);
  const double blend = filtered_ ? period_s_ / (gains_.filter_time_constant_s + period_s_) : 1.0;
  relative_m_ += blend * (relative_T_m - relative_m_);
  filtered_ = true;
  const Eigen::Vector3d relative_velocity_T = R_WT_.transpose() * (velocity_b_mps - velocity_a_mps);

  const double kp = gains_.position_p_per_s2, kd = gains_.position_d_per_s;
  const Eigen::Vector3d acceleration_a_W = -kp * error_a_m - kd * velocity_a_mps;
  Eigen::Vector3d acceleration_b_T = Eigen::Vector3d::Zero();
  const double radial_m = std::hypot(relative_m_.x(), relative_m_.z());
  const bool touching = -force_y_N > gains_.contact_force_N;  // A pushes B back along −y

  switch (phase_) {
    case Phase::kAlign:
    case Phase::kBackOff: {
      const Eigen::Vector3d goal_T(0.0, -gains_.standoff_m, 0.0);
      acceleration_b_T = -kp * (relative_m_ - goal_T) - kd * relative_velocity_T;
      if (radial_m < gains_.align_tolerance_m &&
          std::abs(relative_m_.y() - goal_T.y()) < gains_.align_tolerance_m &&
          relative_velocity_T.norm() < 0.05) {
        phase_ = Phase::kApproach;
        approach_y_m_ = relative_m_.y();
      }
      break;
    }
    case Phase::kApproach: {
      approach_y_m_ = std::min(approach_y_m_ + gains_.approach_speed_mps * period_s_, 0.01);
      const Eigen::Vector3d goal_T(0.0, approach_y_m_, 0.0);
      const Eigen::Vector3d goal_velocity_T(0.0, approach_y_m_ < 0.01 ? gains_.approach_speed_mps : 0.0, 0.0);
      acceleration_b_T = -kp * (relative_m_ - goal_T) - kd * (relative_velocity_T - goal_velocity_T);
      if (touching) {
        phase_ = Phase::kPush;
        push_integral_ = 0.0;
        push_s_ = 0.0;
      }
      if (radial_m > 2.0 * gains_.align_tolerance_m) phase_ = Phase::kBackOff;
      break;
    }
    case Phase::kPush: {
      // direct force control along the axis: PI on the contact force, PD across it
      const double force_error_N = gains_.push_force_N - (-force_y_N);
      push_integral_ += force_error_N * period_s_;
      push_s_ += period_s_;
      acceleration_b_T = -kp * relative_m_ - kd * relative_velocity_T;
      acceleration_b_T.y() = gains_.force_p_per_kg * force_error_N + gains_.force_i_per_Ns * push_integral_;
      if (push_s_ > gains_.give_up_s) phase_ = Phase::kBackOff;
      // the push gone while the apex is at the face: the latch closed (its load is not a contact)
      if (!touching && relative_m_.y() > -gains_.docked_tolerance_m) phase_ = Phase::kDocked;
      break;
    }
    case Phase::kDocked: {
      // hold B where it docks on A; were the latch open, B drifts back and starts over
      acceleration_b_T = -kp * relative_m_ - kd * relative_velocity_T;
      if (relative_m_.y() < -3.0 * gains_.docked_tolerance_m) phase_ = Phase::kBackOff;
      break;
    }
  }
  const Eigen::Vector3d acceleration_b_W = R_WT_ * acceleration_b_T;
  Action action = Action::Zero();
  action.segment<3>(0) = acceleration_a_W / max_acceleration_mps2_;
  action.segment<3>(kActionPerQuadrotor) = acceleration_b_W / max_acceleration_mps2_;
  return action.cwiseMax(-1.0).cwiseMin(1.0);
}

}  // namespace iapsim::rl
