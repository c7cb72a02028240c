#pragma once
// Issue 19's checks of the closed loop against independent references, shared by `iapsim bench fidelity`
// (which prints them) and the tests (which bound them): each measures a response of the simulated vehicle
// in-process (Bullet at 1 kHz, the IAP controller at 200 Hz) and computes what a linear model of the same
// loop, from the same gains, predicts for it.

#include <vector>

#include "control/tracker.h"
#include "model/vehicle.h"
#include "physics/simulation.h"

namespace iapsim::tools {

/// Which flight controller a measurement flies: the paper's (ideal motors, the true rotation) or the
/// realistic one (issue 19's electric drives on a full pack, PX4's gyroscope filters and rate D term).
enum class Actuation { kIdeal, kRealistic };

struct PeakResponse {
  double peak = 0.0;         // largest excursion along the excited direction (m or rad)
  double peak_time_s = 0.0;  // after the step
};

/// A step force `force_N` along W axis `axis` (0 x, 1 y, 2 z: NED) on a rigid body of `mass_kg` held by one
/// axis of the tracker (10) at hover, m x'' = F − k_P x − k_I ∫x − k_D x': the peak of x (a little below
/// the F / k_P = 0.125 m of Table II's position gains, which the integral would hold without it).
PeakResponse PredictStepForce(double mass_kg, double kp, double ki, double kd, double force_N);

/// The same step force on the platform of `vehicle` hovering under the IAP controller with `gains`, as the
/// difference from the same hover without it.
PeakResponse MeasureStepForce(const model::Vehicle& vehicle, const control::TrackerGains& gains, int axis,
                              double force_N, Actuation actuation);

struct StepFigures {
  double rise_time_s = 0.0;      // 10 % to 90 % of the step
  double overshoot = 0.0;        // (peak − step) / step, 0 when it never passes the step
  double settling_time_s = 0.0;  // last time outside ±5 % of the step
};

/// The first sub-aircraft of `vehicle` alone (a 1 g platform on a fixed joint): one free quadrotor.
model::Vehicle SingleSubAircraft(const model::Vehicle& vehicle);

/// A roll attitude step of `step_rad` through the linear cascade of one flight controller's roll axis
/// (attitude P with the rate limit -> rate PI, no D -> first-order motor lag `motor_time_constant_s` -> the
/// body's rotation): what PX4's cascade on the quadrotor should do.
StepFigures PredictAttitudeStep(const model::FlightControllerGains& gains, double motor_time_constant_s,
                                double step_rad);
/// The same step flown by the simulated quadrotor `quadrotor` (SingleSubAircraft) in attitude mode.
StepFigures MeasureAttitudeStep(const model::Vehicle& quadrotor, double step_rad, Actuation actuation);

/// One frequency of the roll-rate loop: the closed loop's response T = p/p_sp and, where the loop has unity
/// feedback (the ideal flight controller), its open loop L = T / (1 − T).
struct RatePoint {
  double frequency_hz = 0.0;
  double closed_loop_gain = 0.0;  // |T|
  double closed_loop_phase_deg = 0.0;
  double open_loop_gain = 0.0;  // |L|
  double open_loop_phase_deg = 0.0;
};
/// The crossover of a loop (|L| = 1) and its phase margin there.
struct Crossover {
  double frequency_hz = 0.0;
  double phase_margin_deg = 0.0;
};

/// The roll-rate loop swept by sinusoidal rate setpoints (a stepped chirp, `frequencies_hz`, each fitted by
/// least squares over whole periods) on the simulated quadrotor in body-rate mode.
std::vector<RatePoint> SweepRateLoop(const model::Vehicle& quadrotor,
                                     const std::vector<double>& frequencies_hz, Actuation actuation);
/// The same points from the linear model: L(s) = (k_p + k_i / s) / s / (τ s + 1).
std::vector<RatePoint> PredictRateLoop(const model::FlightControllerGains& gains,
                                       double motor_time_constant_s,
                                       const std::vector<double>& frequencies_hz);
/// Where |L| crosses 1 between two of the points (log-linear interpolation); zeros when it never does.
Crossover CrossoverOf(const std::vector<RatePoint>& points);

/// A point of a pack's discharge while it hovers its sub-aircraft.
struct DischargePoint {
  double time_s = 0.0;
  double state_of_charge = 0.0;
  double cell_voltage_V = 0.0;  // under the hover load
  double current_A = 0.0;
};
/// The electric power the first sub-aircraft of `vehicle` draws from its pack in a hover (measured in the
/// simulation with the electric drives), then that power drawn from the pack model until
/// `final_state_of_charge`: the loaded voltage at each 10 % of charge (and 5 %), and the hover time.
std::vector<DischargePoint> HoverDischarge(const model::Vehicle& vehicle, double final_state_of_charge);

}  // namespace iapsim::tools
