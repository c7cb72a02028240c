#pragma once
// Rotors of one sub-aircraft: first-order motor speed dynamics with saturation, thrust k_f·ω² along −z_S at
// each hub and drag torque k_m·ω² about z_S (issue 3, seed §V-C), and the mixer that turns a collective
// thrust and body torque into per-rotor thrusts within the motors' limits. When a scenario models the air
// (issue 19), ground effect scales each rotor's thrust and the rotors' in-plane aerodynamics (rotor drag,
// rolling moment) add to the wrench.

#include <Eigen/Core>
#include <array>
#include <cmath>

#include "model/vehicle.h"

namespace iapsim::physics {

constexpr int kMaxRotors = 8;
/// Per-rotor values; fixed capacity so the physics step never allocates.
using RotorVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxRotors, 1>;

/// Thrust in ground effect over thrust out of it at the same rotor speed, for a rotor `height_over_radius`
/// radii above a surface: Cheeseman & Bennett, "The effect of the ground on a helicopter rotor in forward
/// flight", ARC R&M 3021 (1955), from a source image of the rotor's wake in hover:
/// T_IGE / T_OGE = 1 / (1 − (R / 4z)²). The formula is singular at z = R/4 and was checked by its authors
/// down to about z = R/2; below that the ratio stays at its value there, 4/3.
double CheesemanBennettThrustRatio(double height_over_radius);

/// Downwash: a rotor's wake as the slipstream of an actuator disk (momentum theory) that spreads like a
/// round turbulent jet. On the axis of a uniformly loaded disk of radius R in hover the flow moves at
/// w(d) = v_h (1 + d / √(d² + R²)) a distance d below it (the semi-infinite vortex cylinder; Leishman,
/// Principles of Helicopter Aerodynamics, 2nd ed. 2006, ch. 2), contracting by continuity to R/√2 at
/// twice the induced velocity v_h = √(T / (2ρπR²)). The slipstream's momentum flux ρ w² A_w = ρ πR² v_h w
/// is then T (1 + d / √(d² + R²)) / 2: half the thrust at the disk, the thrust far below. Mixing with the
/// still air widens the jet at constant momentum flux (Pope, Turbulent Flows, 2000, §5.1: the round jet's
/// half-velocity radius grows by 0.094 per unit distance). A body in the wake takes the drag of the part of
/// the flux it blocks: C_D / 2 times that flux.
double WakeMomentumFlux_N(double thrust_N, double distance_m, double radius_m);

/// The radius of the wake, as a top hat of the jet's centreline velocity and momentum flux, a distance d
/// below the disk: R/√2 (the contraction is taken as immediate: it is 80 % done one radius below the disk)
/// plus 0.08 d (0.094 d of the half-velocity radius, times √(1 / (2 ln 2)) for a top hat of the same
/// momentum flux).
constexpr double kWakeSpreadRate = 0.094 / 1.1774100225154747;  // √(2 ln 2)
inline double WakeRadius_m(double distance_m, double radius_m) {  // inline: the downwash's culling calls it
  return radius_m * M_SQRT1_2 + kWakeSpreadRate * distance_m;     // for every rotor and body, every step
}

/// Cells of equal area tiling the unit disk, by their centres: one at the centre, a ring of 6 and one of
/// 12, at the radii that halve each ring's area. The wake is sampled with one ray per cell.
constexpr int kWakeCells = 19;
const std::array<Eigen::Vector2d, kWakeCells>& WakeCells();

/// What a mixer gave up of its demand, per axis.
struct MixerCut {
  bool roll_pitch = false, thrust = false, yaw = false;
  bool any() const { return roll_pitch || thrust || yaw; }
};

class Rotors {
 public:
  /// `com_S_m`: the sub-aircraft's centre of mass in S, the point torques are taken about.
  /// Throws std::invalid_argument for more than kMaxRotors rotors or a mixer that cannot make every torque.
  Rotors(const model::RotorSet& rotors, const Eigen::Vector3d& com_S_m);

  int count() const { return static_cast<int>(speeds_rad_s_.size()); }
  double min_thrust_N() const { return min_thrust_N_; }  // per rotor
  double max_thrust_N() const { return max_thrust_N_; }

  /// Sets every motor's speed at once (initial conditions), within the speed range.
  void SetSpeeds(const RotorVector& speeds_rad_s);
  /// Sets the speeds an electric drive reached (physics/drive.h): its motors, not the speed range, bound
  /// them.
  void SetDrivenSpeeds(const RotorVector& speeds_rad_s) { speeds_rad_s_ = speeds_rad_s; }
  const RotorVector& speeds_rad_s() const { return speeds_rad_s_; }
  /// Advances the motors toward `commanded_rad_s` over dt: exact step of ω̇ = (ω_cmd − ω)/τ, with the
  /// command clamped to the speed limits.
  void Step(const RotorVector& commanded_rad_s, double dt_s);

  /// Net force (N) in S and torque (N·m) about the CoM in S from the current speeds.
  void Wrench_S(Eigen::Vector3d* force_S_N, Eigen::Vector3d* torque_S_Nm) const;
  /// The same with each rotor's thrust scaled by `thrust_ratio` (ground effect); the drag torques stay
  /// k_m·ω² (the model gives the thrust at a speed, not the torque).
  void Wrench_S(const RotorVector& thrust_ratio, Eigen::Vector3d* force_S_N,
                Eigen::Vector3d* torque_S_Nm) const;
  /// The rotors' in-plane aerodynamics while S's CoM moves at `v_air_S_mps` relative to the air and S turns
  /// at `w_WS_S`, both in S. Per rotor, with v⊥ its hub's velocity relative to the air perpendicular to the
  /// rotor axis z_S and ω its speed: the rotor drag F = −|ω| c_D v⊥ at the hub (induced drag and blade
  /// flapping's thrust tilt lumped into one term: Martin & Salaün, "The true role of accelerometer feedback
  /// in quadrotor control", ICRA 2010) and the rolling moment M = −spin |ω| c_R v⊥ of the advancing blade's
  /// extra lift (RotorS, Furrer et al., "RotorS — a modular Gazebo MAV simulator framework", 2016). Force
  /// (N) in S, torque (N·m) about the CoM in S; zero without the rotor set's coefficients.
  void AirWrench_S(const Eigen::Vector3d& v_air_S_mps, const Eigen::Vector3d& w_WS_S,
                   Eigen::Vector3d* force_S_N, Eigen::Vector3d* torque_S_Nm) const;
  const model::RotorSet& set() const { return set_; }

  /// Speeds that give these rotor thrusts (clamped to the limits).
  void SpeedsForThrusts(const RotorVector& thrusts_N, RotorVector* speeds_rad_s) const;

  /// Per-rotor thrusts for a collective thrust (N, along −z_S) and torque about the CoM (N·m, in S), within
  /// [min_thrust, max_thrust]. When the limits bind, roll/pitch torque wins over collective thrust, and
  /// both over yaw torque (PX4's mixer priorities: a quadrotor keeps its attitude first). Returns what was
  /// cut.
  MixerCut Mix(double thrust_N, const Eigen::Vector3d& torque_S_Nm, RotorVector* thrusts_N) const;

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
