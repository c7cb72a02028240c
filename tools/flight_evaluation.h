#pragma once
// Tracking evaluation of a recorded flight (issue 4): the reference the controller published on
// /<vehicle>/setpoint against the platform's state of the same physics step on /<vehicle>/state, as the
// seed's Figs. 11-14 compare them. Writes tracking.csv, PNG plots (tools/plot_tracking.py) and a
// "tracking" section into the run's metrics.json.

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "bridge/bag.h"
#include "bridge/config.h"

namespace iapsim::tools {

struct TrackingEvaluation {
  std::string vehicle = "iap";
  std::string controller = "control";  // the process whose report counts allocation saturation
  bool plots = true;
  // the scenario's time 0 as a physics stamp (after its lead-in): what comes before is not evaluated
  int64_t start_ns = 0;
};

/// The `tracking: {vehicle, controller, plots}` section of a scenario's `evaluation`, or nothing when it has
/// none. Throws bridge::ConfigError naming the scenario file and key.
std::optional<TrackingEvaluation> ReadTrackingEvaluation(bridge::YamlMap& evaluation);

/// Evaluates the run in run_dir from its bag (run_dir/run.bag, opened by the caller). Metrics: position
/// error per W axis (RMSE, max |e|, m), ZYX Euler angle error (RMSE, max |e|, degrees; for an under-actuated
/// IAP or a 5-DOF reference pitch and yaw are exactly the x axis's elevation and heading, and roll is the
/// free swing), the samples compared and the setpoints without a state of their stamp
/// (unmatched_setpoints: not compared), saturation counts. Throws std::runtime_error
/// naming the file when the recording lacks the topics.
nlohmann::json EvaluateTracking(const std::string& run_dir, const bridge::BagReader& bag,
                                const TrackingEvaluation& evaluation);

/// ZYX Euler angles (roll, pitch, yaw) of an attitude, in rad.
Eigen::Vector3d EulerZyx(const Eigen::Quaterniond& q);

/// Prints the metrics as a short table.
void PrintTracking(const nlohmann::json& tracking);

}  // namespace iapsim::tools
