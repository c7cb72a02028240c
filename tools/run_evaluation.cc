#include "tools/run_evaluation.h"

#include <fstream>
#include <optional>
#include <stdexcept>

#include "bridge/bag.h"
#include "tools/video.h"

namespace iapsim::tools {

nlohmann::json ReadRunMetrics(const std::string& run_dir) {
  const std::string path = run_dir + "/metrics.json";
  std::ifstream in(path);
  nlohmann::json metrics = nlohmann::json::parse(in, nullptr, false);
  if (!metrics.is_object()) throw std::runtime_error(path + ": missing or not JSON");
  return metrics;
}

void SetRunMetric(const std::string& run_dir, const std::string& key, const nlohmann::json& value) {
  nlohmann::json metrics = ReadRunMetrics(run_dir);
  metrics[key] = value;
  const std::string path = run_dir + "/metrics.json";
  std::ofstream out(path);
  out << metrics.dump(2) << "\n";
  if (!out) throw std::runtime_error(path + ": cannot write");
}

RunEvaluation ReadRunEvaluation(const bridge::Scenario& scenario) {
  RunEvaluation out;
  if (!scenario.evaluation) return out;
  bridge::YamlMap evaluation(scenario.evaluation, scenario.file, "evaluation");
  out.tracking = ReadTrackingEvaluation(evaluation);
  out.contact = ReadContactEvaluation(evaluation);
  if (out.tracking) out.tracking->start_ns = scenario.lead_in_ns();
  if (out.contact) out.contact->start_ns = scenario.lead_in_ns();
  out.odometry = ReadOdometryEvaluation(evaluation);
  if (evaluation.Has("videos")) {
    const YAML::Node videos = evaluation.Raw("videos");
    if (!videos.IsSequence())
      evaluation.Fail("videos", "expected a list of camera eyes (iap/platform/chase)");
    for (const YAML::Node& camera : videos) {
      if (!camera.IsScalar())
        evaluation.Fail("videos", "expected a list of camera eyes (iap/platform/chase)");
      out.videos.push_back(camera.Scalar());
    }
    evaluation.SetResolved("videos", videos);
  }
  evaluation.Finish();
  return out;
}

nlohmann::json EvaluateRun(const std::string& run_dir, const RunEvaluation& evaluation, bool print) {
  nlohmann::json out = nlohmann::json::object();
  const std::string bag_path = run_dir + "/run.bag";
  // opened once for every analysis: reading a bag's index is most of what reading a few topics costs
  std::optional<bridge::BagReader> bag;
  if (evaluation.tracking || evaluation.contact || !evaluation.odometry.empty()) bag.emplace(bag_path);
  if (evaluation.tracking) out["tracking"] = EvaluateTracking(run_dir, *bag, *evaluation.tracking);
  if (evaluation.contact) out["contact"] = EvaluateContact(run_dir, *bag, *evaluation.contact);
  if (!evaluation.odometry.empty()) out["odometry"] = EvaluateOdometry(run_dir, *bag, evaluation.odometry);
  for (const std::string& camera : evaluation.videos) {
    const CameraVideo video = WriteCameraVideo(bag_path, camera, DefaultVideoPath(bag_path, camera));
    out["videos"][video.topic] = ToJson(video);
  }
  if (print) PrintRunEvaluation(out);
  return out;
}

void PrintRunEvaluation(const nlohmann::json& evaluated) {
  if (evaluated.contains("tracking")) PrintTracking(evaluated["tracking"]);
  if (evaluated.contains("contact")) PrintContact(evaluated["contact"]);
  if (evaluated.contains("odometry")) PrintEstimateErrors(evaluated["odometry"]);
  if (evaluated.contains("videos")) {
    for (const auto& video : evaluated["videos"]) PrintCameraVideo(CameraVideoFromJson(video));
  }
}

}  // namespace iapsim::tools
