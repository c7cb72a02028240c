#pragma once
// A vehicle's look, from its description (model/vehicle.h): the platform with its arms, tools and joints,
// and each sub-aircraft, every part on the body that physics moves. A body's own mesh file is used when the
// vehicle names one; otherwise its shapes are drawn, and a sub-aircraft without a mesh is drawn as the
// quadrotor its rotor set describes (frame, arms to the hubs, motors, propeller discs).

#include <string>

#include "model/vehicle.h"
#include "render/scene.h"

namespace iapsim::render {

/// The body names a vehicle's objects use: "<vehicle>/platform" and "<vehicle>/<sub-aircraft name>", as
/// physics names them in iapsim_msgs/IapState's bodies (platform first, then the sub-aircraft).
std::string PlatformBody(const std::string& vehicle);
std::string SubAircraftBody(const std::string& vehicle, const model::SubAircraft& sub);

/// Adds the vehicle's objects to `scene`, named after `vehicle` (the scenario's vehicle name, e.g. "iap").
/// Throws std::invalid_argument naming a mesh file that cannot be read.
void AddVehicle(Scene* scene, const model::Vehicle& description, const std::string& vehicle);

}  // namespace iapsim::render
