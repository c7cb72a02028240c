#include "tools/fidelity_reference.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>
#include <stdexcept>

#include "model/urdf.h"
#include "physics/drive.h"
#include "tools/held_hover.h"

namespace iapsim::tools {
namespace {

constexpr double kStep_s = 0.001;  // physics, as every flight of the paper
constexpr double kGravity_mps2 = 9.81;
constexpr double kModelStep_s = 1e-5;   // the linear models' integration step: far below every time constant
constexpr double kHoverDepth_m = -5.0;  // NED: 5 m up, no ground in these scenes

physics::SimulationConfig SimulationOf(const model::Vehicle& vehicle, Actuation actuation) {
  physics::SimulationConfig config;
  config.step_s = kStep_s;
  config.world.ground = false;
  config.world.gravity_mps2 = kGravity_mps2;
  config.seed = 1;  // the flight controllers' gyroscope noise
  if (actuation == Actuation::kRealistic) {
    config.actuation.enabled = true;
    config.flight_controller_sensing = physics::FlightControllerSensing::kGyro;
  }
  physics::VehicleSpec spec;
  spec.name = vehicle.name;
  spec.vehicle = vehicle;
  spec.description = model::ParseUrdf(model::GenerateUrdf(vehicle), vehicle.name + ".urdf");
  spec.p_WP_m = Eigen::Vector3d(0.0, 0.0, kHoverDepth_m);
  config.vehicles.push_back(spec);
  return config;
}

std::unique_ptr<physics::Simulation> MakeSimulation(const model::Vehicle& vehicle, Actuation actuation) {
  return std::make_unique<physics::Simulation>(SimulationOf(vehicle, actuation));
}

const physics::BodyState& SubAircraftBody(const physics::Simulation& sim) {
  return sim.world().body(sim.output(0).sub_aircraft_bodies.front());
}

double RollOf(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d R = q.toRotationMatrix();
  return std::atan2(R(2, 1), R(2, 2));
}

// Rise (10-90 %), overshoot and 5 % settling of a sampled response to a step of `step` at t = 0.
StepFigures FiguresOf(const std::vector<double>& time_s, const std::vector<double>& response, double step) {
  StepFigures figures;
  double t10 = -1.0, t90 = -1.0, peak = 0.0;
  for (size_t k = 0; k < response.size(); ++k) {
    const double x = response[k] / step;
    if (t10 < 0.0 && x >= 0.1) t10 = time_s[k];
    if (t90 < 0.0 && x >= 0.9) t90 = time_s[k];
    peak = std::max(peak, x);
    if (std::abs(x - 1.0) > 0.05) figures.settling_time_s = time_s[k];
  }
  if (t10 < 0.0 || t90 < 0.0) throw std::runtime_error("the step response never reached 90 % of the step");
  figures.rise_time_s = t90 - t10;
  figures.overshoot = std::max(0.0, peak - 1.0);
  return figures;
}

}  // namespace

PeakResponse PredictStepForce(double mass_kg, double kp, double ki, double kd, double force_N) {
  // state: ∫x, x, x'; integrated by RK4 far below the loop's time constants
  using State = Eigen::Vector3d;
  const auto derivative = [&](const State& s) {
    return State(s(1), s(2), (force_N - kp * s(1) - ki * s(0) - kd * s(2)) / mass_kg);
  };
  PeakResponse response;
  State s = State::Zero();
  const double sign = force_N >= 0.0 ? 1.0 : -1.0;
  for (double t = 0.0; t < 20.0; t += kModelStep_s) {
    const State k1 = derivative(s), k2 = derivative(s + 0.5 * kModelStep_s * k1),
                k3 = derivative(s + 0.5 * kModelStep_s * k2), k4 = derivative(s + kModelStep_s * k3);
    s += kModelStep_s / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    if (sign * s(1) > response.peak) {
      response.peak = sign * s(1);
      response.peak_time_s = t + kModelStep_s;
    }
  }
  return response;
}

namespace {

// The platform's position along W axis `axis` at every physics step after `settle_s` of hover, with
// `force_N` along that axis on the platform from then on.
std::vector<double> HoverUnderStepForce(const model::Vehicle& vehicle, const control::TrackerGains& gains,
                                        int axis, double force_N, Actuation actuation, double settle_s,
                                        double duration_s) {
  HeldHover hover(SimulationOf(vehicle, actuation), gains);
  physics::Simulation& sim = hover.simulation();
  std::vector<double> positions_m;
  while (sim.time_s() < settle_s + duration_s) {
    hover.Control();
    if (sim.time_s() >= settle_s) {
      positions_m.push_back(hover.platform().p_WB_m[axis]);
      Eigen::Vector3d force_W_N = Eigen::Vector3d::Zero();
      force_W_N[axis] = force_N;
      sim.mutable_world().AddForce_W(sim.output(0).platform_body, force_W_N);
    }
    sim.Step();
  }
  return positions_m;
}

}  // namespace

PeakResponse MeasureStepForce(const model::Vehicle& vehicle, const control::TrackerGains& gains, int axis,
                              double force_N, Actuation actuation) {
  if (axis < 0 || axis > 2) throw std::invalid_argument("step force axis must be 0, 1 or 2");
  // the response is the pushed hover less the same hover unpushed: what the integral still corrects at the
  // start (a realistic drive's thrust error of a few percent) cancels, as in the linear model
  const double settle_s = 2.0, duration_s = 10.0;
  const std::vector<double> pushed =
      HoverUnderStepForce(vehicle, gains, axis, force_N, actuation, settle_s, duration_s);
  const std::vector<double> unpushed =
      HoverUnderStepForce(vehicle, gains, axis, 0.0, actuation, settle_s, duration_s);
  PeakResponse response;
  const double sign = force_N >= 0.0 ? 1.0 : -1.0;
  for (size_t k = 0; k < pushed.size() && k < unpushed.size(); ++k) {
    const double excursion_m = sign * (pushed[k] - unpushed[k]);
    if (excursion_m > response.peak) {
      response.peak = excursion_m;
      response.peak_time_s = k * kStep_s;
    }
  }
  return response;
}

model::Vehicle SingleSubAircraft(const model::Vehicle& vehicle) {
  if (vehicle.sub_aircraft.empty()) throw std::invalid_argument(vehicle.name + " has no sub-aircraft");
  model::Vehicle quadrotor;
  quadrotor.name = vehicle.sub_aircraft.front().name + "_alone";
  quadrotor.source_file = vehicle.source_file;
  quadrotor.platform.mass_kg = 0.001;
  quadrotor.platform.inertia_B_kgm2 = Eigen::Matrix3d::Identity() * 1e-8;
  model::SubAircraft sub = vehicle.sub_aircraft.front();
  sub.joint = model::JointType::kFixed;
  sub.joint_P_m.setZero();
  sub.initial_yaw_rad = 0.0;
  quadrotor.sub_aircraft.push_back(sub);
  return quadrotor;
}

StepFigures PredictAttitudeStep(const model::FlightControllerGains& gains, double motor_time_constant_s,
                                double step_rad) {
  std::vector<double> time_s, roll_rad;
  double roll = 0.0, rate = 0.0, integral = 0.0, acceleration = 0.0;
  int k = 0;
  for (double t = 0.0; t < 3.0; t += kModelStep_s, ++k) {
    const double rate_setpoint = std::clamp(gains.attitude_p_per_s.x() * (step_rad - roll),
                                            -gains.max_rate_rad_s.x(), gains.max_rate_rad_s.x());
    const double error = rate_setpoint - rate;
    integral = std::clamp(integral + gains.rate_i_per_s2.x() * error * kModelStep_s,
                          -gains.rate_integral_limit_rad_s2.x(), gains.rate_integral_limit_rad_s2.x());
    const double command = gains.rate_p_per_s.x() * error + integral;
    acceleration += (command - acceleration) * kModelStep_s / motor_time_constant_s;
    rate += acceleration * kModelStep_s;
    roll += rate * kModelStep_s;
    if (k % 100 == 0) {  // every millisecond, as the simulation is sampled
      time_s.push_back(t + kModelStep_s);
      roll_rad.push_back(roll);
    }
  }
  return FiguresOf(time_s, roll_rad, step_rad);
}

StepFigures MeasureAttitudeStep(const model::Vehicle& quadrotor, double step_rad, Actuation actuation) {
  std::unique_ptr<physics::Simulation> sim = MakeSimulation(quadrotor, actuation);
  physics::SubAircraftSetpoint setpoint;
  setpoint.thrust_N = quadrotor.TotalMass_kg() * kGravity_mps2;
  setpoint.q_WS = Eigen::Quaterniond(Eigen::AngleAxisd(step_rad, Eigen::Vector3d::UnitX()));
  std::vector<double> time_s, roll_rad;
  while (sim->time_s() < 3.0) {
    sim->SetCommand(0, 0, setpoint);
    sim->Step();
    time_s.push_back(sim->time_s());
    roll_rad.push_back(RollOf(SubAircraftBody(*sim).q_WB));
  }
  return FiguresOf(time_s, roll_rad, step_rad);
}

std::vector<RatePoint> SweepRateLoop(const model::Vehicle& quadrotor,
                                     const std::vector<double>& frequencies_hz, Actuation actuation) {
  constexpr double kAmplitude_radps = 0.5;
  std::vector<RatePoint> points;
  for (const double f : frequencies_hz) {
    std::unique_ptr<physics::Simulation> sim = MakeSimulation(quadrotor, actuation);
    const double w = 2.0 * M_PI * f;
    const double period_s = 1.0 / f;
    // settle the integral and the transient for 1 s (whole periods), then fit over whole periods, >= 2 s
    const double settle_s = std::ceil(1.0 / period_s) * period_s;
    const double fit_s = std::ceil(2.0 / period_s) * period_s;
    physics::SubAircraftSetpoint setpoint;
    setpoint.mode = physics::SubAircraftSetpoint::Mode::kBodyRate;
    setpoint.thrust_N = quadrotor.TotalMass_kg() * kGravity_mps2;
    // least squares of p(t) = a sin(wt) + b cos(wt) + c over the fit window: normal equations
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    while (sim->time_s() < settle_s + fit_s - 0.5 * kStep_s) {
      setpoint.w_WS_S = Eigen::Vector3d(kAmplitude_radps * std::sin(w * sim->time_s()), 0.0, 0.0);
      sim->SetCommand(0, 0, setpoint);
      sim->Step();
      const double t = sim->time_s();
      if (t <= settle_s + 0.5 * kStep_s) continue;
      const physics::BodyState& body = SubAircraftBody(*sim);
      const double roll_rate = (body.q_WB.conjugate() * body.w_WB_W).x();
      const Eigen::Vector3d basis(std::sin(w * t), std::cos(w * t), 1.0);
      normal += basis * basis.transpose();
      rhs += basis * roll_rate;
    }
    const Eigen::Vector3d ab = normal.ldlt().solve(rhs);
    const std::complex<double> T(ab.x() / kAmplitude_radps, ab.y() / kAmplitude_radps);
    const std::complex<double> L = T / (1.0 - T);
    points.push_back({f, std::abs(T), std::arg(T) * 180.0 / M_PI, std::abs(L), std::arg(L) * 180.0 / M_PI});
  }
  return points;
}

std::vector<RatePoint> PredictRateLoop(const model::FlightControllerGains& gains,
                                       double motor_time_constant_s,
                                       const std::vector<double>& frequencies_hz) {
  std::vector<RatePoint> points;
  for (const double f : frequencies_hz) {
    const std::complex<double> s(0.0, 2.0 * M_PI * f);
    const std::complex<double> L =
        (gains.rate_p_per_s.x() + gains.rate_i_per_s2.x() / s) / s / (motor_time_constant_s * s + 1.0);
    const std::complex<double> T = L / (1.0 + L);
    points.push_back({f, std::abs(T), std::arg(T) * 180.0 / M_PI, std::abs(L), std::arg(L) * 180.0 / M_PI});
  }
  return points;
}

Crossover CrossoverOf(const std::vector<RatePoint>& points) {
  for (size_t i = 1; i < points.size(); ++i) {
    const RatePoint& a = points[i - 1];
    const RatePoint& b = points[i];
    if (a.open_loop_gain >= 1.0 && b.open_loop_gain < 1.0) {
      const double u = std::log(a.open_loop_gain) / (std::log(a.open_loop_gain) - std::log(b.open_loop_gain));
      Crossover crossover;
      crossover.frequency_hz =
          std::exp(std::log(a.frequency_hz) + u * std::log(b.frequency_hz / a.frequency_hz));
      crossover.phase_margin_deg =
          180.0 + a.open_loop_phase_deg + u * (b.open_loop_phase_deg - a.open_loop_phase_deg);
      return crossover;
    }
  }
  return {};
}

std::vector<DischargePoint> HoverDischarge(const model::Vehicle& vehicle, double final_state_of_charge) {
  std::unique_ptr<physics::Simulation> sim = MakeSimulation(vehicle, Actuation::kRealistic);
  while (sim->time_s() < 2.0) sim->Step();  // the hover setpoints of the start, drives settled
  const physics::SubAircraftOutput& hover = sim->output(0).sub_aircraft.front();
  const double power_W = hover.battery_voltage_V * hover.battery_current_A;
  const model::Battery& battery = vehicle.sub_aircraft.front().battery;
  physics::BatteryPack pack(battery, 1.0);
  std::vector<DischargePoint> points;
  double next_mark = 1.0;
  for (double t = 0.0;; t += 1.0) {
    // the ESCs hold the power the rotors need: I = P / V(I), a fixed point reached in a few iterations
    double current_A = power_W / pack.Voltage_V(0.0);
    for (int i = 0; i < 5; ++i) current_A = power_W / pack.Voltage_V(current_A);
    const double soc = pack.state_of_charge();
    if (soc <= next_mark + 1e-9) {
      points.push_back({t, soc, pack.Voltage_V(current_A) / battery.cells, current_A});
      next_mark = next_mark > 0.15 ? next_mark - 0.1 : next_mark - 0.05;
    }
    if (soc <= final_state_of_charge) break;
    pack.Step(current_A, 1.0);
  }
  return points;
}

}  // namespace iapsim::tools
