// Regression flights are deterministic in lockstep (issue 4): the same scenario run twice gives identical
// tracking metrics, to the last bit.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "bridge/launcher.h"
#include "bridge/scenario.h"
#include "tools/flight_evaluation.h"

namespace iapsim::tools {
namespace {

nlohmann::json Fly(const std::string& scenario, const std::string& out_dir) {
  bridge::LaunchOptions options;
  options.scenario_path = scenario;
  options.overrides = {"mode=lockstep", "duration_s=8"};
  options.out_dir = out_dir;
  options.bin_dir = bridge::ExecutableDir();
  const bridge::LaunchResult result = bridge::Launch(options);
  EXPECT_EQ(result.exit_code, 0) << result.message;
  TrackingEvaluation evaluation = *ReadTrackingEvaluation(bridge::LoadScenario(scenario));
  evaluation.plots = false;
  nlohmann::json tracking = EvaluateTracking(result.run_dir, evaluation);
  tracking.erase("csv");
  return tracking;
}

TEST(FlightDeterminism, TwoLockstepRunsGiveIdenticalMetrics) {
  const std::string scenario = std::string(IAPSIM_SOURCE_DIR) + "/configs/regression/two_line_circle.yaml";
  const std::filesystem::path out =
      std::filesystem::path(::testing::TempDir()) / ("iapsim-determinism-" + std::to_string(getpid()));
  const nlohmann::json first = Fly(scenario, (out / "a").string());
  const nlohmann::json second = Fly(scenario, (out / "b").string());
  EXPECT_EQ(first, second) << first.dump(2) << "\n" << second.dump(2);
  EXPECT_GT(first["samples"].get<int>(), 1000);
  EXPECT_GT(first["position_max_m"]["x"].get<double>(), 0.0);  // it flew and was compared
  std::filesystem::remove_all(out);
}

}  // namespace
}  // namespace iapsim::tools
