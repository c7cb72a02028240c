#include "tools/run_evaluation.h"

namespace iapsim::tools {

RunEvaluation ReadRunEvaluation(const bridge::Scenario& scenario) {
  RunEvaluation out;
  if (!scenario.evaluation) return out;
  bridge::YamlMap evaluation(scenario.evaluation, scenario.file, "evaluation");
  out.tracking = ReadTrackingEvaluation(evaluation);
  out.contact = ReadContactEvaluation(evaluation);
  evaluation.Finish();
  return out;
}

nlohmann::json EvaluateRun(const std::string& run_dir, const RunEvaluation& evaluation) {
  nlohmann::json out = nlohmann::json::object();
  if (evaluation.tracking) {
    out["tracking"] = EvaluateTracking(run_dir, *evaluation.tracking);
    PrintTracking(out["tracking"]);
  }
  if (evaluation.contact) {
    out["contact"] = EvaluateContact(run_dir, *evaluation.contact);
    PrintContact(out["contact"]);
  }
  return out;
}

}  // namespace iapsim::tools
