#include "tools/odometry_evaluation.h"

#include <cstdio>
#include <map>
#include <memory>
#include <stdexcept>

#include "bridge/message_format.h"
#include "bridge/message_schema.h"
#include "bridge/pose_file.h"
#include "bridge/trajectory_error.h"
#include "tools/run_evaluation.h"

namespace iapsim::tools {
namespace {

// A topic's poses by header stamp, as `iapsim export --format tum` writes them.
std::vector<bridge::StampedPose> ReadPoses(const bridge::BagReader& bag, const std::string& topic) {
  const bridge::BagTopicInfo* info = nullptr;
  const std::vector<bridge::BagTopicInfo> topics = bag.Topics();
  for (const bridge::BagTopicInfo& t : topics) {
    if (t.topic == topic) info = &t;
  }
  if (info == nullptr || info->count == 0) {
    throw std::runtime_error(bag.path() + ": no messages on " + topic +
                             " (evaluation.odometry; see iapsim info for the recorded topics)");
  }
  const auto schema = bridge::SchemaSet::Parse(info->datatype, info->definition);
  std::map<int64_t, bridge::StampedPose> by_stamp;  // sorted, as the errors need
  bag.ForEach({topic}, [&](const bridge::BagMessage& m) {
    const auto pose = bridge::ExtractPose(*schema, m.bytes.data(), m.bytes.size(), m.record_time_ns);
    if (!pose)
      throw std::runtime_error(bag.path() + ": " + topic + " (" + info->datatype + ") holds no pose");
    by_stamp[pose->time_ns] = *pose;
    return true;
  });
  std::vector<bridge::StampedPose> poses;
  for (const auto& [t_ns, pose] : by_stamp) poses.push_back(pose);
  return poses;
}

std::string FileStem(const std::string& topic) {
  std::string stem = topic.substr(topic.find_first_not_of('/'));
  for (char& c : stem) c = c == '/' ? '_' : c;
  return stem;
}

}  // namespace

std::vector<OdometryPair> ReadOdometryEvaluation(bridge::YamlMap& evaluation) {
  std::vector<OdometryPair> pairs;
  if (!evaluation.Has("odometry")) return pairs;
  const YAML::Node list = evaluation.Raw("odometry");
  const std::string expected = "expected a list of {estimate: TOPIC, truth: TOPIC}";
  if (!list.IsSequence() || list.size() == 0) evaluation.Fail("odometry", expected);
  for (std::size_t i = 0; i < list.size(); ++i) {
    if (!list[i].IsMap()) evaluation.FailAt(list[i], "odometry", expected);
    bridge::YamlMap item(list[i], evaluation.file(),
                         evaluation.PathOf("odometry") + "[" + std::to_string(i) + "]");
    OdometryPair pair;
    item.Required("estimate", &pair.estimate_topic);
    item.Required("truth", &pair.truth_topic);
    item.Finish();
    for (const std::string* topic : {&pair.estimate_topic, &pair.truth_topic}) {
      if (topic->empty() || topic->front() != '/')
        item.Fail(topic == &pair.estimate_topic ? "estimate" : "truth",
                  "expected a topic name starting with /");
    }
    pairs.push_back(pair);
  }
  evaluation.SetResolved("odometry", list);
  return pairs;
}

nlohmann::json EvaluateOdometry(const std::string& run_dir, const bridge::BagReader& bag,
                                const std::vector<OdometryPair>& pairs) {
  nlohmann::json out = nlohmann::json::object();
  for (const OdometryPair& pair : pairs) {
    const std::vector<bridge::StampedPose> estimate = ReadPoses(bag, pair.estimate_topic);
    const std::vector<bridge::StampedPose> truth = ReadPoses(bag, pair.truth_topic);
    nlohmann::json entry = bridge::TrajectoryErrors(estimate, truth);
    if (entry["ate"]["matched"].get<std::size_t>() == 0) {
      throw std::runtime_error(bag.path() + ": no stamp of " + pair.estimate_topic + " is a stamp of " +
                               pair.truth_topic +
                               " (an estimate is compared with the truth of its own stamp)");
    }
    const std::string estimate_tum = FileStem(pair.estimate_topic) + ".tum";
    const std::string truth_tum = FileStem(pair.truth_topic) + ".tum";
    const std::string comment = "t x y z qx qy qz qw (W NED; iapsim evaluation.odometry)";
    bridge::WriteTumFile(run_dir + "/" + estimate_tum, estimate, comment);
    bridge::WriteTumFile(run_dir + "/" + truth_tum, truth, comment);
    entry["truth"] = pair.truth_topic;
    entry["estimate_tum"] = estimate_tum;
    entry["truth_tum"] = truth_tum;
    out[pair.estimate_topic] = entry;
  }
  SetRunMetric(run_dir, "odometry", out);
  return out;
}

void PrintEstimateErrors(const nlohmann::json& odometry) {
  std::printf("  estimates against the truth (ATE RMSE as it is / rigidly aligned, RPE over 1 s):\n");
  for (const auto& [topic, entry] : odometry.items()) {
    std::printf("    %-24s %8.4f / %8.4f m  RPE %7.4f m %6.3f deg  (%zu stamps)\n", topic.c_str(),
                entry["ate"]["rmse_m"].get<double>(), entry["ate_aligned"]["rmse_m"].get<double>(),
                entry["rpe_1s"]["translation_rmse_m"].get<double>(),
                entry["rpe_1s"]["rotation_rmse_deg"].get<double>(),
                entry["ate"]["matched"].get<std::size_t>());
  }
}

}  // namespace iapsim::tools
