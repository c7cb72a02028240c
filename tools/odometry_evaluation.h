#pragma once
// A run's estimates against its ground truth (the scenario's `evaluation.odometry`): each pair of
// nav_msgs/Odometry topics, an estimate (the vio processes' /<vehicle>/<sub>/vio/odom, the platform's
// /<vehicle>/vio/odom, or any other estimator's) and the truth it estimates (/<body>/odom), compared at the
// stamps both have: ATE as it is and rigidly aligned, RPE over 1 s (bridge/trajectory_error.h, the TUM
// benchmark's measures, as `iapsim vio` reports them), and both written as TUM files for evo.
//
//   evaluation:
//     odometry:
//       - {estimate: /iap/sub1/vio/odom, truth: /iap/sub1/odom}

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bridge/bag.h"
#include "bridge/config.h"

namespace iapsim::tools {

struct OdometryPair {
  std::string estimate_topic;
  std::string truth_topic;
};

/// The `odometry` list of a scenario's `evaluation` (empty when it has none). Throws bridge::ConfigError
/// naming the scenario file, line and key.
std::vector<OdometryPair> ReadOdometryEvaluation(bridge::YamlMap& evaluation);

/// Evaluates each pair from the run's bag: {estimate topic: {truth, estimate_tum, truth_tum, ate,
/// ate_aligned, rpe_1s}}, also written into run_dir/metrics.json under "odometry", the TUM files in run_dir
/// (<topic with _ for />.tum). Throws std::runtime_error naming the bag and topic when either has no message.
nlohmann::json EvaluateOdometry(const std::string& run_dir, const bridge::BagReader& bag,
                                const std::vector<OdometryPair>& pairs);

/// Prints one row per pair.
void PrintEstimateErrors(const nlohmann::json& odometry);

}  // namespace iapsim::tools
