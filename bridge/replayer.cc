#include "bridge/replayer.h"

#include <geometry_msgs/PoseStamped.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>

#include "bridge/bag.h"
#include "bridge/eigen_msgs.h"
#include "bridge/message.h"
#include "bridge/message_format.h"
#include "bridge/message_registry.h"
#include "bridge/pose_file.h"

namespace iapsim::bridge {
namespace {

struct Scheduled {
  int64_t due_ns;
  std::string topic;
  const RegisteredType* type;
  std::vector<uint8_t> bytes;
};

class Replayer : public Process {
 public:
  Replayer(const ProcessContext& context, YamlMap& params) : step_ns_(context.scenario.step_ns()) {
    if (params.Has("bag") == params.Has("file")) {
      params.Fail("bag",
                  "a replayer plays exactly one of bag (a recorded bag) or file (a TUM or CSV pose file)");
    }
    params.Optional("frame_id", &frame_id_);
    if (params.Has("bag")) {
      LoadBag(params);
    } else {
      LoadPoseFile(params, context.scenario.file);
    }
    double offset_s = context.scenario.clock.step_s;
    params.OptionalInRange("time_offset_s", &offset_s, context.scenario.clock.step_s, 1e7);
    params.Optional("restamp", &restamp_);
    // the earliest message of the log plays at time_offset_s of the scenario's time (after its lead-in);
    // order by message time
    std::stable_sort(queue_.begin(), queue_.end(),
                     [](const Scheduled& a, const Scheduled& b) { return a.due_ns < b.due_ns; });
    const int64_t origin_ns = queue_.empty() ? 0 : queue_.front().due_ns;
    for (auto& m : queue_)
      m.due_ns += context.scenario.lead_in_ns() + std::llround(offset_s * 1e9) - origin_ns;
  }

  void Setup(Bus& bus) override { bus_ = &bus; }

  void Step(const StepInfo& step) override {
    // publish what is due by the next step
    const int64_t horizon_ns = step.stamp_ns + step_ns_;
    while (next_ < queue_.size() && queue_[next_].due_ns <= horizon_ns) {
      Scheduled& m = queue_[next_++];
      const int offset = m.type->schema->StampOffset();
      if (restamp_ && offset >= 0 && m.bytes.size() >= static_cast<size_t>(offset) + 8) {
        const uint32_t sec = static_cast<uint32_t>(m.due_ns / 1000000000);
        const uint32_t nsec = static_cast<uint32_t>(m.due_ns % 1000000000);
        std::memcpy(m.bytes.data() + offset, &sec, 4);
        std::memcpy(m.bytes.data() + offset + 4, &nsec, 4);
      }
      bus_->PublishRaw(m.topic, m.type->info, m.bytes.data(), m.bytes.size());
      ++published_[m.topic];
    }
  }

  void Finish(nlohmann::json* report) override {
    (*report)["replayed"] = published_;
    (*report)["remaining"] = queue_.size() - next_;
  }

 private:
  // The whole selection is loaded up front: a bad bag or an unknown type fails the --check, not the run.
  void LoadBag(YamlMap& params) {
    std::string bag_path;
    params.Required("bag", &bag_path);
    if (!std::filesystem::exists(bag_path)) params.Fail("bag", "file '" + bag_path + "' does not exist");
    std::vector<std::string> topics;
    ReadStringList(params, "topics", &topics);
    std::vector<std::string> renames;
    ReadStringList(params, "map", &renames);
    std::map<std::string, std::string> rename;
    for (const auto& r : renames) {
      const auto arrow = r.find(":=");
      if (arrow == std::string::npos || arrow == 0 || arrow + 2 == r.size()) {
        params.Fail("map", "entries are FROM:=TO, got '" + r + "'");
      }
      rename[r.substr(0, arrow)] = r.substr(arrow + 2);
    }
    bool as_pose = false;
    params.Optional("as_pose", &as_pose);
    std::string pose_field;
    params.Optional("pose_field", &pose_field);
    if (!pose_field.empty() && !as_pose) params.Fail("pose_field", "only applies with as_pose: true");
    try {
      BagReader bag(bag_path);
      if (!bag.note().empty()) spdlog::warn("{}: {}", bag_path, bag.note());
      for (const auto& topic : topics) {
        bool found = false;
        for (const auto& info : bag.Topics()) found = found || info.topic == topic;
        if (!found) params.Fail("topics", "topic '" + topic + "' is not in " + bag_path);
      }
      bag.ForEach(topics, [&](const BagMessage& m) {
        const RegisteredType* type = FindType(m.type.datatype);
        if (!type || type->info.md5 != m.type.md5) {
          params.Fail("bag", bag_path + ": topic '" + m.topic + "' has type " + m.type.datatype +
                                 " unknown to iapsim's message registry");
        }
        const auto renamed = rename.find(m.topic);
        const std::string& topic = renamed == rename.end() ? m.topic : renamed->second;
        if (!as_pose) {
          queue_.push_back(Scheduled{MessageTimeNs(*type, m), topic, type, m.bytes});
          return true;
        }
        std::optional<StampedPose> pose;
        try {
          pose = ExtractPose(*type->schema, m.bytes.data(), m.bytes.size(), m.record_time_ns, pose_field);
        } catch (const std::exception& e) {
          params.Fail("bag", bag_path + ": topic '" + m.topic + "': " + e.what());
        }
        if (!pose) {
          params.Fail(pose_field.empty() ? "as_pose" : "pose_field",
                      bag_path + ": topic '" + m.topic + "' (" + m.type.datatype + ") holds no pose" +
                          (pose_field.empty() ? "" : " at '" + pose_field + "'"));
        }
        const Eigen::Vector3d position_m(pose->position[0], pose->position[1], pose->position[2]);
        const Eigen::Quaterniond orientation(pose->orientation_xyzw[3], pose->orientation_xyzw[0],
                                             pose->orientation_xyzw[1], pose->orientation_xyzw[2]);
        AddPose(pose->time_ns, topic, position_m, orientation);
        return true;
      });
    } catch (const BagError& e) {
      params.Fail("bag", e.what());
    }
  }

  void LoadPoseFile(YamlMap& params, const std::string& scenario_file) {
    const std::string path = ReadFilePath(params, "file", scenario_file);
    if (!params.Has("format")) params.Fail("format", "is required with file: tum or csv");
    std::string format;
    params.OptionalChoice("format", &format, {"tum", "csv"});
    std::string topic;
    params.Required("topic", &topic);
    for (const TimedPose& pose : ReadPoseFile(path, format)) {
      AddPose(std::llround(pose.t_s * 1e9), topic, pose.position_m, pose.orientation);
    }
  }

  void AddPose(int64_t time_ns, const std::string& topic, const Eigen::Vector3d& position_m,
               const Eigen::Quaterniond& orientation) {
    static const RegisteredType* const kPoseStamped = FindType("geometry_msgs/PoseStamped");
    geometry_msgs::PoseStamped message;
    message.header.stamp = ToRosTime(time_ns);
    message.header.frame_id = frame_id_;
    message.pose.position = ToPointMsg(position_m);
    message.pose.orientation = ToQuaternionMsg(orientation);
    queue_.push_back(Scheduled{time_ns, topic, kPoseStamped, Encode(message)});
  }

  // the time a message refers to: its stamp when it has one (what the data means), else when it was
  // recorded (a bag cannot store time 0, so the recorder writes t = 0 as 1 ns: read back as 0)
  static int64_t MessageTimeNs(const RegisteredType& type, const BagMessage& m) {
    return bridge::MessageTimeNs(*type.schema, m.bytes.data(), m.bytes.size())
        .value_or(m.record_time_ns == 1 ? 0 : m.record_time_ns);
  }

  static void ReadStringList(YamlMap& params, const std::string& key, std::vector<std::string>* out) {
    const YAML::Node node = params.Raw(key);
    if (!node) return;
    if (!node.IsSequence()) params.Fail(key, "expected a list of strings");
    for (const auto& item : node) {
      if (!item.IsScalar()) params.Fail(key, "expected a list of strings");
      out->push_back(item.Scalar());
    }
  }

  int64_t step_ns_;
  bool restamp_ = true;
  std::string frame_id_ = "W";
  Bus* bus_ = nullptr;
  std::vector<Scheduled> queue_;
  size_t next_ = 0;
  std::map<std::string, uint64_t> published_;
};

}  // namespace

std::unique_ptr<Process> MakeReplayer(const ProcessContext& context, YamlMap& params) {
  return std::make_unique<Replayer>(context, params);
}

}  // namespace iapsim::bridge
