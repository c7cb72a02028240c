#include "bridge/recorder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>

#include "bridge/bag.h"
#include "bridge/message_registry.h"

namespace iapsim::bridge {
namespace {

using Clock = std::chrono::steady_clock;

constexpr char kTickTopic[] = "/iapsim/tick";
constexpr char kAckTopic[] = "/iapsim/ack";
// a publisher's written messages are moved out of its buffer once they are the larger part and at least this
constexpr size_t kReclaimBytes = 1 << 20;

double Seconds(Clock::duration duration) { return std::chrono::duration<double>(duration).count(); }

// One publisher's messages not written yet, in its send order, in buffers reused from step to step, and the
// steps its acknowledgements (or ticks) closed.
struct Publisher {
  struct Message {
    uint32_t connection;  // in the bag
    uint32_t size;
    size_t offset;     // in bytes
    int64_t stamp_ns;  // the sim time it refers to; -1: none (the step that closed it stands in)
  };
  struct Close {
    uint64_t step;
    uint64_t end;  // number of messages received before the acknowledgement of `step`
  };
  std::vector<uint8_t> bytes;
  std::vector<Message> messages;
  size_t next_message = 0;  // messages[next_message..] are not written yet
  uint64_t reclaimed = 0;   // messages removed from the front of `messages` (numbering for Close::end)
  std::vector<Close> closes;
  size_t next_close = 0;

  void Add(uint32_t connection, const uint8_t* data, size_t size, int64_t stamp_ns) {
    messages.push_back({connection, static_cast<uint32_t>(size), bytes.size(), stamp_ns});
    bytes.insert(bytes.end(), data, data + size);
  }
  void CloseStep(uint64_t step) { closes.push_back({step, reclaimed + messages.size()}); }
  bool HasClosedSteps() const { return next_close < closes.size(); }
  uint64_t NextClosedStep() const { return closes[next_close].step; }
  // The end of the messages closed by the next close (an index into `messages`).
  size_t EndOfNextClose() const { return static_cast<size_t>(closes[next_close].end - reclaimed); }

  // Drops what was written once it outweighs the rest (so an element is moved about once at most), and the
  // messages' bytes all at once when everything is written.
  void Reclaim() {
    if (next_close > closes.size() - next_close) {
      closes.erase(closes.begin(), closes.begin() + static_cast<std::ptrdiff_t>(next_close));
      next_close = 0;
    }
    if (next_message == messages.size()) {
      reclaimed += messages.size();
      messages.clear();
      bytes.clear();
      next_message = 0;
      return;
    }
    const size_t written_bytes = messages[next_message].offset;
    if (written_bytes < kReclaimBytes || written_bytes < bytes.size() - written_bytes) return;
    bytes.erase(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(written_bytes));
    messages.erase(messages.begin(), messages.begin() + static_cast<std::ptrdiff_t>(next_message));
    for (Message& m : messages) m.offset -= written_bytes;
    reclaimed += next_message;
    next_message = 0;
  }
};

class Recorder : public Process {
 public:
  Recorder(const ProcessContext& context, YamlMap& params)
      : recording_(context.scenario.recording), step_ns_(context.scenario.step_ns()) {
    (void)params;  // the recorder is configured by the scenario's `recording` section
    if (!context.run_dir.empty()) bag_path_ = context.run_dir + "/run.bag";
  }

  void Setup(Bus& bus) override {
    BagWriterOptions options;
    options.compression = recording_.compression == "lz4" ? BagCompression::kLz4 : BagCompression::kNone;
    bag_ = std::make_unique<BagWriter>(bag_path_, options);
    bus.SubscribeRaw("", [this](const uint8_t* data, size_t size, const MessageInfo& info) {
      OnMessage(data, size, info);
    });
  }

  bool StepsAfterPeers() const override { return true; }

  void Step(const StepInfo& step) override {
    const auto start = Clock::now();
    WriteStep(step.step);
    step_s_ += Seconds(Clock::now() - start);
  }

  void Finish(nlohmann::json* report) override {
    if (!bag_) return;
    const auto start = Clock::now();
    // the runtime has read what was still on the bus; the run may have ended early (a process died): write
    // what each publisher closed, step by step, then whatever else reached us
    while (true) {
      bool any = false;
      uint64_t step = 0;
      for (const auto& [name, publisher] : publishers_) {
        if (!publisher.HasClosedSteps()) continue;
        step = any ? std::min(step, publisher.NextClosedStep()) : publisher.NextClosedStep();
        any = true;
      }
      if (!any) break;
      WriteStep(step);
    }
    for (auto& [name, publisher] : publishers_)
      WriteMessages(publisher, publisher.messages.size(), last_step_stamp_ns_);
    step_s_ += Seconds(Clock::now() - start);
    bag_->Close();
    Report(report);
  }

 private:
  enum class Kind { kData, kTick, kAck };
  // what the recorder does with the messages of one (publisher, topic), found by MessageInfo::stream
  struct Stream {
    Publisher* publisher = nullptr;  // null: not seen yet
    Kind kind = Kind::kData;
    int64_t connection = -1;            // in the bag; -1 when the topic is not recorded
    std::string md5;                    // a publisher that changes the topic's type gets another connection
    const SchemaSet* schema = nullptr;  // recorded topics: finds the message's stamp
  };

  void OnMessage(const uint8_t* data, size_t size, const MessageInfo& info) {
    if (info.stream >= streams_.size()) streams_.resize(info.stream + 1);
    Stream& stream = streams_[info.stream];
    if (stream.publisher == nullptr || stream.md5 != info.md5) stream = MakeStream(info);
    if (stream.connection >= 0) {
      const int64_t stamp_ns = MessageTimeNs(*stream.schema, data, size).value_or(-1);
      stream.publisher->Add(static_cast<uint32_t>(stream.connection), data, size, stamp_ns);
    }
    // acks and ticks are sent after the data they close (same socket, same order); both messages begin
    // with `uint64 step`, and the runtime decodes and checks them in full
    if (stream.kind != Kind::kData) {
      uint64_t step;
      if (size < sizeof(step)) {
        throw BusError("recorder: a " + info.datatype + " of " + std::to_string(size) + " bytes from '" +
                       info.publisher + "'");
      }
      std::memcpy(&step, data, sizeof(step));
      stream.publisher->CloseStep(step);
    }
  }

  Stream MakeStream(const MessageInfo& info) {
    Stream stream;
    stream.publisher = &publishers_[info.publisher];
    stream.md5 = info.md5;
    if (info.topic == kTickTopic) stream.kind = Kind::kTick;
    if (info.topic == kAckTopic) stream.kind = Kind::kAck;
    if (!recording_.Records(info.topic)) return stream;
    const RegisteredType* type = FindType(info.datatype);
    if (!type || type->info.md5 != info.md5) {
      throw BusError("recorder: topic '" + info.topic + "' from '" + info.publisher + "' has type " +
                     info.datatype + " (md5 " + info.md5 +
                     ") that is not in iapsim's message registry (bridge/message_registry.cc)");
    }
    stream.connection = bag_->Connection(info.topic, type->info, info.publisher);
    stream.schema = type->schema.get();
    if (connection_topics_.size() <= static_cast<size_t>(stream.connection)) {
      connection_topics_.resize(stream.connection + 1);
      written_.resize(stream.connection + 1, 0);
    }
    connection_topics_[stream.connection] = info.topic;
    const double rate_hz = recording_.MaxRateHz(info.topic);
    if (periods_ns_.size() <= static_cast<size_t>(stream.connection)) {
      periods_ns_.resize(stream.connection + 1, 0);
      last_windows_.resize(stream.connection + 1, -1);
      thinned_.resize(stream.connection + 1, 0);
    }
    periods_ns_[stream.connection] = rate_hz > 0.0 ? std::max<int64_t>(1, std::llround(1e9 / rate_hz)) : 0;
    return stream;
  }

  // Writes every publisher's messages closed by steps up to `step`, publishers in name order. A message's
  // record time is its own stamp (the sim time it refers to, whenever it arrived); a message without one, or
  // stamped 0 (unset), is recorded at the sim time of the step whose acknowledgement closed it.
  void WriteStep(uint64_t step) {
    for (auto& [name, publisher] : publishers_) {
      while (publisher.HasClosedSteps() && publisher.NextClosedStep() <= step) {
        const int64_t step_stamp_ns = static_cast<int64_t>(publisher.NextClosedStep()) * step_ns_;
        last_step_stamp_ns_ = std::max(last_step_stamp_ns_, step_stamp_ns);
        WriteMessages(publisher, publisher.EndOfNextClose(), step_stamp_ns);
        ++publisher.next_close;
      }
      publisher.Reclaim();
    }
  }

  // recording.max_rate_hz: a topic's message is kept when it is the first in its window of 1/rate of record
  // time (sim time, so the same run thins the same messages)
  void WriteMessages(Publisher& publisher, size_t end, int64_t step_stamp_ns) {
    for (; publisher.next_message < end; ++publisher.next_message) {
      const Publisher::Message& m = publisher.messages[publisher.next_message];
      const int64_t record_time_ns = m.stamp_ns >= 0 ? m.stamp_ns : step_stamp_ns;
      if (const int64_t period_ns = periods_ns_[m.connection]; period_ns > 0) {
        const int64_t window = record_time_ns / period_ns;
        if (window <= last_windows_[m.connection]) {
          ++thinned_[m.connection];
          continue;
        }
        last_windows_[m.connection] = window;
      }
      bag_->Write(m.connection, record_time_ns, publisher.bytes.data() + m.offset, m.size);
      ++written_[m.connection];
    }
  }

  void Report(nlohmann::json* report) const {
    std::map<std::string, uint64_t> by_topic, thinned;
    uint64_t messages = 0;
    for (size_t c = 0; c < written_.size(); ++c) {
      by_topic[connection_topics_[c]] += written_[c];
      messages += written_[c];
      if (thinned_[c] > 0) thinned[connection_topics_[c]] += thinned_[c];
    }
    // everything but writing, measured as the process's CPU time less the time spent writing (reading the
    // bus, copying messages): the clock is not read for every message
    const CpuTime cpu = ProcessCpuTime();
    const double receive_s = std::max(0.0, cpu.user_s + cpu.system_s - step_s_);
    const BagWriterStats& stats = bag_->stats();
    (*report)["bag"] = bag_path_;
    (*report)["recorded"] = by_topic;
    (*report)["thinned"] = thinned;  // left out by recording.max_rate_hz
    (*report)["messages"] = messages;
    (*report)["bag_bytes"] = stats.file_bytes;
    (*report)["chunks"] = stats.chunks;
    (*report)["record_bytes"] = stats.record_bytes;
    (*report)["compression"] = recording_.compression;
    (*report)["compression_ratio"] =
        stats.chunk_data_bytes > 0 ? static_cast<double>(stats.record_bytes) / stats.chunk_data_bytes : 1.0;
    (*report)["write_calls"] = stats.write_calls;
    // where the recorder's time went: copying messages off the bus, building bag records, compressing, and
    // the write system calls
    (*report)["time_s"] = {{"receive", receive_s},
                           {"records", std::max(0.0, step_s_ - stats.compress_s - stats.write_s)},
                           {"compress", stats.compress_s},
                           {"write", stats.write_s}};
  }

  RecordingConfig recording_;
  int64_t step_ns_;
  std::string bag_path_;
  std::unique_ptr<BagWriter> bag_;
  std::map<std::string, Publisher> publishers_;  // by name: std::map gives the canonical order
  std::vector<Stream> streams_;                  // by MessageInfo::stream
  std::vector<std::string> connection_topics_;   // by bag connection
  std::vector<uint64_t> written_;                // by bag connection
  std::vector<int64_t> periods_ns_;              // by bag connection: 1 / max_rate_hz; 0: every message
  std::vector<int64_t> last_windows_;            // by bag connection: the window of the last message kept
  std::vector<uint64_t> thinned_;                // by bag connection: messages left out by max_rate_hz
  int64_t last_step_stamp_ns_ = 0;               // of the newest step a publisher closed
  double step_s_ = 0.0;                          // writing to the bag, compression and system calls included
};

}  // namespace

std::unique_ptr<Process> MakeRecorder(const ProcessContext& context, YamlMap& params) {
  return std::make_unique<Recorder>(context, params);
}

}  // namespace iapsim::bridge
