// `--set KEY=VALUE` overrides: map keys by name (created where missing), list entries by index, and a clear
// error naming the assignment where the path cannot be followed.
#include "bridge/config.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

namespace iapsim::bridge {
namespace {

YAML::Node Scenario() {
  return YAML::Load(
      "processes:\n"
      "  physics:\n"
      "    params:\n"
      "      vehicles:\n"
      "        - {name: a, position_m: [0, 0, -5]}\n"
      "        - {name: b, position_m: [0, -1.4, -5]}\n");
}

std::string ErrorOf(const std::string& assignment) {
  try {
    ApplyOverride(Scenario(), assignment, "scenario.yaml");
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "no error";
}

TEST(ApplyOverride, FollowsMapKeysAndListIndices) {
  YAML::Node root = Scenario();
  ApplyOverride(root, "processes.physics.params.vehicles.1.position_m=[0.1, -1.3, -5]", "scenario.yaml");
  ApplyOverride(root, "processes.physics.params.vehicles.0.roll_deg=3", "scenario.yaml");
  ApplyOverride(root, "processes.policy.params.policy=expert", "scenario.yaml");
  const YAML::Node vehicles = root["processes"]["physics"]["params"]["vehicles"];
  EXPECT_EQ(vehicles[1]["position_m"][0].as<double>(), 0.1);
  EXPECT_EQ(vehicles[1]["name"].as<std::string>(), "b");
  EXPECT_EQ(vehicles[0]["roll_deg"].as<double>(), 3.0);
  EXPECT_EQ(root["processes"]["policy"]["params"]["policy"].as<std::string>(), "expert");
  ApplyOverride(root, "processes.physics.params.vehicles.1={name: c}", "scenario.yaml");
  EXPECT_EQ(vehicles[1]["name"].as<std::string>(), "c");
}

TEST(ApplyOverride, APathThatCannotBeFollowedNamesTheAssignment) {
  EXPECT_NE(
      ErrorOf("processes.physics.params.vehicles.2.position_m=[0, 0, 0]")
          .find("scenario.yaml: --set 'processes.physics.params.vehicles.2.position_m=[0, 0, 0]': '2' names "
                "no entry of a list of 2"),
      std::string::npos)
      << ErrorOf("processes.physics.params.vehicles.2.position_m=[0, 0, 0]");
  EXPECT_NE(ErrorOf("processes.physics.params.vehicles.b.position_m=[0, 0, 0]").find("'b' names no entry"),
            std::string::npos);
  EXPECT_NE(
      ErrorOf("processes.physics.params.vehicles.0.name.x=1").find("'name' is not a map of keys or a list"),
      std::string::npos);
  EXPECT_NE(ErrorOf("no_value").find("expected KEY=VALUE"), std::string::npos);
}

}  // namespace
}  // namespace iapsim::bridge
