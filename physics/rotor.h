#pragma once
// Rotors of one sub-aircraft: first-order motor speed dynamics with saturation, thrust k_f·ω² along −z_S at
// each hub and drag torque k_m·ω² about z_S (issue 3, seed §V-C), and the mixer that turns a collective
// thrust and body torque into per-rotor thrusts within the motors' limits.

#include <Eigen/Core>

#include "model/vehicle.h"

namespace iapsim::physics {

constexpr int kMaxRotors = 8;
/// Per-rotor values; fixed capacity so the physics step never allocates.
using RotorVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxRotors, 1>;

class Rotors {
 public:
  /// `com_S_m`: the sub-aircraft's centre of mass in S, the point torques are taken about.
  /// Throws std::invalid_argument for more than kMaxRotors rotors or a mixer that cannot make every torque.
  Rotors(const model::RotorSet& rotors, const Eigen::Vector3d& com_S_m);

  int count() const { return static_cast<int>(speeds_rad_s_.size()); }
  double min_thrust_N() const { return min_thrust_N_; }  // per rotor
  double max_thrust_N() const { return max_thrust_N_; }

  /// Sets every motor's speed at once (initial conditions).
  void SetSpeeds(const RotorVector& speeds_rad_s);
  const RotorVector& speeds_rad_s() const { return speeds_rad_s_; }
  /// Advances the motors toward `commanded_rad_s` over dt: exact step of ω̇ = (ω_cmd − ω)/τ, with the
  /// command clamped to the speed limits.
  void Step(const RotorVector& commanded_rad_s, double dt_s);

  /// Net force (N) in S and torque (N·m) about the CoM in S from the current speeds.
  void Wrench_S(Eigen::Vector3d* force_S_N, Eigen::Vector3d* torque_S_Nm) const;

  /// Speeds that give these rotor thrusts (clamped to the limits).
  void SpeedsForThrusts(const RotorVector& thrusts_N, RotorVector* speeds_rad_s) const;

  /// Per-rotor thrusts for a collective thrust (N, along −z_S) and torque about the CoM (N·m, in S), within
  /// [min_thrust, max_thrust]. When the limits bind, roll/pitch torque wins over collective thrust, and
  /// both over yaw torque (PX4's mixer priorities). Returns whether anything was cut.
  bool Mix(double thrust_N, const Eigen::Vector3d& torque_S_Nm, RotorVector* thrusts_N) const;

 private:
  model::RotorSet set_;
  Eigen::Vector3d com_S_m_;
  double min_thrust_N_, max_thrust_N_;
  double speed_decay_per_s_;  // 1/τ
  // columns: per unit thrust of rotor j, the [collective thrust; torque about the CoM] it makes
  Eigen::Matrix<double, 4, Eigen::Dynamic, 0, 4, kMaxRotors> effect_;
  Eigen::Matrix<double, Eigen::Dynamic, 4, 0, kMaxRotors, 4> mixer_;  // pseudo-inverse of effect_
  RotorVector speeds_rad_s_;
};

}  // namespace iapsim::physics
