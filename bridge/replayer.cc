#include "bridge/replayer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>

#include "bridge/bag.h"
#include "bridge/message_registry.h"

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
    double offset_s = context.scenario.clock.step_s;
    params.OptionalInRange("time_offset_s", &offset_s, context.scenario.clock.step_s, 1e7);
    params.Optional("restamp", &restamp_);

    // the whole selection is loaded up front: a bad bag or an unknown type fails the --check, not the run
    try {
      BagReader bag(bag_path);
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
        queue_.push_back(Scheduled{MessageTimeNs(*type, m),
                                   renamed == rename.end() ? m.topic : renamed->second, type, m.bytes});
        return true;
      });
      // the earliest message of the selection plays at time_offset_s; order by message time
      std::stable_sort(queue_.begin(), queue_.end(),
                       [](const Scheduled& a, const Scheduled& b) { return a.due_ns < b.due_ns; });
      const int64_t origin_ns = queue_.empty() ? 0 : queue_.front().due_ns;
      for (auto& m : queue_) m.due_ns += std::llround(offset_s * 1e9) - origin_ns;
    } catch (const BagError& e) {
      params.Fail("bag", e.what());
    }
  }

  void Setup(Bus& bus) override { bus_ = &bus; }

  void Step(const StepInfo& step) override {
    // publish what is due by the next step
    const int64_t horizon_ns = step.stamp_ns + step_ns_;
    while (next_ < queue_.size() && queue_[next_].due_ns <= horizon_ns) {
      Scheduled& m = queue_[next_++];
      const int offset = m.type->schema->HeaderStampOffset();
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
  // the time a message refers to: its header.stamp when it has one (what the data means), else when it was
  // recorded (a bag cannot store time 0, so record times of t = 0 read 1 ns)
  static int64_t MessageTimeNs(const RegisteredType& type, const BagMessage& m) {
    const int offset = type.schema->HeaderStampOffset();
    if (offset < 0 || m.bytes.size() < static_cast<size_t>(offset) + 8) return m.record_time_ns;
    uint32_t sec, nsec;
    std::memcpy(&sec, m.bytes.data() + offset, 4);
    std::memcpy(&nsec, m.bytes.data() + offset + 4, 4);
    return int64_t{sec} * 1000000000 + nsec;
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
