// Model mismatch (physics/uncertainty.h): the draws' distributions, seeding and independence, what a draw
// changes in the vehicle the physics flies and what it leaves to the flight controllers, and the physics of
// a mismatched vehicle against Newton's law.
#include "physics/uncertainty.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/physics_config.h"
#include "physics/simulation.h"

namespace iapsim::physics {
namespace {

const std::string kThreeStar = std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml";

PhysicsConfig Read(const std::string& uncertainty, const std::string& extra = "") {
  bridge::YamlMap params(
      YAML::Load("vehicles:\n  - {name: iap, file: " + kThreeStar + ", position_m: [0, 0, -2]}\n" + extra +
                 "uncertainty: " + uncertainty + "\n"),
      "test.yaml");
  return ReadPhysicsConfig(params, "test.yaml", 0.001);
}

// what was drawn, relative to the nominal value (absolute where that is 0)
std::map<std::string, double> Draw(PhysicsConfig config, uint64_t seed, PhysicsConfig* config_out = nullptr) {
  std::map<std::string, double> drawn;
  for (const DrawnParameter& p : DrawTrueModel(config.uncertainty, seed, &config.simulation)) {
    drawn[p.name] = p.drawn / (p.nominal != 0.0 ? p.nominal : 1.0);
  }
  if (config_out) *config_out = config;
  return drawn;
}

std::map<std::string, double> Draw(const std::string& uncertainty, uint64_t seed,
                                   PhysicsConfig* config_out = nullptr) {
  return Draw(Read(uncertainty, "air: {}\n"), seed, config_out);
}

TEST(Uncertainty, IsReadAndCheckedNamingTheKey) {
  const UncertaintyConfig read =
      Read(
          "{mass: {normal: 0.05}, inertia: {uniform: 0.1}, platform_com_P_m: [0.03, 0, -0.01],"
          " thrust_coefficient: -0.04, torque_coefficient: {normal: 0.1},"
          " wind_W_mps: {normal: [1, 1, 0.2]}}",
          "air: {}\n")
          .uncertainty;
  EXPECT_TRUE(read.enabled);
  EXPECT_EQ(read.mass.kind, ParameterError::Kind::kNormal);
  EXPECT_EQ(read.mass.value.x(), 0.05);
  EXPECT_EQ(read.inertia.kind, ParameterError::Kind::kUniform);
  EXPECT_EQ(read.platform_com_P_m.kind, ParameterError::Kind::kFixed);
  EXPECT_EQ(read.platform_com_P_m.value, Eigen::Vector3d(0.03, 0.0, -0.01));
  EXPECT_EQ(read.thrust_coefficient.kind, ParameterError::Kind::kFixed);
  EXPECT_EQ(read.thrust_coefficient.value.x(), -0.04);
  EXPECT_FALSE(read.motor_time_constant.active());
  EXPECT_EQ(read.wind_W_mps.value, Eigen::Vector3d(1.0, 1.0, 0.2));

  const std::vector<std::pair<std::string, std::string>> bad = {
      {"{mass: {normal: 0.5}}", "uncertainty.mass.normal"},  // 3σ would make a mass negative
      {"{mass: 1.0}", "uncertainty.mass"},
      {"{mass: {uniform: -0.1}}", "uncertainty.mass.uniform"},
      {"{mass: {gauss: 0.1}}", "uncertainty.mass"},
      {"{mass: {normal: 0.1, uniform: 0.1}}", "uncertainty.mass"},
      {"{inertia: .nan}", "uncertainty.inertia"},
      {"{platform_com_P_m: 0.03}", "uncertainty.platform_com_P_m"},  // a fixed offset needs its axes
      {"{platform_com_P_m: [0.03, 0]}", "uncertainty.platform_com_P_m"},
      {"{thrust_coefficient: [0.1, 0, 0]}",
       "uncertainty.thrust_coefficient"},  // one error for the four rotors
      {"{torque_coefficient: {normal: [0.1, 0, 0]}}", "uncertainty.torque_coefficient.normal"},
      {"{mas: 0.1}", "did you mean 'mass'"},
      {"{wind_W_mps: {normal: 1}}", "air"},  // without air there is no wind to draw
  };
  for (const auto& [text, expected] : bad) {
    SCOPED_TRACE(text);
    try {
      Read(text);
      ADD_FAILURE() << "accepted";
    } catch (const bridge::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
}

// A fixed mismatch changes the flown vehicle exactly, both its rigid bodies and its model, and leaves the
// file's values to the flight controllers.
TEST(Uncertainty, AFixedErrorScalesTheFlownVehicleAndKeepsTheNominalForTheControllers) {
  PhysicsConfig config;
  Draw(
      "{mass: 0.05, inertia: -0.1, platform_com_P_m: [0.03, 0, 0], thrust_coefficient: 0.1,"
      " torque_coefficient: -0.2, motor_time_constant: 0.5}",
      1, &config);
  const model::Vehicle nominal = model::LoadVehicle(kThreeStar);
  const VehicleSpec& spec = config.simulation.vehicles.at(0);
  ASSERT_TRUE(spec.flight_controller_model.has_value());
  EXPECT_EQ(spec.flight_controller_model->platform.mass_kg, nominal.platform.mass_kg);
  EXPECT_EQ(spec.flight_controller_model->sub_aircraft[0].rotors.thrust_coefficient,
            nominal.sub_aircraft[0].rotors.thrust_coefficient);
  EXPECT_NEAR(spec.vehicle.TotalMass_kg(), 1.05 * nominal.TotalMass_kg(), 1e-12);
  EXPECT_NEAR(
      (spec.vehicle.platform.com_B_m - nominal.platform.com_B_m - Eigen::Vector3d(0.03, 0.0, 0.0)).norm(),
      0.0, 1e-15);
  ASSERT_EQ(spec.description.links.size(), 1 + nominal.sub_aircraft.size());
  double description_mass_kg = 0.0;
  for (const model::LinkDescription& link : spec.description.links) description_mass_kg += link.mass.mass_kg;
  EXPECT_NEAR(description_mass_kg, 1.05 * nominal.TotalMass_kg(), 1e-12);
  EXPECT_NEAR(spec.description.links[0].mass.com_B_m.x(), nominal.platform.com_B_m.x() + 0.03, 1e-15);
  EXPECT_TRUE(spec.description.links[0].mass.inertia_B_kgm2.isApprox(
      1.05 * 0.9 * nominal.platform.inertia_B_kgm2, 1e-12));
  for (size_t s = 0; s < nominal.sub_aircraft.size(); ++s) {
    const model::RotorSet& flown = spec.vehicle.sub_aircraft[s].rotors;
    const model::RotorSet& file = nominal.sub_aircraft[s].rotors;
    EXPECT_NEAR(flown.thrust_coefficient, 1.1 * file.thrust_coefficient, 1e-18);
    EXPECT_NEAR(flown.torque_coefficient, 0.8 * file.torque_coefficient, 1e-18);
    EXPECT_NEAR(flown.motor_time_constant_s, 1.5 * file.motor_time_constant_s, 1e-15);
    EXPECT_NEAR(flown.electric.time_constant_up_s, 1.5 * file.electric.time_constant_up_s, 1e-15);
    EXPECT_TRUE(spec.vehicle.sub_aircraft[s].mass.inertia_B_kgm2.isApprox(
        1.05 * 0.9 * nominal.sub_aircraft[s].mass.inertia_B_kgm2, 1e-12));
  }
}

// Normal draws: zero mean, their σ, none beyond 3σ; uniform ones on [−h, h] with σ h/√3. Over 4000 seeds
// the sample mean is within 4 standard errors and the sample σ within 5 %.
TEST(Uncertainty, DrawsFollowTheirDistributions) {
  const PhysicsConfig config =
      Read("{mass: {normal: 0.1}, thrust_coefficient: {uniform: 0.2}, wind_W_mps: {normal: 2}}", "air: {}\n");
  std::vector<double> normal, uniform, wind_x;
  for (uint64_t seed = 1; seed <= 4000; ++seed) {
    const auto drawn = Draw(config, seed);
    normal.push_back(drawn.at("iap/platform/mass_kg") - 1.0);
    uniform.push_back(drawn.at("iap/sub2/thrust_coefficient") - 1.0);
    wind_x.push_back(drawn.at("air/wind_W_mps/x"));  // the mean wind is 0: the draw itself
  }
  auto check = [](const std::vector<double>& x, double sigma, double bound) {
    double mean = 0.0, square = 0.0, largest = 0.0;
    for (double v : x) mean += v, square += v * v, largest = std::max(largest, std::abs(v));
    mean /= x.size();
    const double sd = std::sqrt(square / x.size() - mean * mean);
    EXPECT_LT(std::abs(mean), 4.0 * sigma / std::sqrt(x.size()));
    EXPECT_NEAR(sd, sigma, 0.05 * sigma);
    EXPECT_LE(largest, bound);
  };
  check(normal, 0.1 * std::sqrt(1.0 - 0.0111), 0.3);  // a normal truncated at 3σ keeps 98.9 % of its variance
  check(uniform, 0.2 / std::sqrt(3.0), 0.2);
  check(wind_x, 2.0 * std::sqrt(1.0 - 0.0111), 6.0);
}

TEST(Uncertainty, DrawsRepeatForASeedAndEachQuantityKeepsItsOwnStream) {
  const auto a = Draw("{mass: {normal: 0.05}, thrust_coefficient: {normal: 0.05}}", 7);
  EXPECT_EQ(a, Draw("{mass: {normal: 0.05}, thrust_coefficient: {normal: 0.05}}", 7));
  const auto other_seed = Draw("{mass: {normal: 0.05}, thrust_coefficient: {normal: 0.05}}", 8);
  EXPECT_NE(a.at("iap/platform/mass_kg"), other_seed.at("iap/platform/mass_kg"));
  // adding or removing a distribution leaves the others' draws as they were
  const auto mass_only = Draw("{mass: {normal: 0.05}}", 7);
  EXPECT_EQ(mass_only.at("iap/platform/mass_kg"), a.at("iap/platform/mass_kg"));
  EXPECT_EQ(mass_only.at("iap/sub3/mass_kg"), a.at("iap/sub3/mass_kg"));
  EXPECT_EQ(mass_only.count("iap/sub3/thrust_coefficient"), 0u);
  // each part draws its own
  EXPECT_NE(a.at("iap/sub1/mass_kg"), a.at("iap/sub2/mass_kg"));
  EXPECT_NE(a.at("iap/sub1/thrust_coefficient"), a.at("iap/sub2/thrust_coefficient"));
}

// Held at its nominal hover setpoints, a vehicle 10 % heavier than its file sinks at g (1 − 1/1.1), and
// propellers with 10 % more k_f than the file than the flight controllers invert push 10 % harder, with the
// first-order motors and with the electric drives (whose thrust curve is calibrated on the file's rotors).
TEST(Uncertainty, AMismatchedVehicleMovesAsNewtonsLawSays) {
  auto vertical_acceleration = [](const std::string& uncertainty, const std::string& extra) {
    PhysicsConfig config = Read(uncertainty, extra + "world: {ground: {enabled: false}}\n");
    DrawTrueModel(config.uncertainty, 1, &config.simulation);
    const model::Vehicle nominal = model::LoadVehicle(kThreeStar);
    const Eigen::VectorXd hover_N = nominal.LevelHoverThrusts_N(config.simulation.world.gravity_mps2);
    Simulation sim(config.simulation);
    const int platform = sim.output(0).platform_body;
    for (int s = 0; s < 3; ++s) {
      SubAircraftSetpoint setpoint;
      setpoint.thrust_N = hover_N[s];
      setpoint.q_WS = sim.world().body(sim.output(0).sub_aircraft_bodies[s]).q_WB;
      sim.SetCommand(0, s, setpoint);
    }
    for (int k = 0; k < 300; ++k) sim.Step();  // the motors settle (τ 12.5–50 ms)
    const double v0 = sim.world().body(platform).v_WB_W.z();
    for (int k = 0; k < 100; ++k) sim.Step();
    return (sim.world().body(platform).v_WB_W.z() - v0) / 0.1;
  };
  const double g = 9.81;
  EXPECT_NEAR(vertical_acceleration("{mass: 0.1}", ""), g * (1.0 - 1.0 / 1.1), 0.01 * g * (1.0 - 1.0 / 1.1));
  EXPECT_NEAR(vertical_acceleration("{}", ""), 0.0, 1e-3);
  EXPECT_NEAR(vertical_acceleration("{thrust_coefficient: 0.1}", ""), -0.1 * g, 0.001 * g);
  const double drive_error = vertical_acceleration("{}", "actuation: {battery_sag: false}\n");
  EXPECT_NEAR(vertical_acceleration("{thrust_coefficient: 0.1}", "actuation: {battery_sag: false}\n"),
              drive_error - 0.1 * (g - drive_error), 0.001 * g);
}

}  // namespace
}  // namespace iapsim::physics
