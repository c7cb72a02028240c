// iapsim bench physics: in-process physics steps per second (1 ms steps, flight controllers and rotors
// running, every output computed) for the three-star IAP in the air and resting on the ground, and for IAPs
// of 2 to 8 sub-aircraft, each next to a bare Bullet multibody of the same size stepped in the same run.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/benchmark.h"
#include "physics/simulation.h"
#include "tools/commands.h"

namespace iapsim::tools {
namespace {

constexpr double kSecondsPerFigure = 1.0;

// The vehicle with n copies of its first sub-aircraft on a circle wide enough that their boxes never touch.
model::Vehicle WithSubAircraft(const model::Vehicle& base, int n) {
  model::Vehicle vehicle = base;
  vehicle.name = base.name + "_n" + std::to_string(n);
  vehicle.sub_aircraft.clear();
  // neighbours one box diagonal (0.64 m) plus 5 cm apart, whatever their yaw
  const double radius_m = std::max(0.48, 0.345 / std::sin(M_PI / n));
  for (int i = 0; i < n; ++i) {
    model::SubAircraft sub = base.sub_aircraft.front();
    sub.name = "sub" + std::to_string(i + 1);
    const double angle = 2.0 * M_PI * i / n;
    sub.joint_P_m = Eigen::Vector3d(radius_m * std::cos(angle), radius_m * std::sin(angle), 0.07);
    sub.initial_yaw_rad = angle;
    vehicle.sub_aircraft.push_back(sub);
  }
  return vehicle;
}

// In the air (no ground), hovering; or resting on the ground with idle rotors.
double Measure(const model::Vehicle& vehicle, bool contacts) {
  physics::SimulationConfig config;
  config.world.ground = contacts;
  physics::VehicleSpec spec;
  spec.name = "iap";
  spec.vehicle = vehicle;
  spec.description = model::ParseUrdf(model::GenerateUrdf(vehicle), vehicle.name + ".urdf");
  // resting: the sub-aircraft boxes (0.10 m tall, centred 0.07 m below P) stand on the ground
  spec.p_WP_m = contacts ? Eigen::Vector3d(0.0, 0.0, -0.12) : Eigen::Vector3d(0.0, 0.0, -2.0);
  spec.initial_rotors = contacts ? physics::InitialRotors::kIdle : physics::InitialRotors::kHover;
  config.vehicles.push_back(spec);
  physics::Simulation simulation(config);
  return physics::MeasureStepsPerSecond(&simulation, kSecondsPerFigure);
}

}  // namespace

int BenchPhysics(const std::string& vehicle_path, nlohmann::json* report) {
  const model::Vehicle three_star = model::LoadVehicle(vehicle_path);
  const int n_star = static_cast<int>(three_star.sub_aircraft.size());
  std::printf("physics steps/s, in process, one core, 1 ms steps (%.0f s per figure)\n", kSecondsPerFigure);
  const double air = Measure(three_star, false);
  const double ground = Measure(three_star, true);
  const double bare = physics::MeasureBareMultibodyStepsPerSecond(three_star, n_star, kSecondsPerFigure);
  std::printf("  %-38s %10.0f  (%.2f of bare Bullet)\n", (three_star.name + ", in the air").c_str(), air, air / bare);
  std::printf("  %-38s %10.0f  (%.2f of bare Bullet)\n", (three_star.name + ", resting on the ground").c_str(),
              ground, ground / bare);
  std::printf("  %-38s %10.0f\n", "bare Bullet multibody, same size", bare);
  (*report)["physics"]["vehicle"] = three_star.name;
  (*report)["physics"]["air_steps_per_s"] = air;
  (*report)["physics"]["ground_steps_per_s"] = ground;
  (*report)["physics"]["bare_steps_per_s"] = bare;

  std::printf("\n  %3s %12s %8s %12s %12s %14s\n", "n", "in the air", "vs bare", "on ground", "bare", "us/step (air)");
  double first_us = 0.0;
  for (const int n : {2, 3, 4, 6, 8}) {
    const model::Vehicle vehicle = WithSubAircraft(three_star, n);
    const double a = Measure(vehicle, false);
    const double g = Measure(vehicle, true);
    const double b = physics::MeasureBareMultibodyStepsPerSecond(three_star, n, kSecondsPerFigure);
    const double us = 1e6 / a;
    if (first_us == 0.0) first_us = us;
    std::printf("  %3d %12.0f %8.2f %12.0f %12.0f %9.1f (x%.2f)\n", n, a, a / b, g, b, us, us / first_us);
    nlohmann::json row{{"sub_aircraft", n}, {"air_steps_per_s", a}, {"ground_steps_per_s", g},
                       {"bare_steps_per_s", b}};
    (*report)["physics"]["by_sub_aircraft"].push_back(row);
  }
  return 0;
}

}  // namespace iapsim::tools
