#include "tools/held_hover.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace iapsim::tools {

HeldHover::HeldHover(const physics::SimulationConfig& config, const control::TrackerGains& gains) {
  if (config.vehicles.empty()) throw std::invalid_argument("a held hover needs a vehicle");
  const physics::VehicleSpec& spec = config.vehicles.front();
  control::IapControllerConfig controller_config;
  controller_config.gains = gains;
  controller_config.gravity_mps2 = config.world.gravity_mps2;
  controller_ = std::make_unique<control::IapController>(spec.flight_controller_model.value_or(spec.vehicle),
                                                         controller_config);
  reference_.p_WP_m = spec.p_WP_m;
  reference_.q_WP = Eigen::Quaterniond(Eigen::AngleAxisd(spec.yaw_rad, Eigen::Vector3d::UnitZ()));
  steps_per_control_ = std::max(1, static_cast<int>(std::lround(kControlPeriod_s / config.step_s)));
  simulation_ = std::make_unique<physics::Simulation>(config);
}

const physics::BodyState& HeldHover::platform() const {
  return simulation_->world().body(simulation_->output(0).platform_body);
}

void HeldHover::Control() {
  physics::Simulation& sim = *simulation_;
  if (sim.step_count() % steps_per_control_ != 0) return;
  const physics::BodyState& body = platform();
  control::PlatformState state;
  state.p_WP_m = body.p_WB_m;
  state.q_WP = body.q_WB;
  state.v_WP_P_mps = body.q_WB.conjugate() * body.v_WB_W;
  state.w_WP_P_radps = body.q_WB.conjugate() * body.w_WB_W;
  if (!controller_->Update(reference_, state, control::Vector6d::Zero(),
                           steps_per_control_ * sim.world().step_s())) {
    throw std::runtime_error("the IAP controller rejected a hover update (a non-finite state)");
  }
  const control::ControlOutput& output = controller_->output();
  for (size_t i = 0; i < output.sub_aircraft.size(); ++i) {
    physics::SubAircraftSetpoint setpoint;
    setpoint.thrust_N = output.sub_aircraft[i].thrust_N;
    setpoint.q_WS = output.sub_aircraft[i].q_WS;
    sim.SetCommand(0, static_cast<int>(i), setpoint);
  }
}

void HeldHover::Step() {
  Control();
  simulation_->Step();
}

double MeasureHeldHoverStepsPerSecond(const physics::SimulationConfig& config, int episode_steps,
                                      double min_seconds) {
  using Clock = std::chrono::steady_clock;
  int64_t steps = 0;
  double elapsed_s = 0.0;
  while (elapsed_s < min_seconds) {
    HeldHover hover(config);
    for (int k = 0; k < episode_steps; ++k) {
      hover.Control();
      const auto start = Clock::now();
      hover.simulation().Step();
      elapsed_s += std::chrono::duration<double>(Clock::now() - start).count();
    }
    steps += episode_steps;
  }
  return steps / elapsed_s;
}

}  // namespace iapsim::tools
