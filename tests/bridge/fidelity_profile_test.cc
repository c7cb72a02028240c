// `fidelity:` in a scenario (bridge/scenario.h): a profile fills in, per process exec, what the scenario
// leaves out, the scenario's own values and --set winning; a missing required process and an unknown profile
// are errors naming the key.
#include <gtest/gtest.h>

#include "bridge/scenario.h"
#include "tests/support/test_folder.h"

namespace iapsim::bridge {
namespace {

const std::string kRegression = std::string(IAPSIM_SOURCE_DIR) + "/configs/regression/";

YAML::Node ParamsOf(const Scenario& scenario, const std::string& process) {
  return scenario.Find(process)->params;
}

std::string ErrorOf(const std::string& path, const std::vector<std::string>& overrides) {
  try {
    LoadScenario(path, overrides);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(FidelityProfile, IdealIsTheScenarioAsWritten) {
  const Scenario scenario = LoadScenario(kRegression + "three_star_spiral.yaml");
  EXPECT_EQ(scenario.fidelity, "ideal");
  EXPECT_FALSE(ParamsOf(scenario, "physics")["air"]);
  EXPECT_FALSE(ParamsOf(scenario, "control")["odometry_topic"]);
  EXPECT_TRUE(scenario.Find("control")->after.empty());
}

TEST(FidelityProfile, RealisticFillsWhatTheScenarioLeavesOutAndTheScenarioWins) {
  const Scenario scenario =
      LoadScenario(kRegression + "three_star_spiral.yaml",
                   {"fidelity=realistic", "processes.physics.params.air.wind_W_mps=[0, 3, 0]",
                    "processes.control.params.sensor_link={delay_s: 0.01}"});
  EXPECT_EQ(scenario.fidelity, "realistic");
  const YAML::Node physics = ParamsOf(scenario, "physics");
  EXPECT_EQ(physics["air"]["wind_W_mps"][1].as<double>(), 3.0);                  // --set's
  EXPECT_EQ(physics["air"]["turbulence"]["model"].as<std::string>(), "dryden");  // the profile's, beside it
  EXPECT_EQ(physics["flight_controller_sensing"].as<std::string>(), "estimate");
  EXPECT_EQ(physics["uncertainty"]["mass"]["normal"].as<double>(), 0.02);
  EXPECT_EQ(physics["vehicles"][0]["name"].as<std::string>(), "iap");  // the scenario's own, untouched
  const YAML::Node control = ParamsOf(scenario, "control");
  EXPECT_EQ(control["odometry_topic"].as<std::string>(), "odometry");
  EXPECT_EQ(control["sensor_link"]["delay_s"].as<double>(), 0.01);
  EXPECT_TRUE(control["sensor_link"]["jitter_s"].IsScalar());  // filled in beside --set's delay
  EXPECT_EQ(scenario.Find("control")->after, std::vector<std::string>{"sensors"});
  EXPECT_EQ(ParamsOf(scenario, "sensors")["odometry"]["rate_hz"].as<double>(), 200.0);
  EXPECT_EQ(scenario.resolved["fidelity"].as<std::string>(), "realistic");
}

// The realistic profile's flights start from a settled hover: its lead-in comes before the scenario's time 0
// and lengthens the run by as much; the scenario's own lead-in wins, and one that is not a whole number of
// clock steps is refused by name.
TEST(FidelityProfile, TheLeadInPrecedesTheScenariosTimeZero) {
  const Scenario ideal = LoadScenario(kRegression + "three_star_spiral.yaml");
  EXPECT_EQ(ideal.lead_in_ns(), 0);
  EXPECT_EQ(ideal.last_step(), 65000u);
  const Scenario realistic = LoadScenario(kRegression + "three_star_spiral.yaml", {"fidelity=realistic"});
  EXPECT_EQ(realistic.lead_in_s, 20.0);
  EXPECT_EQ(realistic.lead_in_ns(), 20'000'000'000);
  EXPECT_EQ(realistic.last_step(), 85000u);
  EXPECT_EQ(realistic.duration_s, 65.0);
  EXPECT_EQ(realistic.resolved["lead_in_s"].as<double>(), 20.0);
  const Scenario own =
      LoadScenario(kRegression + "three_star_spiral.yaml", {"fidelity=realistic", "lead_in_s=0.5"});
  EXPECT_EQ(own.lead_in_ns(), 500'000'000);
  EXPECT_EQ(own.last_step(), 65500u);
  const std::string off_grid = ErrorOf(kRegression + "three_star_spiral.yaml", {"lead_in_s=0.0005"});
  EXPECT_NE(off_grid.find("lead_in_s: must be a whole number of clock steps"), std::string::npos) << off_grid;
  const std::string negative = ErrorOf(kRegression + "three_star_spiral.yaml", {"lead_in_s=-1"});
  EXPECT_NE(negative.find("lead_in_s"), std::string::npos) << negative;
}

// Orderings compose: the pilot log's controller waits for its replayer as written, and in the realistic
// profile for the sensors' odometry too (the scenario's list used to win, and the odometry then came at k or
// k + 1 by chance).
TEST(FidelityProfile, AProfilesOrderingAddsToTheScenarios) {
  const std::string pilot = kRegression + "three_square_pilot_log.yaml";
  EXPECT_EQ(LoadScenario(pilot).Find("control")->after, std::vector<std::string>{"replayer"});
  EXPECT_EQ(LoadScenario(pilot, {"fidelity=realistic"}).Find("control")->after,
            (std::vector<std::string>{"replayer", "sensors"}));
  const Scenario twice = LoadScenario(kRegression + "three_star_spiral.yaml",
                                      {"fidelity=realistic", "processes.control.after=[sensors]"});
  EXPECT_EQ(twice.Find("control")->after, std::vector<std::string>{"sensors"});
}

TEST(FidelityProfile, ARequiredProcessMissingOrAnUnknownProfileIsAnErrorNamingTheKey) {
  const std::string hover = std::string(IAPSIM_SOURCE_DIR) + "/configs/scenarios/three_star_hover.yaml";
  const std::string missing = ErrorOf(hover, {"fidelity=realistic"});
  EXPECT_NE(missing.find("three_star_hover.yaml"), std::string::npos) << missing;
  EXPECT_NE(missing.find("fidelity: 'realistic'"), std::string::npos) << missing;
  EXPECT_NE(missing.find("needs a process running iapsim_sensors"), std::string::npos) << missing;
  const std::string unknown = ErrorOf(kRegression + "three_star_spiral.yaml", {"fidelity=realstic"});
  EXPECT_NE(unknown.find("fidelity: expected ideal, a profile of"), std::string::npos) << unknown;
  const std::string no_file = ErrorOf(kRegression + "three_star_spiral.yaml", {"fidelity=nowhere.yaml"});
  EXPECT_NE(no_file.find("fidelity"), std::string::npos) << no_file;
}

TEST(FidelityProfile, AProfileFileIsFoundBesideTheScenarioAndResolvedToAnAbsolutePath) {
  const test_support::TestFolder dir("iapsim-profile");
  const std::string windy = dir.Write(
      "windy.yaml", "processes:\n  iapsim_physics:\n    params:\n      air: {wind_W_mps: [1, 2, 3]}\n");
  const std::string flight = dir.Write("flight.yaml",
                                       "name: f\nfidelity: windy.yaml\nprocesses:\n"
                                       "  physics: {exec: iapsim_physics, role: clock}\n");
  const Scenario scenario = LoadScenario(flight);
  EXPECT_EQ(scenario.fidelity, windy);
  EXPECT_EQ(ParamsOf(scenario, "physics")["air"]["wind_W_mps"][2].as<double>(), 3.0);
  // a profile file on another beside it: the base's keys, the profile's over them
  dir.Write("gusty.yaml",
            "base: windy.yaml\nprocesses:\n  iapsim_physics:\n    params:\n"
            "      air: {gusts: [{start_s: 1, rise_s: 1, hold_s: 1, amplitude_W_mps: [0, 1, 0]}]}\n");
  const YAML::Node air = ParamsOf(LoadScenario(flight, {"fidelity=gusty.yaml"}), "physics")["air"];
  EXPECT_EQ(air["wind_W_mps"][2].as<double>(), 3.0);
  EXPECT_EQ(air["gusts"].size(), 1u);
}

TEST(FidelityProfile, TheArenaProfileIsTheRealisticOneInStillAirOnMotionCapture) {
  const Scenario outdoors = LoadScenario(kRegression + "peg_in_hole.yaml", {"fidelity=realistic"});
  const Scenario arena = LoadScenario(kRegression + "peg_in_hole.yaml", {"fidelity=realistic_indoor"});
  const YAML::Node air = ParamsOf(arena, "physics")["air"];
  EXPECT_EQ(air["wind_W_mps"][0].as<double>(), 0.0);
  EXPECT_FALSE(air["turbulence"]);  // `~` in the profile removed its base's
  EXPECT_TRUE(ParamsOf(outdoors, "physics")["air"]["turbulence"]);
  const YAML::Node odometry = ParamsOf(arena, "sensors")["odometry"];
  EXPECT_EQ(odometry["position_drift_m_per_sqrt_s"].as<double>(), 0.0);
  EXPECT_EQ(odometry["position_sigma_m"].as<double>(), 0.001);
  // everything else is its base's
  EXPECT_EQ(odometry["rate_hz"].as<double>(),
            ParamsOf(outdoors, "sensors")["odometry"]["rate_hz"].as<double>());
  EXPECT_EQ(YAML::Dump(ParamsOf(arena, "physics")["uncertainty"]),
            YAML::Dump(ParamsOf(outdoors, "physics")["uncertainty"]));
  EXPECT_EQ(arena.Find("control")->after, outdoors.Find("control")->after);
  EXPECT_EQ(arena.lead_in_s, outdoors.lead_in_s);
}

TEST(FidelityProfile, AProfilesBaseThatIsMissingOrACycleIsAnErrorNamingTheKey) {
  const test_support::TestFolder dir("iapsim-profile-base");
  const std::string flight =
      dir.Write("flight.yaml", "name: f\nprocesses:\n  physics: {exec: iapsim_physics, role: clock}\n");
  dir.Write("a.yaml", "base: b.yaml\nprocesses: {}\n");
  dir.Write("b.yaml", "base: a.yaml\nprocesses: {}\n");
  dir.Write("lost.yaml", "base: nowhere\nprocesses: {}\n");
  dir.Write("extra.yaml",
            "base: realistic\nprocesses:\n  iapsim_physics:\n    params:\n      air: {gusts: ~}\n");
  const std::string cycle = ErrorOf(flight, {"fidelity=a.yaml"});
  EXPECT_NE(cycle.find("base: 'a.yaml' is this profile or one it is based on (a cycle)"), std::string::npos)
      << cycle;
  const std::string lost = ErrorOf(flight, {"fidelity=lost.yaml"});
  EXPECT_NE(lost.find("lost.yaml"), std::string::npos) << lost;
  EXPECT_NE(lost.find("base: expected a profile of"), std::string::npos) << lost;
  const std::string extra = ErrorOf(flight, {"fidelity=extra.yaml"});
  EXPECT_NE(extra.find("gusts: ~ removes a key of the base, which has none here"), std::string::npos)
      << extra;
}

}  // namespace
}  // namespace iapsim::bridge
