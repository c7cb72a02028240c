// iapsim bench physics: in-process physics steps per second (1 ms steps, flight controllers and rotors
// running, every output computed) for the three-star IAP in the air and resting on the ground, and for IAPs
// of 2 to 8 sub-aircraft, each next to a bare Bullet multibody of the same size stepped in the same run; the
// resting IAP's contact solve from Bullet's defaults to iapsim's, beside MuJoCo on the same scene; a pole in
// the peg-in-hole flight's funnel with Bullet's contact breaking distance and with the flight's.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/benchmark.h"
#include "physics/physics_config.h"
#include "physics/simulation.h"
#include "tools/commands.h"
#include "tools/held_hover.h"
#include "tools/mujoco_reference.h"

namespace iapsim::tools {
namespace {

std::string Ratio(double ratio) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2fx", ratio);
  return text;
}

constexpr double kSecondsPerFigure = 1.0;
// the air and joint models are compared over 5 s flights from the start, against still air the same way
constexpr int kEpisodeSteps = 5000;

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

physics::SimulationConfig Scene(const model::Vehicle& vehicle, bool contacts,
                                const physics::WorldConfig& world) {
  physics::SimulationConfig config;
  config.world = world;  // with the ground: in the air it is 2 m below, as in a flight
  physics::VehicleSpec spec;
  spec.name = "iap";
  spec.vehicle = vehicle;
  spec.description = model::ParseUrdf(model::GenerateUrdf(vehicle), vehicle.name + ".urdf");
  // resting: its collision boxes stand on the ground, idle rotors
  spec.p_WP_m = Eigen::Vector3d(0.0, 0.0, contacts ? RestingPlatformZ_m(vehicle) : -2.0);
  spec.initial_rotors = contacts ? physics::InitialRotors::kIdle : physics::InitialRotors::kHover;
  config.vehicles.push_back(spec);
  return config;
}

// In the air (the ground 2 m below), hovering; or resting on the ground with idle rotors.
double Measure(const model::Vehicle& vehicle, bool contacts, const physics::WorldConfig& world = {}) {
  physics::Simulation simulation(Scene(vehicle, contacts, world));
  return physics::MeasureStepsPerSecond(&simulation, kSecondsPerFigure);
}

// In the air as above, in a 4 m/s wind with light Dryden turbulence, drag on every part (the F450's C_d·A as
// in the README's example), rotor drag, ground effect and downwash (issue 19's air), and joint friction and
// cone limits (the README's example): what those models cost against still air and ideal joints. `actuated`
// adds the electric drives and the flight controllers' own gyroscopes (issue 19's actuation).
double MeasureInGustyAir(model::Vehicle vehicle, bool downwash = true, bool actuated = false) {
  vehicle.platform_drag_area_B_m2 = Eigen::Vector3d(0.01, 0.01, 0.04);
  for (auto& sub : vehicle.sub_aircraft) {
    sub.drag_area_B_m2 = Eigen::Vector3d(0.03, 0.03, 0.06);
    sub.joint_resistance = {0.005, 0.02, 35.0 * M_PI / 180.0};
  }
  physics::SimulationConfig config = Scene(vehicle, false, {});
  config.air.enabled = true;
  config.air.wind_W_mps = Eigen::Vector3d(4.0, 0.0, 0.0);
  config.air.turbulence = true;
  config.air.downwash = downwash;
  config.actuation.enabled = actuated;
  if (actuated) config.flight_controller_sensing = physics::FlightControllerSensing::kGyro;
  return physics::MeasureEpisodeStepsPerSecond(config, kEpisodeSteps, kSecondsPerFigure);
}

// The physics of `scenario_file`'s physics process in `fidelity`, as that process builds it.
physics::SimulationConfig ScenarioPhysics(const std::string& scenario_file, const std::string& fidelity) {
  return physics::LoadScenarioPhysics(scenario_file, {"fidelity=" + fidelity}).simulation;
}

// Issue 19's budget: the realistic profile may cost at most 1.3 times the ideal one. Both profiles of the
// scenario's physics, held at the scenario's start by the IAP controller (uncontrolled, the realistic
// IAP's mismatched CoM tips it over within 2 s and its wakes then meet its own platform), physics steps
// only; short runs of each in turn and the median of the pairs' ratios, as against MuJoCo below (figures a
// second apart differed by 0.05 in the ratio on a shared machine).
void BenchProfiles(const std::string& scenario_file, nlohmann::json* report) {
  const physics::SimulationConfig ideal_config = ScenarioPhysics(scenario_file, "ideal");
  const physics::SimulationConfig realistic_config = ScenarioPhysics(scenario_file, "realistic");
  constexpr int kPairs = 7;
  std::vector<double> ideal, realistic, costs;
  for (int i = 0; i < kPairs; ++i) {
    ideal.push_back(MeasureHeldHoverStepsPerSecond(ideal_config, kEpisodeSteps, kSecondsPerFigure / 2));
    realistic.push_back(
        MeasureHeldHoverStepsPerSecond(realistic_config, kEpisodeSteps, kSecondsPerFigure / 2));
    costs.push_back(ideal.back() / realistic.back());
  }
  for (auto* figures : {&ideal, &realistic, &costs}) std::sort(figures->begin(), figures->end());
  const double cost = costs[kPairs / 2];
  std::printf("  %-38s %10.0f\n", "scenario's physics, fidelity: ideal", ideal[kPairs / 2]);
  std::printf(
      "  %-38s %10.0f  (costs %s ideal, median of %d pairs of runs in turn, %s-%s; issue 19's "
      "budget 1.3x)\n",
      "... fidelity: realistic", realistic[kPairs / 2], Ratio(cost).c_str(), kPairs,
      Ratio(costs.front()).c_str(), Ratio(costs.back()).c_str());
  (*report)["profiles"] = {{"scenario", scenario_file},
                           {"ideal_steps_per_s", ideal[kPairs / 2]},
                           {"realistic_steps_per_s", realistic[kPairs / 2]},
                           {"realistic_cost", cost},
                           {"realistic_cost_pairs", costs}};
}

struct ContactFigures {
  double steps_per_s = 0.0;
  size_t contacts = 0;
  double max_penetration_m = 0.0;
  double weight_error_N = 0.0;  // |contact force on the vehicle + weight − rotor thrust|, last step
};

// The vehicle resting on the ground with these solver settings: speed, then 1 s more for the accuracy.
ContactFigures MeasureResting(const model::Vehicle& vehicle, const physics::WorldConfig& world,
                              double seconds = kSecondsPerFigure) {
  physics::Simulation simulation(Scene(vehicle, true, world));
  ContactFigures figures;
  figures.steps_per_s = physics::MeasureStepsPerSecond(&simulation, seconds);
  for (int k = 0; k < 1000; ++k) {
    simulation.Step();
    for (const physics::Contact& contact : simulation.world().contacts()) {
      figures.max_penetration_m = std::max(figures.max_penetration_m, -contact.depth_m);
    }
  }
  const physics::VehicleOutput& out = simulation.output(0);
  Eigen::Vector3d thrust_W_N = Eigen::Vector3d::Zero();
  for (const auto& sub : out.sub_aircraft) thrust_W_N += sub.thrust_W_N;
  figures.contacts = simulation.world().contacts().size();
  figures.weight_error_N =
      (out.external_force_W_N + thrust_W_N + Eigen::Vector3d(0.0, 0.0, vehicle.TotalMass_kg() * 9.81)).norm();
  return figures;
}

// iapsim's contact solve step by step from Bullet's defaults to today's, and MuJoCo on the same scene.
void BenchContact(const model::Vehicle& vehicle, double air_steps_per_s, nlohmann::json* report) {
  struct Row {
    std::string name;
    physics::WorldConfig world;
  };
  physics::WorldConfig before;  // main before issue 18: Bullet's rows solved cold, every iteration
  before.warm_start = false;
  before.solver_tolerance_mps = 0.0;
  before.factored_contact_rows = false;
  before.sleep_after_s = 0.0;
  physics::WorldConfig warm = before;
  warm.warm_start = true;
  warm.solver_tolerance_mps = physics::WorldConfig().solver_tolerance_mps;
  physics::WorldConfig factored = warm;
  factored.factored_contact_rows = true;
  const std::vector<Row> rows = {
      {"before: cold, 50 iterations, Bullet's rows", before},
      {"warm started, tolerance 1e-7 m/s", warm},
      {"+ factored rows (awake)", factored},
      {"+ sleeping at rest (default)", physics::WorldConfig()},
  };
  std::printf("\ncontact: %s on its boxes on the ground, 1 ms steps (rotors idle, flight controllers on)\n",
              vehicle.name.c_str());
  // "us - air": a step's cost beyond a step in the air; negative asleep, where the dynamics are skipped too
  std::printf("  %-44s %10s %8s %11s %13s %12s\n", "", "steps/s", "x before", "us - air", "penetration m",
              "weight err N");
  double before_steps_per_s = 0.0;
  for (const Row& row : rows) {
    const ContactFigures f = MeasureResting(vehicle, row.world);
    if (before_steps_per_s == 0.0) before_steps_per_s = f.steps_per_s;
    const double contact_us = 1e6 / f.steps_per_s - 1e6 / air_steps_per_s;
    std::printf("  %-44s %10.0f %8.2f %11.1f %13.2e %12.2e\n", row.name.c_str(), f.steps_per_s,
                f.steps_per_s / before_steps_per_s, contact_us, f.max_penetration_m, f.weight_error_N);
    (*report)["contact"]["iapsim"].push_back({{"configuration", row.name},
                                              {"steps_per_s", f.steps_per_s},
                                              {"contacts", f.contacts},
                                              {"contact_us_per_step", contact_us},
                                              {"max_penetration_m", f.max_penetration_m},
                                              {"weight_error_N", f.weight_error_N}});
  }
  for (const std::string solver : {"Newton", "CG"}) {
    const MujocoFigures f = MeasureMujocoResting(vehicle, solver, kSecondsPerFigure);
    const std::string name = "MuJoCo " + f.version + " " + solver + " (no rotors, no controllers)";
    std::printf("  %-44s %10.0f %8.2f %11s %13.2e %12.2e\n", name.c_str(), f.steps_per_s,
                f.steps_per_s / before_steps_per_s, "", f.max_penetration_m, f.weight_error_N);
    (*report)["contact"]["mujoco"].push_back({{"solver", solver},
                                              {"version", f.version},
                                              {"steps_per_s", f.steps_per_s},
                                              {"contacts", f.contacts},
                                              {"max_penetration_m", f.max_penetration_m},
                                              {"weight_error_N", f.weight_error_N},
                                              {"solver_iterations", f.solver_iterations}});
  }
  std::printf("  %-44s %10.0f\n", "iapsim in the air (no contact)", air_steps_per_s);
  // iapsim's rate over MuJoCo's from short runs of each in turn, the median of the pairs: a shared machine's
  // speed can change from one second to the next, and figures a few seconds apart carried that into the ratio
  // (0.73-1.49x for the same two builds)
  constexpr int kPairs = 5;
  for (const auto& [configuration, world] :
       {std::pair{"awake", rows[rows.size() - 2].world}, std::pair{"default", rows.back().world}}) {
    for (const std::string solver : {"Newton", "CG"}) {
      std::vector<double> ratios;
      for (int i = 0; i < kPairs; ++i) {
        const double ours = MeasureResting(vehicle, world, kSecondsPerFigure / kPairs).steps_per_s;
        ratios.push_back(ours /
                         MeasureMujocoResting(vehicle, solver, kSecondsPerFigure / kPairs).steps_per_s);
      }
      std::sort(ratios.begin(), ratios.end());
      std::printf("  iapsim %s / MuJoCo %s %s (median of %d pairs of runs in turn; %s-%s)\n", configuration,
                  solver.c_str(), Ratio(ratios[kPairs / 2]).c_str(), kPairs, Ratio(ratios.front()).c_str(),
                  Ratio(ratios.back()).c_str());
      (*report)["contact"]["vs_mujoco"][configuration][solver] = ratios[kPairs / 2];
      (*report)["contact"]["vs_mujoco_pairs"][configuration][solver] = ratios;
    }
  }
}

// The peg-in-hole's contact in miniature: a pole 30 mm thick and 0.3 m long (0.3 kg, a multibody link as a
// vehicle's tool is) dropped into the peg-in-hole flight's funnel, mouth up, and leaning in its 50 mm hole
// after 2 s, kept awake, collided within Bullet's breaking distance (3.5 mm for the funnel) and within the
// flight's own `contact_breaking_distance_m`: steps/s and the contact points a solve is given, in pairs of
// runs in turn.
void BenchConformalContact(const std::string& peg_scenario, nlohmann::json* report) {
  const physics::WorldConfig flight_world = physics::LoadScenarioPhysics(peg_scenario).simulation.world;
  const auto funnel =
      std::find_if(flight_world.objects.begin(), flight_world.objects.end(),
                   [](const physics::WorldObject& object) { return object.name == "funnel"; });
  if (funnel == flight_world.objects.end()) {
    throw std::runtime_error(peg_scenario + ": expected a world object named 'funnel'");
  }
  const double flight_breaking_m = flight_world.contact_breaking_distance_m;
  const model::MultibodyDescription pole = model::SolidCylinder("pole", 0.3, 0.015, 0.3);
  struct Figures {
    double steps_per_s = 0.0;
    double points_per_solve = 0.0;
  };
  const auto measure = [&](double breaking_m, double seconds) {
    physics::SimulationConfig config;
    config.world.sleep_after_s = 0.0;
    config.world.contact_breaking_distance_m = breaking_m;
    physics::WorldObject upright = *funnel;
    upright.p_WO_m = Eigen::Vector3d(0.0, 0.0, -0.5);  // mouth up (NED), 0.5 m above the ground
    upright.q_WO = Eigen::Quaterniond::Identity();
    config.world.objects = {upright};
    physics::Simulation simulation(config);
    // its lower end 2 cm above the mouth and 4 cm off the axis
    simulation.mutable_world().AddMultibody("pole", pole, Eigen::Vector3d(0.04, 0.0, -0.5 - 0.02 - 0.15),
                                            Eigen::Quaterniond::Identity());
    for (int k = 0; k < 2000; ++k) simulation.Step();
    const physics::SolverStats settled = simulation.world().solver_stats();
    Figures figures;
    figures.steps_per_s = physics::MeasureStepsPerSecond(&simulation, seconds);
    const physics::SolverStats& stats = simulation.world().solver_stats();
    figures.points_per_solve = static_cast<double>(stats.contact_points - settled.contact_points) /
                               static_cast<double>(std::max<uint64_t>(1, stats.solves - settled.solves));
    return figures;
  };
  constexpr int kPairs = 5;
  std::vector<double> bullet, capped, ratios;
  Figures last_bullet, last_capped;
  for (int i = 0; i < kPairs; ++i) {
    last_bullet = measure(0.0, kSecondsPerFigure / kPairs);
    last_capped = measure(flight_breaking_m, kSecondsPerFigure / kPairs);
    bullet.push_back(last_bullet.steps_per_s);
    capped.push_back(last_capped.steps_per_s);
    ratios.push_back(last_capped.steps_per_s / last_bullet.steps_per_s);
  }
  for (auto* figures : {&bullet, &capped, &ratios}) std::sort(figures->begin(), figures->end());
  std::printf("\nconformal contact: a 30 mm pole leaning in the funnel's 50 mm hole, awake, 1 ms steps\n");
  std::printf("  %-44s %10s %18s\n", "", "steps/s", "points a solve");
  std::printf("  %-44s %10.0f %18.1f\n", "Bullet's breaking distance (3.5 mm here)", bullet[kPairs / 2],
              last_bullet.points_per_solve);
  char capped_name[64];
  std::snprintf(capped_name, sizeof(capped_name), "the flight's distance (%g m)",
                flight_breaking_m);
  std::printf("  %-44s %10.0f %18.1f  (%s, median of %d pairs of runs in turn, %s-%s)\n", capped_name,
              capped[kPairs / 2], last_capped.points_per_solve, Ratio(ratios[kPairs / 2]).c_str(), kPairs,
              Ratio(ratios.front()).c_str(), Ratio(ratios.back()).c_str());
  (*report)["conformal_contact"] = {{"scenario", peg_scenario},
                                    {"contact_breaking_distance_m", flight_breaking_m},
                                    {"bullet_steps_per_s", bullet[kPairs / 2]},
                                    {"capped_steps_per_s", capped[kPairs / 2]},
                                    {"bullet_points_per_solve", last_bullet.points_per_solve},
                                    {"capped_points_per_solve", last_capped.points_per_solve},
                                    {"speedup", ratios[kPairs / 2]},
                                    {"speedup_pairs", ratios}};
}

}  // namespace

int BenchPhysics(const std::string& vehicle_path, const std::string& scenario_path, nlohmann::json* report) {
  const model::Vehicle three_star = model::LoadVehicle(vehicle_path);
  const int n_star = static_cast<int>(three_star.sub_aircraft.size());
  std::printf("physics steps/s, in process, one core, 1 ms steps (%.0f s per figure)\n", kSecondsPerFigure);
  physics::WorldConfig awake;  // the contact solved every step: what a vehicle pushing on something costs
  awake.sleep_after_s = 0.0;
  const double air = Measure(three_star, false);
  const double ground = Measure(three_star, true, awake);
  const double asleep = Measure(three_star, true);
  const double still =
      physics::MeasureEpisodeStepsPerSecond(Scene(three_star, false, {}), kEpisodeSteps, kSecondsPerFigure);
  const double gusty = MeasureInGustyAir(three_star);
  const double no_downwash = MeasureInGustyAir(three_star, false);
  const double actuated = MeasureInGustyAir(three_star, true, true);
  const double bare = physics::MeasureBareMultibodyStepsPerSecond(three_star, n_star, kSecondsPerFigure);
  std::printf("  %-38s %10.0f  (%.2f of bare Bullet)\n", (three_star.name + ", in the air").c_str(), air,
              air / bare);
  std::printf("  %-38s %10.0f  (%.2f of bare Bullet, %.2f of in the air)\n",
              (three_star.name + ", resting on the ground").c_str(), ground, ground / bare, ground / air);
  std::printf("  %-38s %10.0f  (%.2f of in the air)\n", (three_star.name + ", ... asleep (default)").c_str(),
              asleep, asleep / air);
  std::printf("  %-38s %10.0f  (%.2f of still air, ideal joints: %.0f, 5 s flights)\n",
              (three_star.name + ", gusty air, joint friction").c_str(), gusty, gusty / still, still);
  std::printf("  %-38s %10.0f  (%.2f of still air; with it %.2f of this)\n", "... without downwash",
              no_downwash, no_downwash / still, gusty / no_downwash);
  std::printf("  %-38s %10.0f  (%.2f of still air)\n", "... with electric drives, FC gyroscopes", actuated,
              actuated / still);
  std::printf("  %-38s %10.0f\n", "bare Bullet multibody, same size", bare);
  std::printf("  held at the start of %s by the IAP controller, 5 s flights:\n", scenario_path.c_str());
  BenchProfiles(scenario_path, &(*report)["physics"]);
  (*report)["physics"]["vehicle"] = three_star.name;
  (*report)["physics"]["air_steps_per_s"] = air;
  (*report)["physics"]["ground_steps_per_s"] = ground;
  (*report)["physics"]["ground_asleep_steps_per_s"] = asleep;
  (*report)["physics"]["bare_steps_per_s"] = bare;
  (*report)["physics"]["gusty_air_steps_per_s"] = gusty;
  (*report)["physics"]["gusty_air_no_downwash_steps_per_s"] = no_downwash;
  (*report)["physics"]["gusty_air_actuated_steps_per_s"] = actuated;
  (*report)["physics"]["still_air_episode_steps_per_s"] = still;
  BenchContact(three_star, air, &(*report)["physics"]);
  BenchConformalContact("configs/regression/peg_in_hole.yaml", &(*report)["physics"]);

  std::printf("\n  %3s %12s %8s %12s %12s %14s\n", "n", "in the air", "vs bare", "on ground", "bare",
              "us/step (air)");
  std::printf("  %3s %12s %8s %12s\n", "", "", "", "(awake)");
  double first_us = 0.0;
  for (const int n : {2, 3, 4, 6, 8}) {
    const model::Vehicle vehicle = WithSubAircraft(three_star, n);
    const double a = Measure(vehicle, false);
    const double g = Measure(vehicle, true, awake);
    const double b = physics::MeasureBareMultibodyStepsPerSecond(three_star, n, kSecondsPerFigure);
    const double us = 1e6 / a;
    if (first_us == 0.0) first_us = us;
    std::printf("  %3d %12.0f %8.2f %12.0f %12.0f %9.1f (x%.2f)\n", n, a, a / b, g, b, us, us / first_us);
    nlohmann::json row{
        {"sub_aircraft", n}, {"air_steps_per_s", a}, {"ground_steps_per_s", g}, {"bare_steps_per_s", b}};
    (*report)["physics"]["by_sub_aircraft"].push_back(row);
  }
  return 0;
}

}  // namespace iapsim::tools
