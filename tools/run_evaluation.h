#pragma once
// The after-run analyses a scenario asks for in its `evaluation` section: tracking (flight_evaluation.h),
// contact (contact_evaluation.h), estimates against the truth (odometry_evaluation.h) and videos of cameras
// (video.h). `iapsim run`, `iapsim evaluate` and `iapsim regress` all go through here.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "bridge/scenario.h"
#include "tools/contact_evaluation.h"
#include "tools/flight_evaluation.h"
#include "tools/odometry_evaluation.h"

namespace iapsim::tools {

struct RunEvaluation {
  std::optional<TrackingEvaluation> tracking;
  std::optional<ContactEvaluation> contact;
  std::vector<OdometryPair> odometry;
  std::vector<std::string> videos;  // camera eyes: an MP4 and a contact sheet of each in the run directory
  bool empty() const { return !tracking && !contact && odometry.empty() && videos.empty(); }
};

/// run_dir/metrics.json (the launcher's figures of the run, and the evaluations' once written). Throws
/// std::runtime_error naming the file when it is missing or not a JSON object.
nlohmann::json ReadRunMetrics(const std::string& run_dir);
/// Sets `key` of run_dir/metrics.json to `value` (an evaluation's figures), keeping the rest.
void SetRunMetric(const std::string& run_dir, const std::string& key, const nlohmann::json& value);

/// Reads the scenario's `evaluation` section (unknown keys are errors). Throws bridge::ConfigError.
RunEvaluation ReadRunEvaluation(const bridge::Scenario& scenario);

/// Runs each analysis on run_dir, prints their tables (unless `print` is false) and returns {tracking: ...,
/// contact: ..., odometry: ..., videos: ...} (all but the videos are also written into run_dir/metrics.json).
/// Throws std::runtime_error naming a file that is missing data.
nlohmann::json EvaluateRun(const std::string& run_dir, const RunEvaluation& evaluation, bool print = true);
/// Prints the tables of what EvaluateRun returned.
void PrintRunEvaluation(const nlohmann::json& evaluated);

}  // namespace iapsim::tools
