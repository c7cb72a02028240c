#include "rosbridge/ros_bridge.h"

#include <iapsim_msgs/IapState.h>
#include <ros/callback_queue.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <spdlog/spdlog.h>
#include <tf2_msgs/TFMessage.h>
#include <topic_tools/shape_shifter.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "bridge/eigen_msgs.h"
#include "bridge/message_registry.h"
#include "model/urdf.h"
#include "rosbridge/mount_frames.h"
#include "rosbridge/ros_master.h"
#include "rosbridge/vehicle_tf.h"

namespace iapsim::rosbridge {
namespace {

using Clock = std::chrono::steady_clock;

// a registered type by name; a ROS type iapsim does not know cannot be checked or stamped
const bridge::RegisteredType* ReadType(bridge::YamlMap& entry) {
  std::string name;
  entry.Required("type", &name);
  const bridge::RegisteredType* type = bridge::FindType(name);
  if (!type) {
    std::string known;
    for (const bridge::RegisteredType* t : bridge::AllTypes())
      known += (known.empty() ? "" : ", ") + t->info.datatype;
    entry.Fail("type", "'" + name + "' is not a message type iapsim knows (" + known + ")");
  }
  return type;
}

void CheckTopicName(bridge::YamlMap& entry, const std::string& key, const std::string& name) {
  if (name.size() < 2 || name[0] != '/' || name.back() == '/' ||
      name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_/") !=
          std::string::npos ||
      name.find("//") != std::string::npos) {
    entry.Fail(key, "expected a global topic name such as /iap/odom (letters, digits, '_' and '/'), got '" +
                        name + "'");
  }
}

// {topic, type, as} of a to_ros or from_ros entry: where from, the type, where to (default: the same name)
void ReadRoute(bridge::YamlMap& entry, std::string* from, const bridge::RegisteredType** type,
               std::string* to) {
  entry.Required("topic", from);
  CheckTopicName(entry, "topic", *from);
  *type = ReadType(entry);
  *to = *from;
  entry.Optional("as", to);
  CheckTopicName(entry, "as", *to);
}

// Calls `read` with each entry of the list under `key` (absent: none), then checks the entry's keys.
template <class Read>
void ReadList(bridge::YamlMap& params, const std::string& key, const std::string& expected, Read read) {
  const YAML::Node list = params.Raw(key);
  if (list && !list.IsSequence()) params.Fail(key, "expected a list of " + expected);
  YAML::Node resolved(YAML::NodeType::Sequence);  // each entry as read (a file's path made absolute)
  for (size_t i = 0; list && i < list.size(); ++i) {
    bridge::YamlMap entry(list[i], params.file(), params.PathOf(key) + "[" + std::to_string(i) + "]");
    read(entry);
    entry.Finish();
    resolved.push_back(entry.Resolved());
  }
  params.SetResolved(key, resolved);
}

// rate_hz of a forwarded topic: the first message of each window of 1/rate of its stamp passes
struct StampWindow {
  int64_t period_ns = 0;  // 0: every message
  int64_t last_window = -1;

  void SetRate(double rate_hz) {
    period_ns = rate_hz > 0.0 ? std::max<int64_t>(1, std::llround(1e9 / rate_hz)) : 0;
  }
  bool Passes(int64_t stamp_ns) {
    if (period_ns == 0) return true;
    const int64_t window = stamp_ns / period_ns;
    if (window <= last_window) return false;
    last_window = window;
    return true;
  }
};

// Round trips of a question (a to_ros message) to its answer (a from_ros message of the same stamp), in ms.
struct RoundTrips {
  std::deque<std::pair<int64_t, int64_t>> open;  // (stamp, bus send time) of questions not answered yet
  std::vector<double> ms;
  uint64_t unanswered = 0;           // questions overtaken by the answer to a later one
  uint64_t before_first_answer = 0;  // questions before the first answer: the answering node was not up yet

  void Asked(int64_t stamp_ns, int64_t sent_unix_ns) { open.emplace_back(stamp_ns, sent_unix_ns); }
  void Answered(int64_t stamp_ns, int64_t now_unix_ns) {
    while (!open.empty() && open.front().first < stamp_ns) {
      open.pop_front();
      ++(ms.empty() ? before_first_answer : unanswered);
    }
    if (!open.empty() && open.front().first == stamp_ns) {
      ms.push_back(static_cast<double>(now_unix_ns - open.front().second) * 1e-6);
      open.pop_front();
    }
  }
  nlohmann::json Report() {
    // open at the end: asked too late for an answer to reach the bus before the run stopped
    nlohmann::json report = {{"answered", ms.size()},
                             {"unanswered", unanswered},
                             {"before_first_answer", before_first_answer},
                             {"open_at_end", open.size()}};
    if (ms.empty()) return report;
    std::sort(ms.begin(), ms.end());
    const auto at = [this](double q) {
      return ms[std::min(ms.size() - 1, static_cast<size_t>(q * ms.size()))];
    };
    report["p50_ms"] = at(0.5);
    report["p99_ms"] = at(0.99);
    report["max_ms"] = ms.back();
    return report;
  }
};

struct ToRos {
  std::string topic, ros_topic;
  const bridge::RegisteredType* type = nullptr;
  StampWindow rate;
  ros::Publisher publisher;
  topic_tools::ShapeShifter shape;
  std::optional<RoundTrips> round_trips;  // a from_ros topic answers this one
  struct Held {
    std::vector<uint8_t> bytes;
    std::optional<int64_t> stamp_ns;
    int64_t sent_unix_ns;
  };
  std::vector<Held> held;  // lockstep, answered: forwarded at the next step
  int64_t last_forwarded_stamp_ns = -1;
  uint64_t forwarded = 0, thinned = 0;
};

struct FromRos {
  std::string ros_topic, topic;
  const bridge::RegisteredType* type = nullptr;
  std::string answers;  // ROS name of the to_ros topic it answers; "" none
  ToRos* question = nullptr;
  double answer_timeout_s = 10.0;
  ros::Subscriber subscriber;
  int64_t newest_stamp_ns = -1;
  uint64_t received = 0, forwarded = 0, wrong_type = 0;
};

geometry_msgs::TransformStamped ToMsg(const FrameTransform& t, const ros::Time& stamp) {
  geometry_msgs::TransformStamped m;
  m.header.stamp = stamp;
  m.header.frame_id = t.parent;
  m.child_frame_id = t.child;
  m.transform.translation = bridge::ToVector3Msg(t.p_parent_child_m);
  m.transform.rotation = bridge::ToQuaternionMsg(t.q_parent_child);
  return m;
}

// a vehicle on /tf: its frames (rosbridge/vehicle_tf.h) and its --ros URDF
struct TfVehicle {
  std::string name;
  model::Vehicle model;
  std::optional<VehicleTf> frames;
  StampWindow rate;
  uint64_t published = 0;
};

class RosBridge : public bridge::Process {
 public:
  RosBridge(const bridge::ProcessContext& context, bridge::YamlMap& params)
      : mode_(context.scenario.mode),
        ros_dir_((context.run_dir.empty() ? std::string(".") : context.run_dir) + "/ros") {
    params.OptionalChoice("master", &master_, {"environment", "private"});
    params.OptionalInRange("master_port", &master_port_, 0, 65535);
    params.OptionalInRange("master_timeout_s", &master_timeout_s_, 0.1, 600.0);
    params.Optional("node_name", &node_name_);
    params.Optional("clock", &clock_);
    params.OptionalInRange("queue_size", &queue_size_, 1, 100000);
    params.OptionalInRange("poll_period_us", &poll_period_us_, 10, 100000);
    if (master_ == "environment" && params.Has("master_port")) {
      params.Fail("master_port",
                  "is for master: private (with master: environment, ROS_MASTER_URI says where)");
    }
    ReadToRos(params);
    ReadFromRos(params);
    // a lockstep step that waits for an answer neither acknowledges nor sends a heartbeat meanwhile: the
    // clock and the launcher must wait as long
    for (const FromRos& f : from_ros_) {
      const double longest_s = std::min(context.self.hang_timeout_s, context.scenario.clock.ack_timeout_s);
      if (f.question && mode_ == bridge::ClockMode::kLockstep && longest_s <= f.answer_timeout_s) {
        std::ostringstream what;
        what << "lockstep waits up to answer_timeout_s (" << f.answer_timeout_s << " s) for " << f.ros_topic
             << ": give clock.ack_timeout_s and this process's hang_timeout_s more (they are "
             << context.scenario.clock.ack_timeout_s << " and " << context.self.hang_timeout_s << " s)";
        params.Fail("from_ros", what.str());
      }
    }
    if (params.Has("tf")) ReadTf(params.Map("tf"), context.scenario);
    if (to_ros_.empty() && from_ros_.empty() && tf_vehicles_.empty()) {
      params.Fail("to_ros", "nothing to forward: give to_ros, from_ros or tf");
    }
  }

  ~RosBridge() override {
    if (!ros::isInitialized()) return;
    for (ToRos& t : to_ros_) t.publisher.shutdown();
    for (FromRos& f : from_ros_) f.subscriber.shutdown();
    clock_publisher_.shutdown();
    tf_publisher_.shutdown();
    tf_static_publisher_.shutdown();
    node_.reset();
    ros::shutdown();
    // the private master stops after this node has unregistered from it
    master_process_.reset();
  }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    StartRos();
    for (TfVehicle& v : tf_vehicles_) {
      bus.Subscribe<iapsim_msgs::IapState>(
          "/" + v.name + "/state",
          [this, &v](const iapsim_msgs::IapState& state, const bridge::MessageInfo&) { OnState(v, state); });
    }
    for (ToRos& t : to_ros_) {
      bus.SubscribeSerialized(t.topic, t.type->info,
                              [this, &t](const uint8_t* data, size_t size, const bridge::MessageInfo& info) {
                                FromBus(t, data, size, info);
                              });
    }
  }

  std::chrono::microseconds poll_period() const override {
    return std::chrono::microseconds(poll_period_us_);
  }

  // realtime and fast: what ROS sent goes onto the bus now
  void Poll() override {
    if (mode_ == bridge::ClockMode::kLockstep) return;
    queue_.callAvailable(ros::WallDuration(0));
    CheckMaster();
  }

  void Step(const bridge::StepInfo& step) override {
    if (clock_) {
      clock_message_.clock = bridge::ToRosTime(step.stamp_ns);
      clock_publisher_.publish(clock_message_);
    }
    if (mode_ != bridge::ClockMode::kLockstep) {
      queue_.callAvailable(ros::WallDuration(0));
      return;
    }
    CheckMaster();
    if (!connected_) WaitForAnsweringNodes();
    for (ToRos& t : to_ros_) {
      for (const ToRos::Held& m : t.held)
        Publish(t, m.bytes.data(), m.bytes.size(), m.stamp_ns, m.sent_unix_ns);
      t.held.clear();
    }
    queue_.callAvailable(ros::WallDuration(0));
    for (FromRos& f : from_ros_) {
      if (f.question) WaitForAnswer(f, step);
    }
  }

  void Finish(nlohmann::json* report) override {
    (*report)["ros_master"] = ros::master::getURI();
    for (ToRos& t : to_ros_) {
      nlohmann::json& r = (*report)["to_ros"][t.ros_topic];
      r = {{"from", t.topic},
           {"forwarded", t.forwarded},
           {"thinned", t.thinned},
           {"subscribers", t.publisher ? t.publisher.getNumSubscribers() : 0}};
      if (t.round_trips) r["round_trip"] = t.round_trips->Report();
    }
    for (const TfVehicle& v : tf_vehicles_) (*report)["tf"][v.name] = {{"published", v.published}};
    for (FromRos& f : from_ros_) {
      (*report)["from_ros"][f.ros_topic] = {{"to", f.topic},
                                            {"received", f.received},
                                            {"forwarded", f.forwarded},
                                            {"wrong_type", f.wrong_type}};
    }
  }

 private:
  void ReadToRos(bridge::YamlMap& params) {
    ReadList(params, "to_ros", "{topic, type, as, rate_hz}", [this](bridge::YamlMap& entry) {
      ToRos& t = to_ros_.emplace_back();
      ReadRoute(entry, &t.topic, &t.type, &t.ros_topic);
      double rate_hz = 0.0;
      entry.OptionalInRange("rate_hz", &rate_hz, 0.0, 1e6);
      if (rate_hz > 0.0) {
        if (t.type->schema->StampOffset() < 0) {
          entry.Fail("rate_hz", "needs a stamped type (" + t.type->info.datatype + " has no header.stamp)");
        }
        t.rate.SetRate(rate_hz);
      }
      for (size_t j = 0; j + 1 < to_ros_.size(); ++j) {
        if (to_ros_[j].ros_topic == t.ros_topic)
          entry.Fail("as", "ROS topic '" + t.ros_topic + "' is used twice");
      }
    });
  }

  void ReadFromRos(bridge::YamlMap& params) {
    ReadList(params, "from_ros", "{topic, type, as, answers}", [this](bridge::YamlMap& entry) {
      FromRos& f = from_ros_.emplace_back();
      ReadRoute(entry, &f.ros_topic, &f.type, &f.topic);
      entry.Optional("answers", &f.answers);
      entry.OptionalInRange("answer_timeout_s", &f.answer_timeout_s, 0.001, 3600.0);
      if (f.answers.empty()) return;
      for (ToRos& t : to_ros_) {
        if (t.ros_topic == f.answers) f.question = &t;
      }
      if (!f.question) entry.Fail("answers", "'" + f.answers + "' is not the ROS name of a to_ros topic");
      if (f.question->round_trips) entry.Fail("answers", "'" + f.answers + "' is answered twice");
      if (f.type->schema->StampOffset() < 0 || f.question->type->schema->StampOffset() < 0) {
        entry.Fail("answers", "question and answer must both be stamped types (" +
                                  f.question->type->info.datatype + ", " + f.type->info.datatype + ")");
      }
      f.question->round_trips.emplace();
    });
  }

  void ReadTf(bridge::YamlMap tf, const bridge::Scenario& scenario) {
    double rate_hz = 50.0;
    tf.OptionalInRange("rate_hz", &rate_hz, 0.0, 1e6);
    tf.Optional("robot_description", &robot_description_);
    ReadList(tf, "vehicles", "{name, file}", [&](bridge::YamlMap& entry) {
      TfVehicle& v = tf_vehicles_.emplace_back();
      entry.Required("name", &v.name);
      const std::string file = bridge::ReadFilePath(entry, "file", scenario.file);
      try {
        v.model = model::LoadVehicle(file);
      } catch (const std::exception& e) {
        entry.Fail("file", e.what());
      }
      v.frames.emplace(v.model, v.name);
      v.rate.SetRate(rate_hz);
    });
    if (tf_vehicles_.empty()) tf.Fail("vehicles", "is required: the vehicles whose frames go on /tf");
    const YAML::Node mounts = tf.Raw("mounts_from");
    if (mounts && !mounts.IsSequence()) tf.Fail("mounts_from", "expected a list of process names");
    for (size_t i = 0; mounts && i < mounts.size(); ++i) {
      if (!mounts[i].IsScalar()) tf.Fail("mounts_from", "expected a list of process names");
      const std::string process = mounts[i].Scalar();
      try {
        MountFrames frames = ReadMountFrames(scenario, process);
        mount_frames_.insert(mount_frames_.end(), frames.fixed.begin(), frames.fixed.end());
        for (const std::string& frame : frames.moving) {
          spdlog::info("tf: {} of '{}' moves with its body and is not on /tf", frame, process);
        }
      } catch (const std::exception& e) {
        tf.Fail("mounts_from", e.what());
      }
    }
    tf.Finish();
  }

  // /tf_static (latched) and each vehicle's URDF on the parameter server
  void StartTf() {
    if (tf_vehicles_.empty()) return;
    tf_publisher_ = node_->advertise<tf2_msgs::TFMessage>("/tf", static_cast<uint32_t>(queue_size_));
    tf_static_publisher_ = node_->advertise<tf2_msgs::TFMessage>("/tf_static", 1, /*latch=*/true);
    tf2_msgs::TFMessage fixed;
    fixed.transforms.push_back(ToMsg(WorldToNed(), ros::Time(0)));
    for (const TfVehicle& v : tf_vehicles_) {
      for (const FrameTransform& t : v.frames->fixed()) fixed.transforms.push_back(ToMsg(t, ros::Time(0)));
      if (!robot_description_) continue;
      const std::string urdf = model::GenerateRosUrdf(v.model);
      ros::param::set("/" + v.name + "/robot_description", urdf);
      if (tf_vehicles_.size() == 1) ros::param::set("/robot_description", urdf);
    }
    for (const FrameTransform& t : mount_frames_) fixed.transforms.push_back(ToMsg(t, ros::Time(0)));
    tf_static_publisher_.publish(fixed);
  }

  void OnState(TfVehicle& v, const iapsim_msgs::IapState& state) {
    if (!v.rate.Passes(bridge::ToNanoseconds(state.header.stamp))) return;
    tf_message_.transforms.clear();
    for (const FrameTransform& t : v.frames->Moving(state)) {
      tf_message_.transforms.push_back(ToMsg(t, state.header.stamp));
    }
    tf_publisher_.publish(tf_message_);
    ++v.published;
  }

  void StartRos() {
    ros::M_string remappings;
    if (master_ == "private") {
      master_process_.emplace(master_port_, ros_dir_);
      remappings["__master"] = master_process_->uri();
      remappings["__ip"] = "127.0.0.1";
    } else if (!std::getenv("ROS_MASTER_URI")) {
      throw std::runtime_error("master: environment, but ROS_MASTER_URI is not set (or use master: private)");
    }
    ros::init(remappings, node_name_, ros::init_options::NoSigintHandler);
    const auto deadline = Clock::now() + std::chrono::duration<double>(master_timeout_s_);
    while (!ros::master::check()) {
      CheckMaster();
      if (Clock::now() > deadline) {
        throw std::runtime_error("the ROS master at " + ros::master::getURI() + " did not answer within " +
                                 std::to_string(master_timeout_s_) + " s (master_timeout_s)");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    // written once the master answers: a user (or a test) starts ROS nodes when the file appears
    if (master_process_) {
      std::ofstream(ros_dir_ + "/master_uri") << master_process_->uri() << "\n";
    }
    spdlog::info("ROS master {}{}", ros::master::getURI(),
                 master_process_ ? " (private: export ROS_MASTER_URI=" + ros::master::getURI() + ")" : "");
    node_.emplace();
    node_->setCallbackQueue(&queue_);
    if (master_process_ && clock_) ros::param::set("/use_sim_time", true);
    if (clock_)
      clock_publisher_ = node_->advertise<rosgraph_msgs::Clock>("/clock", static_cast<uint32_t>(queue_size_));
    for (ToRos& t : to_ros_) {
      t.shape.morph(t.type->info.md5, t.type->info.datatype, t.type->info.definition, "0");
      t.publisher = t.shape.advertise(*node_, t.ros_topic, static_cast<uint32_t>(queue_size_));
    }
    StartTf();
    for (FromRos& f : from_ros_) {
      const boost::function<void(const topic_tools::ShapeShifter::ConstPtr&)> callback =
          [this, &f](const topic_tools::ShapeShifter::ConstPtr& message) { FromRosMessage(f, *message); };
      f.subscriber = node_->subscribe<topic_tools::ShapeShifter>(
          f.ros_topic, static_cast<uint32_t>(queue_size_), callback, ros::VoidConstPtr(),
          ros::TransportHints().tcpNoDelay());
    }
  }

  void CheckMaster() {
    if (!master_process_) return;
    const auto now = Clock::now();
    if (now - last_master_check_ < std::chrono::seconds(1)) return;
    last_master_check_ = now;
    master_process_->CheckAlive();
  }

  void FromBus(ToRos& t, const uint8_t* data, size_t size, const bridge::MessageInfo& info) {
    const std::optional<int64_t> stamp_ns = bridge::MessageStampNs(*t.type->schema, data, size);
    if (stamp_ns && !t.rate.Passes(*stamp_ns)) {
      ++t.thinned;
      return;
    }
    // lockstep: a question goes out at this process's step, once its answering node listens
    if (t.round_trips && mode_ == bridge::ClockMode::kLockstep) {
      t.held.push_back({std::vector<uint8_t>(data, data + size), stamp_ns, info.sent_unix_ns});
      return;
    }
    Publish(t, data, size, stamp_ns, info.sent_unix_ns);
  }

  void Publish(ToRos& t, const uint8_t* data, size_t size, std::optional<int64_t> stamp_ns,
               int64_t sent_unix_ns) {
    if (t.round_trips && stamp_ns) {
      t.round_trips->Asked(*stamp_ns, sent_unix_ns);
      t.last_forwarded_stamp_ns = *stamp_ns;
    }
    ros::serialization::IStream stream(const_cast<uint8_t*>(data), static_cast<uint32_t>(size));
    t.shape.read(stream);
    t.publisher.publish(t.shape);
    ++t.forwarded;
  }

  void FromRosMessage(FromRos& f, const topic_tools::ShapeShifter& message) {
    ++f.received;
    if (message.getMD5Sum() != f.type->info.md5) {
      if (f.wrong_type++ == 0) {
        spdlog::warn(
            "ROS topic {}: a {} (md5 {}) where {} was configured: not forwarded (counted as wrong_type)",
            f.ros_topic, message.getDataType(), message.getMD5Sum(), f.type->info.datatype);
      }
      return;
    }
    buffer_.resize(message.size());
    ros::serialization::OStream stream(buffer_.data(), static_cast<uint32_t>(buffer_.size()));
    message.write(stream);
    bus_->PublishRaw(f.topic, f.type->info, buffer_.data(), buffer_.size());
    ++f.forwarded;
    if (!f.question) return;
    if (const auto stamp_ns = bridge::MessageStampNs(*f.type->schema, buffer_.data(), buffer_.size())) {
      f.newest_stamp_ns = std::max(f.newest_stamp_ns, *stamp_ns);
      f.question->round_trips->Answered(*stamp_ns, bridge::UnixTimeNs());
    }
  }

  // lockstep, before the first question goes out: a node that the master lists as subscribing to the
  // question and publishing the answer, and every subscriber of the question connected to this node (a
  // question sent before would be lost; another subscriber, such as rviz, is not taken for the answering
  // node)
  void WaitForAnsweringNodes() {
    for (FromRos& f : from_ros_) {
      if (!f.question) continue;
      const auto deadline = Clock::now() + std::chrono::duration<double>(f.answer_timeout_s);
      while (!AnsweringNodeConnected(f)) {
        if (Clock::now() > deadline) {
          throw std::runtime_error("no ROS node subscribed to " + f.answers + " and publishing " +
                                   f.ros_topic + " (connected) within " + std::to_string(f.answer_timeout_s) +
                                   " s (answer_timeout_s of " + f.ros_topic + "), at " +
                                   ros::master::getURI());
        }
        CheckMaster();
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
    connected_ = true;
  }

  bool AnsweringNodeConnected(const FromRos& f) const {
    XmlRpc::XmlRpcValue request, response, state;
    request[0] = ros::this_node::getName();
    if (!ros::master::execute("getSystemState", request, response, state, false)) return false;
    // state: [publishers, subscribers, services], each [[topic, [node, ...]], ...]
    const auto nodes_of = [&state](int kind, const std::string& topic) {
      std::set<std::string> nodes;
      for (int i = 0; i < state[kind].size(); ++i) {
        if (static_cast<std::string>(state[kind][i][0]) != topic) continue;
        for (int n = 0; n < state[kind][i][1].size(); ++n)
          nodes.insert(static_cast<std::string>(state[kind][i][1][n]));
      }
      return nodes;
    };
    const std::set<std::string> answering = nodes_of(0, f.ros_topic), asked = nodes_of(1, f.answers);
    const bool both = std::any_of(asked.begin(), asked.end(), [&answering](const std::string& node) {
      return answering.count(node) > 0;
    });
    return both && f.question->publisher.getNumSubscribers() >= asked.size() &&
           f.subscriber.getNumPublishers() > 0;
  }

  void WaitForAnswer(FromRos& f, const bridge::StepInfo& step) {
    const int64_t asked_ns = f.question->last_forwarded_stamp_ns;
    const auto deadline = Clock::now() + std::chrono::duration<double>(f.answer_timeout_s);
    while (f.newest_stamp_ns < asked_ns) {
      if (Clock::now() > deadline) {
        throw std::runtime_error("lockstep: no answer on ROS topic " + f.ros_topic + " to the " + f.answers +
                                 " of t = " + std::to_string(static_cast<double>(asked_ns) * 1e-9) +
                                 " s within " + std::to_string(f.answer_timeout_s) +
                                 " s (answer_timeout_s), at step " + std::to_string(step.step));
      }
      queue_.callAvailable(ros::WallDuration(0.001));
      CheckMaster();
    }
  }

  bridge::ClockMode mode_;
  std::string ros_dir_;  // RUN/ros: the private master's logs and URI
  std::string master_ = "environment";
  int master_port_ = 0;
  double master_timeout_s_ = 30.0;
  std::string node_name_ = "iapsim_bridge";
  bool clock_ = true;
  int queue_size_ = 100;
  int poll_period_us_ = 100;
  std::deque<ToRos> to_ros_;  // deque: callbacks hold references to the entries
  std::deque<FromRos> from_ros_;
  std::deque<TfVehicle> tf_vehicles_;
  std::vector<FrameTransform> mount_frames_;  // sensors' and cameras' (tf.mounts_from)
  bool robot_description_ = true;

  bridge::Bus* bus_ = nullptr;
  std::optional<PrivateRosMaster> master_process_;
  Clock::time_point last_master_check_{};
  ros::CallbackQueue queue_;
  std::optional<ros::NodeHandle> node_;
  ros::Publisher clock_publisher_, tf_publisher_, tf_static_publisher_;
  tf2_msgs::TFMessage tf_message_;
  rosgraph_msgs::Clock clock_message_;
  std::vector<uint8_t> buffer_;
  bool connected_ = false;
};

}  // namespace

std::unique_ptr<bridge::Process> MakeRosBridge(const bridge::ProcessContext& context,
                                               bridge::YamlMap& params) {
  return std::make_unique<RosBridge>(context, params);
}

}  // namespace iapsim::rosbridge
