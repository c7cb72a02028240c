#include "physics/drive.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iapsim::physics {

namespace {

constexpr double kVoltageFilterTimeConstant_s = 1.0;  // PX4's Battery: _voltage_filter_v, 1 s

}  // namespace

double LithiumPolymerCellVoltage_V(double state_of_charge) {
  const double s = std::clamp(state_of_charge, 0.0, 1.0);
  return -1.031 * std::exp(-35.0 * s) + 3.685 + s * (0.2156 + s * (-0.1178 + s * 0.3201));
}

BatteryPack::BatteryPack(const model::Battery& battery, double state_of_charge)
    : battery_(battery), state_of_charge_(std::clamp(state_of_charge, 0.0, 1.0)) {}

double BatteryPack::Voltage_V(double current_A) const {
  const double cell_V = LithiumPolymerCellVoltage_V(state_of_charge_) - polarization_V_ -
                        battery_.internal_resistance_ohm * current_A;
  return battery_.cells * std::max(cell_V, 0.0);
}

void BatteryPack::Step(double current_A, double dt_s) {
  state_of_charge_ = std::max(state_of_charge_ - current_A * dt_s / (3600.0 * battery_.capacity_Ah), 0.0);
  if (dt_s != decay_step_s_) {  // once per step length
    decay_step_s_ = dt_s;
    decay_ = std::exp(-dt_s / battery_.polarization_time_constant_s);
  }
  const double settled_V = battery_.polarization_resistance_ohm * current_A;
  polarization_V_ = settled_V + (polarization_V_ - settled_V) * decay_;
}

ElectricDrive::Motor ElectricDrive::MotorOf(const model::RotorSet& rotors) {
  Motor motor;
  motor.back_emf_V_per_rad_s = 60.0 / (2.0 * M_PI * rotors.electric.kv_rpm_per_V);
  motor.current_A_s2 = rotors.torque_coefficient / motor.back_emf_V_per_rad_s;
  motor.quadratic_V_s2 = rotors.electric.resistance_ohm * motor.current_A_s2;
  motor.no_load_current_A = rotors.electric.no_load_current_A;
  motor.no_load_drop_V = rotors.electric.resistance_ohm * motor.no_load_current_A;
  return motor;
}

// The motor equation's steady speed: R k_m / k_e ω² + k_e ω + (R I₀ − u V) = 0, the positive root in a form
// that does not cancel.
double ElectricDrive::SteadySpeed_rad_s(const Motor& motor, double throttle, double voltage_V) {
  const double drive_V = std::clamp(throttle, 0.0, 1.0) * voltage_V - motor.no_load_drop_V;
  if (drive_V <= 0.0) return 0.0;
  const double k_e = motor.back_emf_V_per_rad_s;
  return 2.0 * drive_V / (k_e + std::sqrt(k_e * k_e + 4.0 * motor.quadratic_V_s2 * drive_V));
}

ElectricDrive::ElectricDrive(const model::RotorSet& rotors, const model::Battery& battery,
                             double state_of_charge, bool battery_sag, bool battery_scale)
    : rotors_(rotors),
      motor_(MotorOf(rotors)),
      battery_(battery, state_of_charge),
      battery_sag_(battery_sag),
      use_battery_scale_(battery_scale) {
  if (!(rotors.electric.kv_rpm_per_V > 0.0)) {
    throw std::invalid_argument("the rotors have no electric model (rotors.electric in the vehicle file)");
  }
  if (battery.cells < 1) throw std::invalid_argument("there is no battery (battery in the vehicle file)");
  throttle_ = RotorVector::Zero(static_cast<int>(rotors.hub_S_m.size()));
  voltage_V_ = battery_sag ? battery_.Voltage_V(0.0) : battery_.charged_voltage_V();
  filtered_voltage_V_ = voltage_V_;
  CalibrateOn(rotors);
}

void ElectricDrive::CalibrateOn(const model::RotorSet& rotors) {
  const double charged_V = battery_.charged_voltage_V();
  const Motor motor = MotorOf(rotors);
  const double full_speed_rad_s = SteadySpeed_rad_s(motor, 1.0, charged_V);
  if (!(full_speed_rad_s > 0.0)) {
    throw std::invalid_argument("the motors do not turn at full throttle on a charged battery");
  }
  full_throttle_thrust_N_ = rotors.thrust_coefficient * full_speed_rad_s * full_speed_rad_s;
  thrust_model_factor_ = rotors.electric.thrust_model_factor;
  if (thrust_model_factor_ < 0.0) {  // least squares of t − u = f (u² − u) over the calibration points
    double numerator = 0.0, denominator = 0.0;
    for (int i = 0; i <= 100; ++i) {
      const double u = i / 100.0;
      const double t = std::pow(SteadySpeed_rad_s(motor, u, charged_V) / full_speed_rad_s, 2);
      numerator += (t - u) * (u * u - u);
      denominator += (u * u - u) * (u * u - u);
    }
    thrust_model_factor_ = std::clamp(numerator / denominator, 0.0, 1.0);
  }
}

double ElectricDrive::SteadySpeed_rad_s(double throttle, double voltage_V) const {
  return SteadySpeed_rad_s(motor_, throttle, voltage_V);
}

double ElectricDrive::MotorCurrent_A(double speed_rad_s) const {
  return motor_.current_A_s2 * speed_rad_s * speed_rad_s + motor_.no_load_current_A;
}

double ElectricDrive::ThrottleForThrust(double thrust_N) const {
  const double t = std::clamp(thrust_N / full_throttle_thrust_N_ * battery_scale_, 0.0, 1.0);
  const double f = thrust_model_factor_;
  if (f < 1e-9) return t;
  return (-(1.0 - f) + std::sqrt((1.0 - f) * (1.0 - f) + 4.0 * f * t)) / (2.0 * f);
}

void ElectricDrive::Step(const RotorVector& thrusts_N, double dt_s, Rotors* rotors) {
  if (dt_s != step_s_) {  // the exact first-order steps' factors, once per step length
    step_s_ = dt_s;
    filter_gain_ = 1.0 - std::exp(-dt_s / kVoltageFilterTimeConstant_s);
    up_gain_ = 1.0 - std::exp(-dt_s / rotors_.electric.time_constant_up_s);
    down_gain_ = 1.0 - std::exp(-dt_s / rotors_.electric.time_constant_down_s);
  }
  voltage_V_ = battery_sag_ ? battery_.Voltage_V(current_A_) : battery_.charged_voltage_V();
  if (use_battery_scale_) {
    filtered_voltage_V_ += (voltage_V_ - filtered_voltage_V_) * filter_gain_;
    battery_scale_ = std::clamp(battery_.charged_voltage_V() / filtered_voltage_V_, 1.0, 1.3);
  }
  const double up = up_gain_, down = down_gain_;
  RotorVector speeds = rotors->speeds_rad_s();
  // rotor by rotor in separate passes: the rotors' square roots and divisions do not wait on each other
  for (int j = 0; j < speeds.size(); ++j) throttle_[j] = ThrottleForThrust(thrusts_N[j]);
  RotorVector steady_rad_s(speeds.size());
  for (int j = 0; j < speeds.size(); ++j) steady_rad_s[j] = SteadySpeed_rad_s(throttle_[j], voltage_V_);
  current_A_ = 0.0;
  for (int j = 0; j < speeds.size(); ++j) {
    speeds[j] += (steady_rad_s[j] - speeds[j]) * (steady_rad_s[j] > speeds[j] ? up : down);
    current_A_ += throttle_[j] * MotorCurrent_A(speeds[j]);
  }
  rotors->SetDrivenSpeeds(speeds);
  if (battery_sag_) battery_.Step(current_A_, dt_s);
}

}  // namespace iapsim::physics
