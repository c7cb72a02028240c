#pragma once
// Figures for `iapsim bench physics`: in-process physics steps per second of a Simulation, and of a bare
// Bullet multibody of the same size (no colliders, no rotors, no outputs) stepped the same way, the
// ceiling the simulation is compared against.

#include "physics/simulation.h"

namespace iapsim::physics {

/// Steps `simulation` for at least `min_seconds` of wall time (after a warm-up) and returns steps/s.
double MeasureStepsPerSecond(Simulation* simulation, double min_seconds);

/// Steps fresh simulations of `config` for `episode_steps` each, for at least `min_seconds` of stepping
/// (construction not counted), and returns steps/s: a flight that is not controlled in position stays the
/// flight it started as (in wind it would drift into the ground or its joints' limits given time).
double MeasureEpisodeStepsPerSecond(const SimulationConfig& config, int episode_steps, double min_seconds);

/// The same for a bare btMultiBody: a base and `links` spherical links with the masses of `vehicle`'s
/// platform and first sub-aircraft, constant link forces, gravity, 1 ms steps.
double MeasureBareMultibodyStepsPerSecond(const model::Vehicle& vehicle, int links, double min_seconds);

}  // namespace iapsim::physics
