#include "physics/benchmark.h"

#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <btBulletDynamicsCommon.h>

#include <chrono>
#include <cmath>

namespace iapsim::physics {
namespace {

using Clock = std::chrono::steady_clock;

// Runs `step` in batches until `min_seconds` have passed; returns steps per second.
template <class Step>
double Rate(const Step& step, double min_seconds) {
  for (int k = 0; k < 2000; ++k) step();  // warm-up: caches, contact manifolds
  int64_t steps = 0;
  const auto start = Clock::now();
  double elapsed = 0.0;
  while (elapsed < min_seconds) {
    for (int k = 0; k < 1000; ++k) step();
    steps += 1000;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  }
  return steps / elapsed;
}

}  // namespace

double MeasureStepsPerSecond(Simulation* simulation, double min_seconds) {
  return Rate([simulation] { simulation->Step(); }, min_seconds);
}

double MeasureEpisodeStepsPerSecond(const SimulationConfig& config, int episode_steps, double min_seconds) {
  int64_t steps = 0;
  double elapsed = 0.0;
  while (elapsed < min_seconds) {
    Simulation simulation(config);
    const auto start = Clock::now();
    for (int k = 0; k < episode_steps; ++k) simulation.Step();
    elapsed += std::chrono::duration<double>(Clock::now() - start).count();
    steps += episode_steps;
  }
  return steps / elapsed;
}

double MeasureBareMultibodyStepsPerSecond(const model::Vehicle& vehicle, int links, double min_seconds) {
  btDefaultCollisionConfiguration collision_config;
  btCollisionDispatcher dispatcher(&collision_config);
  btDbvtBroadphase broadphase;
  btMultiBodyConstraintSolver solver;
  btMultiBodyDynamicsWorld world(&dispatcher, &broadphase, &solver, &collision_config);
  world.setGravity(btVector3(0.0, 0.0, 9.81));
  const Eigen::Vector3d platform = vehicle.platform.inertia_B_kgm2.diagonal();
  const model::SubAircraft& sub = vehicle.sub_aircraft.front();
  const Eigen::Vector3d inertia = sub.mass.inertia_B_kgm2.diagonal();
  btMultiBody body(links, vehicle.platform.mass_kg, btVector3(platform.x(), platform.y(), platform.z()), false,
                   false);
  for (int i = 0; i < links; ++i) {
    const double angle = 2.0 * M_PI * i / links;
    body.setupSpherical(i, sub.mass.mass_kg, btVector3(inertia.x(), inertia.y(), inertia.z()), -1,
                        btQuaternion::getIdentity(), btVector3(0.5 * std::cos(angle), 0.5 * std::sin(angle), 0.07),
                        btVector3(0.0, 0.0, 0.0), true);
  }
  body.finalizeMultiDof();
  body.setLinearDamping(0.0);
  body.setAngularDamping(0.0);
  body.setCanSleep(false);
  world.addMultiBody(&body);
  const double hover_N = -(vehicle.platform.mass_kg + links * sub.mass.mass_kg) * 9.81 / links;
  const double rate = Rate(
      [&] {
        for (int i = 0; i < links; ++i) body.addLinkForce(i, btVector3(0.0, 0.0, hover_N));
        world.stepSimulation(0.001, 0);
      },
      min_seconds);
  world.removeMultiBody(&body);
  return rate;
}

}  // namespace iapsim::physics
