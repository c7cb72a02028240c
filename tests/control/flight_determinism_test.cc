// Regression flights are deterministic in lockstep (issues 4 and 7): the same scenario run twice gives
// identical tracking and contact metrics, to the last bit, also when the controller closes its loop on
// another process's output (the sensors' filtered wrench, ordered by `after`).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "bridge/launcher.h"
#include "bridge/scenario.h"
#include "tools/run_evaluation.h"

namespace iapsim::tools {
namespace {

nlohmann::json Fly(const std::string& scenario, const std::string& out_dir, double duration_s) {
  bridge::LaunchOptions options;
  options.scenario_path = scenario;
  options.overrides = {"mode=lockstep", "duration_s=" + std::to_string(duration_s)};
  options.out_dir = out_dir;
  options.bin_dir = bridge::ExecutableDir();
  const bridge::LaunchResult result = bridge::Launch(options);
  EXPECT_EQ(result.exit_code, 0) << result.message;
  RunEvaluation evaluation = ReadRunEvaluation(bridge::LoadScenario(scenario));
  if (evaluation.tracking) evaluation.tracking->plots = false;
  if (evaluation.contact) evaluation.contact->plots = false;
  nlohmann::json metrics = EvaluateRun(result.run_dir, evaluation);
  for (auto& [analysis, section] : metrics.items()) section.erase("csv");
  return metrics;
}

std::filesystem::path OutDir(const std::string& name) {
  return std::filesystem::path(::testing::TempDir()) /
         ("iapsim-determinism-" + name + "-" + std::to_string(getpid()));
}

TEST(FlightDeterminism, TwoLockstepRunsGiveIdenticalMetrics) {
  const std::string scenario = std::string(IAPSIM_SOURCE_DIR) + "/configs/regression/two_line_circle.yaml";
  const std::filesystem::path out = OutDir("circle");
  const nlohmann::json first = Fly(scenario, (out / "a").string(), 8.0);
  const nlohmann::json second = Fly(scenario, (out / "b").string(), 8.0);
  EXPECT_EQ(first, second) << first.dump(2) << "\n" << second.dump(2);
  EXPECT_GT(first["tracking"]["samples"].get<int>(), 1000);
  EXPECT_GT(first["tracking"]["position_max_m"]["x"].get<double>(), 0.0);  // it flew and was compared
  std::filesystem::remove_all(out);
}

TEST(FlightDeterminism, TheWallPushClosedOnTheSensorsProcessRepeatsToTheBit) {
  const std::string scenario = std::string(IAPSIM_SOURCE_DIR) + "/configs/regression/wall_push.yaml";
  const std::filesystem::path out = OutDir("wall");
  // past the first contact (4.5 s) and the switch to (21) (5.3 s)
  const nlohmann::json first = Fly(scenario, (out / "a").string(), 10.0);
  const nlohmann::json second = Fly(scenario, (out / "b").string(), 10.0);
  EXPECT_EQ(first, second) << first.dump(2) << "\n" << second.dump(2);
  EXPECT_GT(first["contact"]["engaged_at_s"].get<double>(), 4.0);
  EXPECT_GT(first["contact"]["max_filtered_force_N"].get<double>(), 1.0);
  std::filesystem::remove_all(out);
}

}  // namespace
}  // namespace iapsim::tools
