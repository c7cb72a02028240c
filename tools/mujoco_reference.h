#pragma once
// The MuJoCo counterpart of `iapsim bench physics`'s contact scene, stepped in the same run for a ratio: a
// vehicle standing on its collision boxes on the ground plane, as MuJoCo bodies (the platform on a free
// joint, each sub-aircraft on a ball joint, the same masses, inertias and boxes, friction 0.5), 1 ms steps.
// MuJoCo 2.2 from Debian (libmujoco-dev) is used here only, as a reference; nothing else links it.

#include <string>

#include "model/vehicle.h"

namespace iapsim::tools {

struct MujocoFigures {
  std::string version;
  double steps_per_s = 0.0;
  int contacts = 0;
  double max_penetration_m = 0.0;  // over the measured steps (MuJoCo's contacts are soft)
  double weight_error_N = 0.0;     // |sum of the contacts' vertical forces − weight|, last step
  int solver_iterations = 0;       // of the last step
};

/// Where the vehicle's platform origin stands (z in NED) when its lowest collision box corner touches the
/// ground plane z = 0, level, joints at their initial positions. Boxes only, as below.
double RestingPlatformZ_m(const model::Vehicle& vehicle);

/// The vehicle's MJCF standing on z = 0 (NED, gravity +z), for MuJoCo's `solver` (Newton | CG | PGS).
/// Throws std::invalid_argument for a vehicle with shapes other than boxes.
std::string RestingVehicleMjcf(const model::Vehicle& vehicle, const std::string& solver);

/// Steps that scene for at least `min_seconds` after a 2 s settle and measures it.
MujocoFigures MeasureMujocoResting(const model::Vehicle& vehicle, const std::string& solver,
                                   double min_seconds);

}  // namespace iapsim::tools
