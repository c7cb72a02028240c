#pragma once
// The physics process's configuration (the `params` of a scenario's physics process), read into a
// SimulationConfig. In-process users (benchmarks, RL) read the same section, so a scenario describes the
// world once for every way of running it.

#include <string>
#include <vector>

#include "bridge/config.h"
#include "physics/simulation.h"
#include "physics/uncertainty.h"

namespace iapsim::physics {

struct PhysicsConfig {
  SimulationConfig simulation;
  int substeps = 1;               // physics steps per publish step (the scenario's clock step)
  bool publish_contacts = true;   // /contacts: every contact point, every publish step
  std::vector<std::string> urdf;  // per vehicle: the URDF it was built from ("" when generated)
  // the true vehicles and wind are drawn from it with the run's seed (DrawTrueModel) before the simulation
  // is built
  UncertaintyConfig uncertainty;
};

/// Reads `params` (world, air, vehicles, actuation, uncertainty, latches, substeps, publish_contacts).
/// Relative file names resolve against the scenario file's folder, then the working folder; the resolved
/// values record absolute paths so a run restarts from its scenario.resolved.yaml. Throws bridge::ConfigError
/// naming the file, key and line.
PhysicsConfig ReadPhysicsConfig(bridge::YamlMap& params, const std::string& scenario_file,
                                double publish_step_s);

/// The physics of the scenario's clock process, which must be an iapsim_physics, as that process builds
/// it: `overrides` ("key.path=value", e.g. "fidelity=realistic") applied to the scenario, its params read,
/// the physics' seed of the run, and the model mismatch drawn with it. For in-process users (benchmarks, the
/// RL environments). Throws bridge::ConfigError naming the file.
PhysicsConfig LoadScenarioPhysics(const std::string& scenario_file,
                                  const std::vector<std::string>& overrides = {});

}  // namespace iapsim::physics
