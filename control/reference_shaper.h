#pragma once
// Reference shaping for streamed pose commands (issue 23). A pilot's transmitter sends held values that
// change in steps (attitude switched by a channel) or start and stop moving at once (a stick's velocity);
// fed to the tracker raw, each step asks for an impulse of force and torque that the sub-aircraft cannot
// give before they tilt, and the feed-forward estimated by differencing the stream jumps with it. The
// shaper turns the raw stream into a reference the IAP can fly, with exact derivatives: per axis, a
// critically damped second-order filter of natural frequency ω (its bandwidth), written as the cascade a
// position controller is (PX4's multicopter position control: velocity from the position error, then
// acceleration from the velocity error),
//
//   v_des = clamp(ω/2 · e, ±v_max),   a = clamp(2ω (v_des − v), ±a_max),
//
// which in the linear region is ẍ = ω² e − 2ω ẋ (both poles at −ω: no overshoot) and with the limits is a
// rate- and acceleration-limited approach that still does not overshoot while v_max ≤ 2 a_max / ω (the
// deceleration that following v_des asks for is ω/2 · |v|). Attitude the same way on SO(3), per axis of the
// shaped platform frame: e = Log(R̄ᵀ R_cmd), rates ω̄ and angular accelerations in that frame.
//
// Each step holds the acceleration constant over dt and integrates exactly: p ← p + v dt + a dt²/2,
// v ← v + a dt (and R̄ ← R̄ Exp(ω̄ dt + α dt²/2), exact about a fixed axis), so the reference's velocity
// and acceleration are the derivatives of its pose that the tracker (10), (16) feeds forward.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "control/trajectory.h"

namespace iapsim::control {

/// The defaults suit a transmitter's log flown by the seed's IAPs (three-square, three-star: 0.4 m/s stick
/// speeds, 8-10° roll and pitch switches, 20-30° yaw steps; tuned on tools/generate_pilot_log.py --seed 1):
/// they keep the allocation and every mixer out of saturation there, and satisfy v_max <= 2 a_max / ω on
/// every axis (no overshoot). A heavier or slower vehicle wants limits from its own envelope.
struct ReferenceShaperConfig {
  double bandwidth_hz = 1.0;  // natural frequency ω / 2π of the critically damped response
  // per W axis (x, y, z)
  Eigen::Vector3d max_velocity_mps{0.6, 0.6, 0.3};
  Eigen::Vector3d max_acceleration_mps2{2.0, 2.0, 1.0};
  // per axis of the shaped platform frame (roll, pitch, yaw): 30°/s, 120°/s²
  Eigen::Vector3d max_rate_radps{0.5236, 0.5236, 0.5236};
  Eigen::Vector3d max_angular_acceleration_radps2{2.0944, 2.0944, 2.0944};
};

class ReferenceShaper {
 public:
  /// Throws std::invalid_argument for a bandwidth or a limit that is not positive and finite.
  explicit ReferenceShaper(const ReferenceShaperConfig& config);

  /// Starts at `pose` at rest.
  void Reset(const Eigen::Vector3d& p_WP_m, const Eigen::Quaterniond& q_WP);

  /// The reference for now, toward the command (p_cmd, q_cmd), whose acceleration holds for the next dt_s;
  /// then advances by dt_s. Requires a Reset first.
  PoseReference Step(const Eigen::Vector3d& p_command_WP_m, const Eigen::Quaterniond& q_command_WP,
                     double dt_s);

  const ReferenceShaperConfig& config() const { return config_; }

 private:
  ReferenceShaperConfig config_;
  double omega_radps_;
  Eigen::Vector3d p_WP_m_ = Eigen::Vector3d::Zero(), v_WP_W_mps_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_WP_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_WP_P_radps_ = Eigen::Vector3d::Zero();
};

}  // namespace iapsim::control
