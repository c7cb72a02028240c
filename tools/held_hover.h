#pragma once
// The IAP controller holding a simulated IAP at its start pose, in-process and on the true state: the
// closed loop of a flight without the bus, for the fidelity references (tools/fidelity_reference.h) and
// for timing the physics of a flight (`iapsim bench physics`) where an uncontrolled vehicle would tumble.

#include <memory>

#include "control/iap_controller.h"
#include "physics/simulation.h"

namespace iapsim::tools {

class HeldHover {
 public:
  static constexpr double kControlPeriod_s = 0.005;  // the IAP controller at 200 Hz, as in the paper

  /// The first vehicle of `config` held at its start position and yaw under `gains` (Table II's by default);
  /// the controller knows the vehicle file's model (the flight controllers' model where one was drawn).
  explicit HeldHover(const physics::SimulationConfig& config,
                     const control::TrackerGains& gains = control::TrackerGains());

  /// The controller's update and the sub-aircraft's commands, when one is due at this step.
  void Control();
  /// Control(), then one physics step.
  void Step();

  physics::Simulation& simulation() { return *simulation_; }
  const physics::BodyState& platform() const;

 private:
  std::unique_ptr<physics::Simulation> simulation_;
  std::unique_ptr<control::IapController> controller_;
  control::PoseReference reference_;
  int steps_per_control_ = 1;
};

/// Physics steps per second of 5 s flights of `config` under HeldHover, counting only the physics steps.
double MeasureHeldHoverStepsPerSecond(const physics::SimulationConfig& config, int episode_steps,
                                      double min_seconds);

}  // namespace iapsim::tools
