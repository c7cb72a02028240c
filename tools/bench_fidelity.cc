// iapsim bench fidelity: issue 19's reference checks of the closed loop, each beside the figure an
// independent model or a published value gives (tools/fidelity_reference.h): a 1 N step force on the hovering
// IAP against the linear loop of Table II's gains, the F450's PX4 cascade (a 10° attitude step and a stepped
// chirp of the rate loop) against its linear model and PX4's autotune target, and a LiPo pack's hover
// discharge against PX4's loaded full and empty cell voltages. Ideal: the paper's actuation; realistic: the
// electric drives on a full pack and the flight controllers on their gyroscopes.

#include <cstdio>

#include "model/vehicle.h"
#include "tools/commands.h"
#include "tools/fidelity_reference.h"

namespace iapsim::tools {
namespace {

constexpr double kDeg = M_PI / 180.0;

void BenchStepForce(const model::Vehicle& vehicle, nlohmann::json* report) {
  const control::TrackerGains gains;  // Table II
  const double mass_kg = vehicle.TotalMass_kg();
  std::printf(
      "1 N step force on the hovering %s, Table II gains; model m x'' + k_D x' + k_P x + k_I \u222bx = F,"
      " m = %.2f kg\n",
      vehicle.name.c_str(), mass_kg);
  std::printf("  %-5s %10s %8s %10s %8s %10s %8s\n", "axis", "model m", "at s", "ideal m", "at s",
              "realistic", "at s");
  const char* names[] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis) {
    const PeakResponse model = PredictStepForce(mass_kg, gains.kp[axis], gains.ki[axis], gains.kd[axis], 1.0);
    const PeakResponse ideal = MeasureStepForce(vehicle, gains, axis, 1.0, Actuation::kIdeal);
    const PeakResponse real = MeasureStepForce(vehicle, gains, axis, 1.0, Actuation::kRealistic);
    std::printf("  %-5s %10.4f %8.2f %10.4f %8.2f %10.4f %8.2f\n", names[axis], model.peak, model.peak_time_s,
                ideal.peak, ideal.peak_time_s, real.peak, real.peak_time_s);
    (*report)["step_force"].push_back({{"axis", names[axis]},
                                       {"model_peak_m", model.peak},
                                       {"model_peak_time_s", model.peak_time_s},
                                       {"ideal_peak_m", ideal.peak},
                                       {"ideal_peak_time_s", ideal.peak_time_s},
                                       {"realistic_peak_m", real.peak},
                                       {"realistic_peak_time_s", real.peak_time_s}});
  }
}

nlohmann::json StepJson(const StepFigures& f) {
  return {{"rise_time_s", f.rise_time_s}, {"overshoot", f.overshoot}, {"settling_time_s", f.settling_time_s}};
}

void BenchFlightController(const model::Vehicle& vehicle, nlohmann::json* report) {
  const model::Vehicle quadrotor = SingleSubAircraft(vehicle);
  const model::SubAircraft& sub = quadrotor.sub_aircraft.front();
  const model::FlightControllerGains& gains = sub.flight_controller;
  const double tau_s = sub.rotors.motor_time_constant_s;
  std::printf("\nflight controller of %s alone (roll; PX4 cascade as in its vehicle file, motor %.3f s)\n",
              sub.name.c_str(), tau_s);
  std::printf("  %-36s %8s %11s %12s\n", "10 deg attitude step", "rise s", "overshoot %", "settling s");
  const StepFigures model = PredictAttitudeStep(gains, tau_s, 10.0 * kDeg);
  const StepFigures ideal = MeasureAttitudeStep(quadrotor, 10.0 * kDeg, Actuation::kIdeal);
  const StepFigures real = MeasureAttitudeStep(quadrotor, 10.0 * kDeg, Actuation::kRealistic);
  for (const auto& [name, f] :
       {std::pair{"linear cascade model", model}, std::pair{"ideal", ideal}, std::pair{"realistic", real}}) {
    std::printf("  %-36s %8.3f %11.1f %12.3f\n", name, f.rise_time_s, 100.0 * f.overshoot, f.settling_time_s);
  }
  (*report)["attitude_step"] = {
      {"model", StepJson(model)}, {"ideal", StepJson(ideal)}, {"realistic", StepJson(real)}};

  const std::vector<double> frequencies_hz = {0.5, 0.7, 1.0, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0, 11.0, 16.0};
  const std::vector<RatePoint> predicted = PredictRateLoop(gains, tau_s, frequencies_hz);
  const std::vector<RatePoint> swept = SweepRateLoop(quadrotor, frequencies_hz, Actuation::kIdeal);
  const std::vector<RatePoint> swept_real = SweepRateLoop(quadrotor, frequencies_hz, Actuation::kRealistic);
  std::printf("  roll-rate loop, stepped chirp of +-0.5 rad/s: closed loop |T| and phase (deg)\n");
  std::printf("  %8s %16s %16s %16s\n", "Hz", "linear model", "ideal", "realistic");
  for (size_t i = 0; i < frequencies_hz.size(); ++i) {
    std::printf("  %8.1f %8.3f %7.1f %8.3f %7.1f %8.3f %7.1f\n", frequencies_hz[i],
                predicted[i].closed_loop_gain, predicted[i].closed_loop_phase_deg, swept[i].closed_loop_gain,
                swept[i].closed_loop_phase_deg, swept_real[i].closed_loop_gain,
                swept_real[i].closed_loop_phase_deg);
    (*report)["rate_loop"]["points"].push_back(
        {{"frequency_hz", frequencies_hz[i]},
         {"model_gain", predicted[i].closed_loop_gain},
         {"model_phase_deg", predicted[i].closed_loop_phase_deg},
         {"ideal_gain", swept[i].closed_loop_gain},
         {"ideal_phase_deg", swept[i].closed_loop_phase_deg},
         {"realistic_gain", swept_real[i].closed_loop_gain},
         {"realistic_phase_deg", swept_real[i].closed_loop_phase_deg}});
  }
  const Crossover model_crossover = CrossoverOf(predicted);
  const Crossover ideal_crossover = CrossoverOf(swept);
  std::printf(
      "  open-loop crossover: linear model %.2f Hz, phase margin %.0f deg; ideal (L = T / (1 - T),"
      " unity feedback) %.2f Hz, %.0f deg\n",
      model_crossover.frequency_hz, model_crossover.phase_margin_deg, ideal_crossover.frequency_hz,
      ideal_crossover.phase_margin_deg);
  // PX4's autotune designs the rate loop for MC_AT_RISE_TIME (default 0.14 s, range 0.01-0.5 s); a loop
  // that closes like a first-order one with that rise time crosses over at 2.2 / (2 pi t_r)
  std::printf("  PX4 reference: MC_AT_RISE_TIME 0.14 s (0.01-0.5 s) = crossover %.1f Hz (%.1f-%.0f Hz)\n",
              2.2 / (2.0 * M_PI * 0.14), 2.2 / (2.0 * M_PI * 0.5), 2.2 / (2.0 * M_PI * 0.01));
  (*report)["rate_loop"]["model_crossover_hz"] = model_crossover.frequency_hz;
  (*report)["rate_loop"]["model_phase_margin_deg"] = model_crossover.phase_margin_deg;
  (*report)["rate_loop"]["ideal_crossover_hz"] = ideal_crossover.frequency_hz;
  (*report)["rate_loop"]["ideal_phase_margin_deg"] = ideal_crossover.phase_margin_deg;
}

void BenchBattery(const model::Vehicle& vehicle, nlohmann::json* report) {
  const model::Battery& battery = vehicle.sub_aircraft.front().battery;
  const std::vector<DischargePoint> points = HoverDischarge(vehicle, 0.05);
  std::printf("\nbattery: a %dS %.0f mAh pack at the hover power of one %s sub-aircraft (%.0f W)\n",
              battery.cells, 1000.0 * battery.capacity_Ah, vehicle.name.c_str(),
              points.front().cell_voltage_V * battery.cells * points.front().current_A);
  std::printf("  %-8s %9s %10s %14s\n", "charge", "time min", "current A", "cell V (load)");
  for (const DischargePoint& p : points) {
    std::printf("  %6.0f %% %9.1f %10.1f %14.3f\n", 100.0 * p.state_of_charge, p.time_s / 60.0, p.current_A,
                p.cell_voltage_V);
    (*report)["battery"].push_back({{"state_of_charge", p.state_of_charge},
                                    {"time_s", p.time_s},
                                    {"current_A", p.current_A},
                                    {"cell_voltage_V", p.cell_voltage_V}});
  }
  std::printf(
      "  PX4 reference: a full cell under load 4.05 V (BAT1_V_CHARGED), empty 3.6 V (BAT1_V_EMPTY of v1.14;"
      " 3.5 V before: \"down to 10 %% before it drops off\")\n");
}

}  // namespace

int BenchFidelity(const std::string& vehicle_path, nlohmann::json* report) {
  const model::Vehicle vehicle = model::LoadVehicle(vehicle_path);
  std::printf("fidelity: the simulated closed loop against independent references (issue 19)\n");
  BenchStepForce(vehicle, &(*report)["fidelity"]);
  BenchFlightController(vehicle, &(*report)["fidelity"]);
  BenchBattery(vehicle, &(*report)["fidelity"]);
  return 0;
}

}  // namespace iapsim::tools
