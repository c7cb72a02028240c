#pragma once
// The Bullet IAP in-process for the closed-loop control tests: physics at 1 kHz with no ground, the vehicle
// at a start position, and the platform's state as the controller reads it.

#include <memory>
#include <string>
#include <vector>

#include "control/tracker.h"
#include "model/urdf.h"
#include "physics/simulation.h"

namespace iapsim::control::testing {

constexpr double kGravity = 9.81;
constexpr double kPhysicsStep_s = 0.001;
constexpr int kStepsPerControl = 5;  // 200 Hz, as in the paper

inline model::Vehicle LoadTestVehicle(const std::string& name) {
  return model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/" + name + ".yaml");
}

inline std::unique_ptr<physics::Simulation> MakeSimulation(
    const model::Vehicle& vehicle, const Eigen::Vector3d& p_WP_m,
    const std::vector<physics::WorldObject>& objects = {}) {
  physics::SimulationConfig world;
  world.step_s = kPhysicsStep_s;
  world.world.ground = false;
  world.world.gravity_mps2 = kGravity;
  world.world.objects = objects;
  physics::VehicleSpec spec;
  spec.name = vehicle.name;
  spec.vehicle = vehicle;
  spec.description = model::ParseUrdf(model::GenerateUrdf(vehicle), vehicle.name + ".urdf");
  spec.p_WP_m = p_WP_m;
  world.vehicles.push_back(spec);
  return std::make_unique<physics::Simulation>(world);
}

/// The platform's pose in W and twist in P, from the simulation's first vehicle.
inline PlatformState PlatformStateOf(const physics::Simulation& sim) {
  const physics::BodyState& body = sim.world().body(sim.output(0).platform_body);
  PlatformState state;
  state.p_WP_m = body.p_WB_m;
  state.q_WP = body.q_WB;
  state.v_WP_P_mps = body.q_WB.conjugate() * body.v_WB_W;
  state.w_WP_P_radps = body.q_WB.conjugate() * body.w_WB_W;
  return state;
}

}  // namespace iapsim::control::testing
