#pragma once
// The electric drive of one sub-aircraft (issue 19): what lies between its flight controller's per-rotor
// thrusts and the rotors' speeds on a real quadrotor, used when a scenario models the actuation.
//
//   thrust (N) ─▶ PX4 thrust model ─▶ throttle u ∈ [0, 1] ─▶ ESC: u·V ─▶ motor ─▶ ω ─▶ k_f ω²
//                                                              ▲ V sags with charge and current
//
// - The flight controller's output stage normalises each thrust by the full-throttle thrust of a charged
//   pack and inverts PX4's thrust model t = f u² + (1 − f) u (THR_MDL_FAC; PX4 user guide, "Multicopter
//   thrust curve"), as PX4 does before its motor outputs. As the pack sags it gives less thrust than asked
//   for, unless the flight controller scales its thrust by the charged voltage over the pack's voltage,
//   low-passed with a 1 s time constant, by 1 to 1.3 (PX4's MC_BAT_SCALE_EN and its Battery::computeScale;
//   off by default in PX4).
// - Each ESC applies u·V to its motor, u clamped to [0, 1] (the ESC's saturation), and draws u times
//   the motor current from the battery (a lossless buck converter).
// - Each motor is a DC motor (a brushless motor commutated by its ESC; Quan Quan, "Introduction to
//   Multicopter Design and Control", Springer 2017, ch. 4): at a steady speed u V = k_e ω + R I with
//   I = k_m ω² / k_t + I₀, the current whose torque balances the propeller's drag k_m ω² plus the no-load
//   current, and k_e = k_t = 60 / (2π Kv) in SI units. The speed approaches that steady speed first-order,
//   with one time constant up and another down (RotorS' and PX4 Gazebo's motor model: an ESC that does not
//   brake actively spins down more slowly than up).
// - The battery's cells in series, each a Thevenin model: open-circuit voltage over state of charge behind an
//   ohmic resistance and one RC pair for polarisation (Plett, "Battery Management Systems", vol. 1, 2015,
//   ch. 2), with the charge counted in coulombs.

#include "model/vehicle.h"
#include "physics/rotor.h"

namespace iapsim::physics {

/// Open-circuit voltage of one lithium-ion polymer cell at a state of charge in [0, 1] (clamped to it):
/// Chen & Rincón-Mora, "Accurate electrical battery model capable of predicting runtime and I–V
/// performance", IEEE Trans. Energy Conversion 21(2), 2006, their fit for a polymer cell:
/// V = −1.031 e^(−35 s) + 3.685 + 0.2156 s − 0.1178 s² + 0.3201 s³ (4.10 V full, 3.69 V at 10 %, 2.65 V
/// empty).
double LithiumPolymerCellVoltage_V(double state_of_charge);

/// A full cell under load: PX4's BAT_V_CHARGED default ("full cell voltage (5C load)"). The thrust curve
/// is calibrated at it, and PX4's battery scale compensates toward it.
constexpr double kChargedCellVoltage_V = 4.05;

class BatteryPack {
 public:
  /// Rested (no polarisation) at `state_of_charge` in [0, 1].
  BatteryPack(const model::Battery& battery, double state_of_charge);

  /// The pack's terminal voltage while it delivers `current_A`.
  double Voltage_V(double current_A) const;
  /// Delivers `current_A` for `dt_s`: the charge drops by I dt, and each cell's polarisation voltage takes
  /// the exact step of v̇ = (R_p I − v) / τ_p.
  void Step(double current_A, double dt_s);

  double state_of_charge() const { return state_of_charge_; }
  double polarization_V() const { return polarization_V_; }  // per cell
  double charged_voltage_V() const { return battery_.cells * kChargedCellVoltage_V; }

 private:
  model::Battery battery_;
  double state_of_charge_;
  double polarization_V_ = 0.0;
  double decay_step_s_ = 0.0;  // the step the polarization's decay factor was computed for
  double decay_ = 0.0;
};

class ElectricDrive {
 public:
  /// `battery_sag` false feeds the motors the pack's charged voltage throughout (an ideal supply), to study
  /// the motors alone; `battery_scale` is PX4's MC_BAT_SCALE_EN. Throws std::invalid_argument when the rotor
  /// set has no electric model or there is no battery.
  ElectricDrive(const model::RotorSet& rotors, const model::Battery& battery, double state_of_charge,
                bool battery_sag, bool battery_scale);

  /// Calibrates the flight controller's thrust curve (THR_MDL_FAC when fitted, and the full-throttle thrust)
  /// on these rotors instead: the vehicle file's, where the physics flies others (model mismatch).
  void CalibrateOn(const model::RotorSet& rotors);

  /// The speed a motor settles at under `throttle` (clamped to [0, 1]) from a supply of `voltage_V`.
  double SteadySpeed_rad_s(double throttle, double voltage_V) const;
  /// The current a motor draws spinning its propeller at `speed_rad_s`.
  double MotorCurrent_A(double speed_rad_s) const;
  /// The flight controller's output stage: the throttle PX4's thrust model gives for a rotor thrust, times
  /// the battery scale.
  double ThrottleForThrust(double thrust_N) const;

  /// THR_MDL_FAC: the vehicle file's, or the least-squares fit of t = f u² + (1 − f) u to the motor's steady
  /// thrust at the charged voltage over u = 0, 0.01, ..., 1 (what a thrust-stand calibration gives).
  double thrust_model_factor() const { return thrust_model_factor_; }
  /// The thrust of one rotor at full throttle and the charged voltage.
  double full_throttle_thrust_N() const { return full_throttle_thrust_N_; }
  /// PX4's battery scale in the last step (1 without it).
  double battery_scale() const { return battery_scale_; }

  /// One step: the throttles for the flight controller's rotor thrusts; each motor moves toward the speed
  /// they give at the battery's voltage under the last step's current; the battery delivers the current
  /// the motors now draw.
  void Step(const RotorVector& thrusts_N, double dt_s, Rotors* rotors);

  const RotorVector& throttle() const { return throttle_; }
  double voltage_V() const { return voltage_V_; }  // supplied in the last step
  double current_A() const { return current_A_; }  // drawn from the battery in the last step
  const BatteryPack& battery() const { return battery_; }

 private:
  // the motor equation's constants, computed once: the step solves it for four rotors every millisecond
  struct Motor {
    double back_emf_V_per_rad_s;  // k_e = 60 / (2π Kv)
    double quadratic_V_s2;        // R k_m / k_e: the resistive drop of the propeller's load current per ω²
    double no_load_drop_V;        // R I₀
    double current_A_s2;          // k_m / k_e: the load current per ω²
    double no_load_current_A;     // I₀
  };
  static Motor MotorOf(const model::RotorSet& rotors);
  static double SteadySpeed_rad_s(const Motor& motor, double throttle, double voltage_V);

  model::RotorSet rotors_;
  Motor motor_;
  BatteryPack battery_;
  bool battery_sag_;
  bool use_battery_scale_;
  double battery_scale_ = 1.0;
  double filtered_voltage_V_;    // what PX4's battery scale sees
  double step_s_ = 0.0, filter_gain_ = 0.0, up_gain_ = 0.0, down_gain_ = 0.0;  // for step_s_
  double thrust_model_factor_;
  double full_throttle_thrust_N_;
  RotorVector throttle_;
  double voltage_V_;
  double current_A_ = 0.0;
};

}  // namespace iapsim::physics
