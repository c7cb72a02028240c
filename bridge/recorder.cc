#include "bridge/recorder.h"

#include <spdlog/spdlog.h>

#include <map>

#include "bridge/bag.h"
#include "bridge/message_registry.h"

namespace iapsim::bridge {
namespace {

constexpr char kTickTopic[] = "/iapsim/tick";
constexpr char kAckTopic[] = "/iapsim/ack";

bool StartsWithAny(const std::string& topic, const std::vector<std::string>& prefixes) {
  for (const auto& p : prefixes) {
    if (topic.compare(0, p.size(), p) == 0) return true;
  }
  return false;
}

class Recorder : public Process {
 public:
  Recorder(const ProcessContext& context, YamlMap& params) : recording_(context.scenario.recording) {
    (void)params;  // the recorder is configured by the scenario's `recording` section
    if (!context.run_dir.empty()) bag_path_ = context.run_dir + "/run.bag";
  }

  void Setup(Bus& bus) override {
    bag_ = std::make_unique<BagWriter>(bag_path_);
    bus.SubscribeRaw("", [this](const uint8_t* data, size_t size, const MessageInfo& info) {
      OnMessage(data, size, info);
    });
  }

  bool StepsAfterPeers() const override { return true; }

  void Step(const StepInfo& step) override {
    last_stamp_ns_ = step.stamp_ns;
    for (auto& [publisher, queue] : queues_) WriteClosed(publisher, queue, step.stamp_ns);
  }

  void Finish(nlohmann::json* report) override {
    if (!bag_) return;
    // the run may end early (a process died): keep everything that reached us
    for (auto& [publisher, queue] : queues_) {
      queue.closed = queue.messages.size();
      WriteClosed(publisher, queue, last_stamp_ns_);
    }
    bag_->Close();
    nlohmann::json topics = nlohmann::json::object();
    for (const auto& [topic, count] : written_) topics[topic] = count;
    (*report)["bag"] = bag_path_;
    (*report)["recorded"] = topics;
  }

 private:
  struct Pending {
    std::string topic;
    const TypeInfo* type;
    std::vector<uint8_t> bytes;
  };
  struct Queue {
    std::vector<Pending> messages;
    size_t closed = 0;  // messages[0, closed) precede the publisher's latest ack
  };

  void OnMessage(const uint8_t* data, size_t size, const MessageInfo& info) {
    Queue& queue = queues_[info.publisher];
    const bool recorded = (recording_.include.empty() || StartsWithAny(info.topic, recording_.include)) &&
                          !StartsWithAny(info.topic, recording_.exclude);
    if (recorded) Enqueue(queue, data, size, info);
    // acks and ticks are sent after the data they close (same socket, same order)
    if (info.topic == kAckTopic || info.topic == kTickTopic) queue.closed = queue.messages.size();
  }

  void Enqueue(Queue& queue, const uint8_t* data, size_t size, const MessageInfo& info) {
    const RegisteredType* type = FindType(info.datatype);
    if (!type || type->info.md5 != info.md5) {
      throw BusError("recorder: topic '" + info.topic + "' from '" + info.publisher + "' has type " +
                     info.datatype + " (md5 " + info.md5 +
                     ") that is not in iapsim's message registry (bridge/message_registry.cc)");
    }
    queue.messages.push_back(Pending{info.topic, &type->info, std::vector<uint8_t>(data, data + size)});
  }

  void WriteClosed(const std::string& publisher, Queue& queue, int64_t stamp_ns) {
    for (size_t i = 0; i < queue.closed; ++i) {
      const Pending& m = queue.messages[i];
      bag_->Write(m.topic, *m.type, stamp_ns, m.bytes.data(), m.bytes.size(), publisher);
      ++written_[m.topic];
    }
    queue.messages.erase(queue.messages.begin(), queue.messages.begin() + static_cast<long>(queue.closed));
    queue.closed = 0;
  }

  RecordingConfig recording_;
  std::string bag_path_;
  std::unique_ptr<BagWriter> bag_;
  std::map<std::string, Queue> queues_;  // by publisher name: std::map gives the canonical order
  std::map<std::string, uint64_t> written_;
  int64_t last_stamp_ns_ = 0;
};

}  // namespace

std::unique_ptr<Process> MakeRecorder(const ProcessContext& context, YamlMap& params) {
  return std::make_unique<Recorder>(context, params);
}

}  // namespace iapsim::bridge
