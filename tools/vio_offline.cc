#include "tools/vio_offline.h"

#include <iapsim_msgs/UwbRanges.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Imu.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>
#include <utility>

#include "bridge/bag.h"
#include "bridge/config.h"
#include "bridge/eigen_msgs.h"
#include "bridge/message.h"
#include "bridge/message_format.h"
#include "bridge/pose_file.h"
#include "bridge/scenario.h"
#include "bridge/trajectory_error.h"
#include "render/camera_rig.h"
#include "render/image.h"
#include "sensors/imu.h"
#include "tools/plot_script.h"
#include "vio/config.h"
#include "vio/estimator.h"
#include "vio/run_setup.h"
#include "vio/stereo_tracker.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Milliseconds(Clock::time_point since) {
  return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

// A data-set problem: a missing topic, a camera model that disagrees. Exit code 2.
struct DatasetError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// A ground-truth odometry message without its header and covariances (kept for every stamp of the run).
struct TruthSample {
  geometry_msgs::Pose pose;
  geometry_msgs::Twist twist;  ///< in B (ROS)
};

struct SubAircraftResult {
  std::vector<bridge::StampedPose> estimate, truth;  // of the body B, at the image stamps
  std::map<int64_t, nav_msgs::Odometry> shared;      // the estimates as the vio process publishes them
  vio::EstimatorStatistics statistics;
  double decode_ms = 0.0, front_end_ms = 0.0, sequence_s = 0.0;
  int frames = 0;
};

struct DatasetInput {
  std::string bag_path;
  std::string scenario_path;
  vio::RunSetup setup;
};

DatasetInput ReadDataset(const VioOfflineArgs& args, const vio::VioConfig& config) {
  DatasetInput in;
  if (fs::is_directory(args.input)) {
    in.bag_path = (fs::path(args.input) / "run.bag").string();
    in.scenario_path =
        args.scenario.empty() ? (fs::path(args.input) / "scenario.resolved.yaml").string() : args.scenario;
  } else {
    in.bag_path = args.input;
    in.scenario_path = args.scenario.empty()
                           ? (fs::path(args.input).parent_path() / "scenario.resolved.yaml").string()
                           : args.scenario;
  }
  if (!fs::exists(in.bag_path)) throw DatasetError(in.bag_path + ": no such bag");
  if (!fs::exists(in.scenario_path)) {
    throw DatasetError(in.scenario_path +
                       ": no such scenario (the bag's run writes scenario.resolved.yaml beside it; "
                       "or give --scenario)");
  }
  const bridge::Scenario scenario = bridge::LoadScenario(in.scenario_path);
  in.setup = vio::ReadRunSetup(scenario, args.mode, config, args.sub_aircraft);
  return in;
}

// Every topic the estimation reads must be in the bag, and the recorded camera model must be the scenario's.
void CheckBag(const bridge::BagReader& bag, const vio::SubAircraftSetup& sub) {
  std::map<std::string, bridge::BagTopicInfo> topics;
  for (const bridge::BagTopicInfo& t : bag.Topics()) topics[t.topic] = t;
  for (const std::string* topic : {&sub.left_topic, &sub.right_topic, &sub.left_info_topic, &sub.imu_topic,
                                   &sub.truth_topic, &sub.attitude_topic}) {
    if (topic->empty() || (topics.count(*topic) != 0 && topics[*topic].count > 0)) continue;
    std::string images;
    for (const auto& [name, info] : topics) {
      if (info.datatype == "sensor_msgs/CompressedImage") images += " " + name;
    }
    throw DatasetError(
        bag.path() + ": no messages on " + *topic + " (" + sub.body + "'s stereo camera '" + sub.camera.name +
        "', its IMU, ground truth and, for virpo, attitude estimate are needed); the bag's images:" +
        (images.empty() ? " none" : images));
  }
  std::optional<sensor_msgs::CameraInfo> info;
  std::string error;
  bag.ForEach({sub.left_info_topic}, [&](const bridge::BagMessage& m) {
    info.emplace();
    if (!bridge::Decode(m.bytes, &*info, &error))
      throw DatasetError(bag.path() + ": " + m.topic + ": " + error);
    return false;
  });
  const render::CameraIntrinsics& K = sub.rig.intrinsics;
  const double tolerance = 1e-6 * K.fx;
  if (static_cast<int>(info->width) != K.width || static_cast<int>(info->height) != K.height ||
      std::abs(info->K[0] - K.fx) > tolerance || std::abs(info->K[4] - K.fy) > tolerance ||
      std::abs(info->K[2] - K.cx) > tolerance || std::abs(info->K[5] - K.cy) > tolerance) {
    char what[512];
    std::snprintf(
        what, sizeof(what),
        "%s: %s: the recorded camera (%ux%u, fx %.3f fy %.3f cx %.3f cy %.3f) is not the scenario's "
        "camera '%s' on %s (%dx%d, fx %.3f fy %.3f cx %.3f cy %.3f)",
        bag.path().c_str(), sub.left_info_topic.c_str(), info->width, info->height, info->K[0], info->K[4],
        info->K[2], info->K[5], sub.camera.name.c_str(), sub.body.c_str(), K.width, K.height, K.fx, K.fy,
        K.cx, K.cy);
    throw DatasetError(what);
  }
}

Eigen::Isometry3d PoseOf(const geometry_msgs::Pose& pose) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = bridge::FromMsg(pose.orientation).normalized().toRotationMatrix();
  X.translation() = bridge::FromMsg(pose.position);
  return X;
}

bridge::StampedPose Stamped(int64_t t_ns, const Eigen::Isometry3d& X) {
  bridge::StampedPose pose;
  pose.time_ns = t_ns;
  const Eigen::Quaterniond q(X.linear());
  for (int a = 0; a < 3; ++a) pose.position[a] = X.translation()(a);
  pose.orientation_xyzw[0] = q.x();
  pose.orientation_xyzw[1] = q.y();
  pose.orientation_xyzw[2] = q.z();
  pose.orientation_xyzw[3] = q.w();
  return pose;
}

// As `iapsim export --format tum` writes an odometry topic: the message's own numbers, not recomputed.
bridge::StampedPose Stamped(int64_t t_ns, const geometry_msgs::Pose& pose) {
  bridge::StampedPose stamped;
  stamped.time_ns = t_ns;
  const double values[7] = {pose.position.x,    pose.position.y,    pose.position.z,   pose.orientation.x,
                            pose.orientation.y, pose.orientation.z, pose.orientation.w};
  std::copy(values, values + 3, stamped.position);
  std::copy(values + 3, values + 7, stamped.orientation_xyzw);
  return stamped;
}

// Ground truth by topic and stamp: each sub-aircraft's (its first state starts the estimate) and the
// platform's.
using Truth = std::map<std::string, std::map<int64_t, TruthSample>>;

// The ground truth and, where the run's sensors carried a platform_imu, the platform's own attitude estimate
// by stamp (the centre takes its tilt and rate, as the vio process's platform instance does), in one pass.
Truth ReadTruth(const bridge::BagReader& bag, const DatasetInput& in, vio::PlatformAttitudes* attitudes) {
  const std::string& attitude_topic = in.setup.platform_attitude_topic;
  std::vector<std::string> topics;
  for (const vio::SubAircraftSetup& sub : in.setup.subs) topics.push_back(sub.truth_topic);
  if (!in.setup.platform_truth_topic.empty()) topics.push_back(in.setup.platform_truth_topic);
  if (!attitude_topic.empty()) topics.push_back(attitude_topic);
  Truth truth;
  nav_msgs::Odometry odometry;
  sensor_msgs::Imu attitude;
  std::string error;
  bag.ForEach(topics, [&](const bridge::BagMessage& m) {
    if (m.topic == attitude_topic) {
      if (!bridge::Decode(m.bytes, &attitude, &error))
        throw DatasetError(bag.path() + ": " + m.topic + ": " + error);
      (*attitudes)[bridge::ToNanoseconds(attitude.header.stamp)] = vio::PlatformAttitudeOf(attitude);
      return true;
    }
    if (!bridge::Decode(m.bytes, &odometry, &error))
      throw DatasetError(bag.path() + ": " + m.topic + ": " + error);
    truth[m.topic][bridge::ToNanoseconds(odometry.header.stamp)] = {odometry.pose.pose, odometry.twist.twist};
    return true;
  });
  if (!attitude_topic.empty() && attitudes->empty()) {
    throw DatasetError(bag.path() + ": no messages on " + attitude_topic +
                       " (the run's sensors process has a platform_imu, whose attitude the centre takes)");
  }
  return truth;
}

using Inputs = std::vector<std::function<void(vio::Estimator&)>>;

struct PendingPair {
  std::vector<uint8_t> left, right;
  bool Complete() const { return !left.empty() && !right.empty(); }
};

// A hand-over between two threads of the pass over the bag: Push waits while `capacity` items wait (0:
// never); after Close, Push refuses (returns false) and Pop returns what is left, then nothing.
template <typename T>
class HandOver {
 public:
  explicit HandOver(std::size_t capacity = 0) : capacity_(capacity) {}
  bool Push(T item) {
    std::unique_lock<std::mutex> lock(mutex_);
    room_.wait(lock, [&] { return closed_ || capacity_ == 0 || items_.size() < capacity_; });
    if (closed_) return false;
    items_.push_back(std::move(item));
    ready_.notify_one();
    return true;
  }
  std::optional<T> Pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [&] { return closed_ || !items_.empty(); });
    if (items_.empty()) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    room_.notify_one();
    return item;
  }
  void Close() {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
    room_.notify_all();
    ready_.notify_all();
  }

 private:
  const std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable room_, ready_;
  std::deque<T> items_;
  bool closed_ = false;
};

// How many stamps a front end may run ahead of the estimators, and the reader ahead of them.
constexpr std::size_t kStampsAhead = 8;
// The front ends' nice value above the estimators': they take the cores the estimators leave (at each
// stamp's meeting, while the slowest estimator finishes) without taking turns with them (measured on (a)-2,
// VIRPO: the two cores 1.87 busy at the same priority, 1.98 at 5 or 10, 1.94 at 3; 5 rather than 10 keeps
// their share against other work on the machine, which the estimators wait on them for).
constexpr int kFrontEndNiceness = 5;

// What a front end spent, over the pass.
struct FrontEndTiming {
  double decode_ms = 0.0, track_ms = 0.0;
};

// One sub-aircraft's front end on a thread of its own: it decodes and tracks the pairs it is given, in order,
// and hands each frame to each of its `consumers` (the estimations of one pass: a frame does not depend on
// the mode or the estimator's settings, so `--mode all` and `--mode anchors` track each image once). A front
// end needs nothing from the estimate, so it runs ahead of the lockstep estimators and fills the core that
// the slowest estimator of a stamp leaves the others waiting on (VIRPO on (a)-2 kept 1.80-1.83 of the two
// cores busy with decoding and tracking inside each estimator's step).
class FrontEnd {
 public:
  FrontEnd(const vio::SubAircraftSetup& sub, const vio::TrackerOptions& options, std::size_t consumers)
      : sub_(sub), tracker_(sub.rig, options), pairs_(kStampsAhead) {
    for (std::size_t c = 0; c < consumers; ++c) frames_.push_back(std::make_unique<HandOver<Tracked>>());
    thread_ = std::thread([this] { Loop(); });
  }
  ~FrontEnd() { Join(); }
  FrontEnd(const FrontEnd&) = delete;
  FrontEnd& operator=(const FrontEnd&) = delete;

  /// Queues the pair of `t_ns`; false once closed.
  bool Give(int64_t t_ns, PendingPair pair) { return pairs_.Push({t_ns, std::move(pair)}); }
  /// No more pairs: the front end tracks what it has and stops.
  void Close() { pairs_.Close(); }
  /// Consumer c's tracked frame of `t_ns`, its next in order; rethrows the front end's failure.
  vio::StereoFrame Take(std::size_t c, int64_t t_ns) {
    std::optional<Tracked> tracked = frames_[c]->Pop();
    if (!tracked)
      throw std::runtime_error(sub_.body + ": the front end stopped before the frame it was given");
    if (tracked->failure) std::rethrow_exception(tracked->failure);
    if (tracked->t_ns != t_ns) throw std::logic_error(sub_.body + ": the front end's frames are out of step");
    return std::move(tracked->frame);
  }
  /// Stops taking pairs and waits for the thread: what it has queued is dropped unless taken before.
  void Join() {
    pairs_.Close();
    for (auto& frames : frames_) frames->Close();
    if (thread_.joinable()) thread_.join();
  }
  /// What it spent; complete after Join.
  const FrontEndTiming& timing() const { return timing_; }

 private:
  struct Tracked {
    int64_t t_ns = 0;
    vio::StereoFrame frame;
    std::exception_ptr failure;
  };

  void Loop() {
    // Linux: the nice value is the thread's own (setpriority(2)); lowering it needs no privilege
    setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), getpriority(PRIO_PROCESS, 0) + kFrontEndNiceness);
    while (std::optional<std::pair<int64_t, PendingPair>> job = pairs_.Pop()) {
      Tracked tracked;
      tracked.t_ns = job->first;
      try {
        Clock::time_point stage = Clock::now();
        const render::Image left = render::DecodeImage(job->second.left, sub_.left_topic);
        const render::Image right = render::DecodeImage(job->second.right, sub_.right_topic);
        timing_.decode_ms += Milliseconds(stage);
        stage = Clock::now();
        tracked.frame = tracker_.Track(static_cast<double>(job->first) * 1e-9, left, right);
        timing_.track_ms += Milliseconds(stage);
      } catch (...) {
        tracked.failure = std::current_exception();
      }
      const bool failed = tracked.failure != nullptr;
      for (std::size_t c = 0; c + 1 < frames_.size(); ++c) frames_[c]->Push(tracked);
      frames_.back()->Push(std::move(tracked));
      if (failed) break;
    }
    for (auto& frames : frames_) frames->Close();
  }

  const vio::SubAircraftSetup& sub_;
  vio::StereoTracker tracker_;
  FrontEndTiming timing_;  ///< written by this thread only
  HandOver<std::pair<int64_t, PendingPair>> pairs_;
  // by consumer, unbounded: the pairs' bound and the reader's hold them to a few stamps
  std::vector<std::unique_ptr<HandOver<Tracked>>> frames_;
  std::thread thread_;
};

// One sub-aircraft's estimation during the pass over the bag.
struct SubAircraftRun {
  const vio::SubAircraftSetup* input = nullptr;
  const std::map<int64_t, TruthSample>* truth = nullptr;
  vio::Estimator estimator;
  std::vector<std::size_t> peer_index;  ///< by sub-aircraft: its index among this one's peers (virpo)
  Inputs inputs;  ///< IMU samples, attitudes and ranges in bag order, for the estimator's next frame (the
                  ///< reader's)
  std::optional<nav_msgs::Odometry> shared;  ///< this step's estimate, as the vio process publishes it
  SubAircraftResult result;

  SubAircraftRun(const vio::SubAircraftSetup& sub, const vio::EstimatorOptions& options)
      : input(&sub), estimator(sub.rig, options) {}

  // Gives the estimator the inputs that came before the frame, then the frame.
  void Estimate(int64_t t_ns, const vio::StereoFrame& frame, const Inputs& frame_inputs,
                const std::string& bag_path) {
    const vio::SubAircraftSetup& sub = *input;
    for (const auto& give : frame_inputs) give(estimator);
    const auto truth_now = truth->find(t_ns);
    if (result.frames == 0) {
      if (truth_now == truth->end()) {
        throw DatasetError(bag_path + ": " + sub.truth_topic +
                           " has no ground truth at the first image's stamp " +
                           std::to_string(static_cast<double>(t_ns) * 1e-9) + " s");
      }
      nav_msgs::Odometry first;  // as the vio process gets it
      first.pose.pose = truth_now->second.pose;
      first.twist.twist = truth_now->second.twist;
      estimator.SetInitialState(vio::ImuStateOf(first, sub.X_BI));
    }
    shared = vio::OdometryOf(estimator.AddFrame(frame), sub, t_ns);
    result.estimate.push_back(Stamped(t_ns, shared->pose.pose));
    result.shared[t_ns] = *shared;
    if (truth_now != truth->end()) result.truth.push_back(Stamped(t_ns, PoseOf(truth_now->second.pose)));
    ++result.frames;
  }
};

// What the bag has given of one sub-aircraft's images and IMU so far: the same for every estimation of the
// pass (the reader's).
struct SubAircraftFeed {
  std::map<int64_t, PendingPair> pairs;  ///< by stamp, until the step of that stamp
  double last_imu_t_s = -std::numeric_limits<double>::infinity();
};

// Feeds one bag message of a sub-aircraft to its feed (images, the IMU's clock) and to its estimation in each
// variant of the pass (`runs`): IMU samples to all, attitudes and ranges (to the variant's own anchors) to
// those whose mode reads them.
void Dispatch(const bridge::BagMessage& m, const std::string& bag_path, SubAircraftFeed* feed,
              const std::vector<SubAircraftRun*>& runs) {
  const vio::SubAircraftSetup& sub = *runs.front()->input;  // images and IMU: the same in every variant
  std::string error;
  const auto decode = [&](auto* message) {
    if (!bridge::Decode(m.bytes, message, &error))
      throw DatasetError(bag_path + ": " + m.topic + ": " + error);
  };
  if (m.topic == sub.imu_topic) {
    sensor_msgs::Imu imu;
    decode(&imu);
    sensors::ImuSample sample;
    sample.f_I_mps2 = bridge::FromMsg(imu.linear_acceleration);
    sample.w_I_radps = bridge::FromMsg(imu.angular_velocity);
    const double t_s = static_cast<double>(bridge::ToNanoseconds(imu.header.stamp)) * 1e-9;
    feed->last_imu_t_s = t_s;
    for (SubAircraftRun* run : runs)
      run->inputs.push_back([t_s, sample](vio::Estimator& e) { e.AddImu(t_s, sample); });
  } else if (m.topic == sub.left_topic || m.topic == sub.right_topic) {
    sensor_msgs::CompressedImage image;
    decode(&image);
    PendingPair& pair = feed->pairs[bridge::ToNanoseconds(image.header.stamp)];
    (m.topic == sub.left_topic ? pair.left : pair.right) = image.data;
  } else {
    std::optional<sensor_msgs::Imu> attitude;
    std::optional<iapsim_msgs::UwbRanges> ranges;
    for (SubAircraftRun* run : runs) {
      const vio::SubAircraftSetup& mine = *run->input;
      if (m.topic == mine.attitude_topic) {
        if (!attitude) decode(&attitude.emplace());
        const double t_s = static_cast<double>(bridge::ToNanoseconds(attitude->header.stamp)) * 1e-9;
        const Eigen::Quaterniond q_WI =
            bridge::FromMsg(attitude->orientation).normalized() * Eigen::Quaterniond(mine.X_BI.linear());
        run->inputs.push_back([t_s, q_WI](vio::Estimator& e) { e.AddAttitude(t_s, q_WI); });
      } else if (m.topic == mine.uwb_topic) {
        if (!ranges) {
          decode(&ranges.emplace());
          if (ranges->peers.size() != ranges->ranges_m.size())
            throw DatasetError(bag_path + ": " + m.topic + ": peers and ranges_m differ in length");
        }
        const double t_s = static_cast<double>(bridge::ToNanoseconds(ranges->header.stamp)) * 1e-9;
        for (std::size_t i = 0; i < ranges->peers.size(); ++i) {
          const auto anchor = mine.anchors_W.find(ranges->peers[i]);
          if (anchor == mine.anchors_W.end()) continue;
          const Eigen::Vector3d p_WA = anchor->second;
          const double range = ranges->ranges_m[i], sigma = mine.range_sigma_m;
          run->inputs.push_back([=](vio::Estimator& e) { e.AddRange(t_s, p_WA, range, sigma); });
        }
      }
    }
  }
}

// The stamp of the next step, when it can be taken: the earliest complete pair of any sub-aircraft, once
// every sub-aircraft's IMU has passed it (so everything its sensors sent at that instant, attitude and
// ranges too, is in: what the vio process has at that step) and each has its own pair there or has moved
// past it (a frame the renderer dropped for one sub-aircraft does not hold the others). At the end of the
// bag, whatever is left.
std::optional<int64_t> NextStep(const std::vector<SubAircraftFeed>& feeds, bool end_of_bag) {
  std::optional<int64_t> t_ns;
  for (const SubAircraftFeed& feed : feeds) {
    for (const auto& [stamp, pair] : feed.pairs) {
      if (!pair.Complete()) continue;
      if (!t_ns || stamp < *t_ns) t_ns = stamp;
      break;
    }
  }
  if (!t_ns || end_of_bag) return t_ns;
  for (const SubAircraftFeed& feed : feeds) {
    const double t_s = static_cast<double>(*t_ns) * 1e-9;
    if (feed.last_imu_t_s <= t_s) return std::nullopt;
    const auto here = feed.pairs.find(*t_ns);
    if ((here == feed.pairs.end() || !here->second.Complete()) &&
        feed.pairs.upper_bound(*t_ns) == feed.pairs.end())
      return std::nullopt;
  }
  return t_ns;
}

// One thread per sub-aircraft's estimator for the whole run, stepping it when told (with a thread started per
// stamp, VIO on (a)-2 ran at 0.75x real time; with these, 0.82x).
class StepWorkers {
 public:
  explicit StepWorkers(std::size_t count) : due_(count, false), failures_(count) {
    for (std::size_t i = 0; i < count; ++i) threads_.emplace_back([this, i] { Loop(i); });
  }
  ~StepWorkers() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    work_.notify_all();
    for (std::thread& thread : threads_) thread.join();
  }
  StepWorkers(const StepWorkers&) = delete;
  StepWorkers& operator=(const StepWorkers&) = delete;

  /// Starts job(i) on worker i for each i of `which` (the job must outlive the Wait that follows).
  void Start(const std::vector<std::size_t>& which, const std::function<void(std::size_t)>& job) {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &job;
    for (std::size_t i : which) due_[i] = true;
    remaining_ = which.size();
    work_.notify_all();
  }
  /// Returns when the started jobs are done, rethrowing the first failure.
  void Wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return remaining_ == 0; });
    for (std::exception_ptr& failure : failures_) {
      if (failure) std::rethrow_exception(std::exchange(failure, nullptr));
    }
  }

 private:
  void Loop(std::size_t i) {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      work_.wait(lock, [&] { return stop_ || due_[i]; });
      if (stop_) return;
      lock.unlock();
      try {
        (*job_)(i);
      } catch (...) {
        failures_[i] = std::current_exception();
      }
      lock.lock();
      due_[i] = false;
      if (--remaining_ == 0) done_.notify_one();
    }
  }

  std::mutex mutex_;
  std::condition_variable work_, done_;
  std::vector<bool> due_;
  std::vector<std::exception_ptr> failures_;
  std::size_t remaining_ = 0;
  bool stop_ = false;
  const std::function<void(std::size_t)>* job_ = nullptr;
  std::vector<std::thread> threads_;
};

// One estimation of a pass over the bag: a mode and the estimator's settings, its output folder, and the run
// as its scenario reads for it. The variants of one pass (`--mode all`, `--mode anchors`) differ in mode and
// anchors only: the same sub-aircraft, images and tracker settings, so that their front ends are shared.
struct Variant {
  std::string name;  ///< its folder in a series ("virpo", "anchors_2"); empty alone
  VioOfflineArgs args;
  vio::VioConfig config;
  DatasetInput in;
  std::string out_dir;
};

// Every sub-aircraft's estimation in each variant in one pass over the bag, in lockstep by image stamp: at
// each stamp the estimators step in parallel (one thread each), each seeing the others of its variant's
// joints as they shared them after the previous stamps (as processes exchanging odometry over the bus would,
// seed Fig. 4), so the result does not depend on the threads' timing, nor on the other variants of the
// pass. Three stages run at once: this thread reads the bag and hands each stamp's pairs to the front ends
// (one per sub-aircraft, each frame tracked once for every variant) and the stamp to the stepping thread,
// the front ends track ahead, and the stepping thread steps the estimators a stamp at a time. Returns the
// results by variant, then sub-aircraft.
std::vector<std::vector<SubAircraftResult>> EstimateAll(const bridge::BagReader& bag,
                                                        const std::vector<Variant>& variants,
                                                        const Truth& truth) {
  const std::vector<vio::SubAircraftSetup>& subs = variants.front().in.setup.subs;
  const std::size_t n = subs.size();
  const std::string& bag_path = variants.front().in.bag_path;
  for (const Variant& variant : variants) {
    const std::vector<vio::SubAircraftSetup>& own = variant.in.setup.subs;
    bool same = own.size() == n;
    for (std::size_t i = 0; same && i < n; ++i) {
      same = own[i].body == subs[i].body && own[i].left_topic == subs[i].left_topic &&
             own[i].right_topic == subs[i].right_topic && own[i].imu_topic == subs[i].imu_topic;
    }
    if (!same)
      throw std::logic_error("the variants of one pass over " + bag_path + " read other sub-aircraft");
  }
  std::vector<SubAircraftFeed> feeds(n);
  std::vector<SubAircraftRun> runs;  // variant v's sub-aircraft i at v * n + i
  runs.reserve(variants.size() * n);
  std::map<std::string, std::size_t> owner;  // topic → sub-aircraft
  std::vector<std::string> topics;
  for (const Variant& variant : variants) {
    for (std::size_t i = 0; i < n; ++i) {
      const vio::SubAircraftSetup& sub = variant.in.setup.subs[i];
      runs.emplace_back(sub,
                        vio::EstimatorOptionsFor(variant.in.setup, i, variant.args.mode, variant.config));
      runs.back().truth = &truth.at(sub.truth_topic);
      for (std::size_t o = 0; o < n; ++o) runs.back().peer_index.push_back(o < i ? o : o - 1);
      for (const std::string& topic :
           {sub.imu_topic, sub.left_topic, sub.right_topic, sub.uwb_topic, sub.attitude_topic}) {
        if (!topic.empty() && owner.emplace(topic, i).second) topics.push_back(topic);
      }
    }
  }
  std::vector<std::vector<SubAircraftRun*>> runs_of(n);  // by sub-aircraft, one per variant
  for (std::size_t k = 0; k < runs.size(); ++k) runs_of[k % n].push_back(&runs[k]);
  struct Stamp {
    int64_t t_ns = 0;
    std::vector<std::size_t> stepping;  ///< the sub-aircraft with a pair at t_ns
    std::vector<Inputs> inputs;         ///< by run, of those stepping
  };
  std::vector<std::unique_ptr<FrontEnd>> front_ends;
  for (const vio::SubAircraftSetup& sub : subs)
    front_ends.push_back(std::make_unique<FrontEnd>(sub, variants.front().config.tracker, variants.size()));
  HandOver<Stamp> stamps(kStampsAhead);
  const Stamp* stepping = nullptr;
  const std::function<void(std::size_t)> job = [&](std::size_t k) {
    runs[k].Estimate(stepping->t_ns, front_ends[k % n]->Take(k / n, stepping->t_ns), stepping->inputs[k],
                     bag_path);
  };
  StepWorkers workers(runs.size());  // after `job` and the front ends: joined before they go
  std::exception_ptr failure;        // the stepping thread's
  const auto stop = [&] {
    stamps.Close();
    for (auto& front_end : front_ends) front_end->Close();
  };
  std::thread stepper([&] {
    try {
      while (const std::optional<Stamp> stamp = stamps.Pop()) {
        std::vector<std::size_t> which;
        for (std::size_t v = 0; v < variants.size(); ++v) {
          for (std::size_t i : stamp->stepping) which.push_back(v * n + i);
        }
        for (SubAircraftRun& run : runs) run.shared.reset();
        stepping = &*stamp;
        workers.Start(which, job);
        workers.Wait();
        for (std::size_t v = 0; v < variants.size(); ++v) {
          if (variants[v].args.mode != "virpo") continue;
          SubAircraftRun* const own = &runs[v * n];
          for (std::size_t i : stamp->stepping) {
            const vio::PeerJoint joint = vio::PeerJointOf(*own[i].shared);
            for (std::size_t o : stamp->stepping) {
              if (o != i)
                own[o].estimator.AddPeerJoint(own[o].peer_index[i], static_cast<double>(stamp->t_ns) * 1e-9,
                                              joint);
            }
          }
        }
      }
    } catch (...) {
      failure = std::current_exception();
      stop();  // the reader stops at its next hand-over
    }
  });
  struct JoinOnExit {  // also when the reader throws
    std::function<void()> stop;
    std::thread& thread;
    ~JoinOnExit() {
      if (!thread.joinable()) return;
      stop();
      thread.join();
    }
  } join_stepper{stop, stepper};

  // Hands the stamp's pairs to the front ends and the stamp to the stepping thread; false once stopped.
  const auto hand_over = [&](int64_t t_ns) {
    Stamp stamp{t_ns, {}, std::vector<Inputs>(runs.size())};
    for (std::size_t i = 0; i < n; ++i) {
      SubAircraftFeed& feed = feeds[i];
      const auto pair = feed.pairs.find(t_ns);
      if (pair != feed.pairs.end() && pair->second.Complete()) {
        if (!front_ends[i]->Give(t_ns, std::move(pair->second))) return false;
        stamp.stepping.push_back(i);
        for (std::size_t v = 0; v < variants.size(); ++v) {
          stamp.inputs[v * n + i] = std::move(runs[v * n + i].inputs);
          runs[v * n + i].inputs.clear();
        }
      }
      feed.pairs.erase(feed.pairs.begin(), feed.pairs.upper_bound(t_ns));
    }
    return stamps.Push(std::move(stamp));
  };
  bool handing_over = true;
  const auto hand_over_ready = [&](bool end_of_bag) {
    while (handing_over) {
      const std::optional<int64_t> t_ns = NextStep(feeds, end_of_bag);
      if (!t_ns) return;
      handing_over = hand_over(*t_ns);
    }
  };
  bag.ForEach(topics, [&](const bridge::BagMessage& m) {
    const std::size_t i = owner.at(m.topic);
    Dispatch(m, bag_path, &feeds[i], runs_of[i]);
    hand_over_ready(false);
    return handing_over;
  });
  hand_over_ready(true);
  stop();
  stepper.join();
  if (failure) std::rethrow_exception(failure);

  std::vector<std::vector<SubAircraftResult>> results(variants.size());
  for (std::size_t k = 0; k < runs.size(); ++k) {
    SubAircraftRun& run = runs[k];
    FrontEnd& front_end = *front_ends[k % n];
    front_end.Join();  // its timing complete
    run.result.decode_ms = front_end.timing().decode_ms;
    run.result.front_end_ms = front_end.timing().track_ms;
    run.result.statistics = run.estimator.statistics();
    const auto& e = run.result.estimate;
    run.result.sequence_s =
        e.size() < 2 ? 0.0 : static_cast<double>(e.back().time_ns - e.front().time_ns) * 1e-9;
    results[k / n].push_back(std::move(run.result));
  }
  return results;
}

struct CentreResult {
  std::vector<bridge::StampedPose> estimate, truth;
};

// The platform pose at each stamp every sub-aircraft has an estimate for: the rigid transform that best
// carries the joints d_i (in P) onto the estimated joints (in W), X_WP = UmeyamaRigid(d, J), its tilt the
// platform's own attitude estimate's where the run has one; its truth from the platform's ground-truth
// odometry.
CentreResult EstimateCentre(const DatasetInput& in, const std::vector<SubAircraftResult>& results,
                            const Truth& truth, const vio::PlatformAttitudes& attitudes) {
  CentreResult out;
  std::map<int64_t, std::vector<nav_msgs::Odometry>> at;
  for (const SubAircraftResult& r : results) {
    for (const auto& [t_ns, odometry] : r.shared) at[t_ns].push_back(odometry);
  }
  for (const auto& [t_ns, subs] : at) {
    if (subs.size() != in.setup.joints_P.size()) continue;
    const vio::PlatformAttitude* attitude = nullptr;
    if (!in.setup.platform_attitude_topic.empty()) {
      attitude = vio::PlatformAttitudeAt(attitudes, t_ns);
      if (!attitude) {
        throw DatasetError(in.bag_path + ": no message on " + in.setup.platform_attitude_topic +
                           " at or before t = " + std::to_string(static_cast<double>(t_ns) * 1e-9) + " s");
      }
    }
    const nav_msgs::Odometry platform =
        vio::PlatformOdometryOf(in.setup.joints_P, subs, in.setup.vehicle_name, attitude);
    out.estimate.push_back(Stamped(t_ns, platform.pose.pose));
  }
  const auto platform = truth.find(in.setup.platform_truth_topic);
  if (platform == truth.end()) return out;
  for (const bridge::StampedPose& p : out.estimate) {
    const auto it = platform->second.find(p.time_ns);
    if (it != platform->second.end()) out.truth.push_back(Stamped(p.time_ns, PoseOf(it->second.pose)));
  }
  return out;
}

// Writes <out_dir>/<body with _>_estimate.tum and _truth.tum and returns the body's entry of vio.json: the
// file names and its errors (ATE as it is and aligned, RPE over 1 s), whose ATEs it also hands back.
nlohmann::json WriteTrajectory(const std::string& out_dir, const std::string& body,
                               const std::vector<bridge::StampedPose>& estimate,
                               const std::vector<bridge::StampedPose>& truth,
                               bridge::AbsoluteTrajectoryError* ate,
                               bridge::AbsoluteTrajectoryError* ate_aligned) {
  std::string stem = body;
  for (char& c : stem) c = c == '/' ? '_' : c;
  const std::string comment = "t x y z qx qy qz qw (W NED, body FRD; iapsim vio)";
  bridge::WriteTumFile((fs::path(out_dir) / (stem + "_estimate.tum")).string(), estimate, comment);
  bridge::WriteTumFile((fs::path(out_dir) / (stem + "_truth.tum")).string(), truth, comment);
  nlohmann::json entry = bridge::TrajectoryErrors(estimate, truth, ate, ate_aligned);
  entry["estimate_tum"] = stem + "_estimate.tum";
  entry["truth_tum"] = stem + "_truth.tum";
  return entry;
}

// A variant of the pass from its arguments; its output in `out_dir` (empty: <the bag's folder>/vio_<mode>).
Variant MakeVariant(const std::string& name, const VioOfflineArgs& args, const std::string& out_dir) {
  Variant variant;
  variant.name = name;
  variant.args = args;
  variant.config = vio::LoadVioConfig(args.config, args.overrides);
  variant.in = ReadDataset(args, variant.config);
  variant.out_dir = out_dir.empty()
                        ? (fs::path(variant.in.bag_path).parent_path() / ("vio_" + args.mode)).string()
                        : out_dir;
  return variant;
}

// Writes a variant's TUM files and vio.json, prints its table and returns the report. `wall_s` is the pass's,
// which estimated every variant of `pass` (names) at once.
nlohmann::json Report(const Variant& variant, const std::vector<SubAircraftResult>& results,
                      const Truth& truth, const vio::PlatformAttitudes& attitudes, double wall_s,
                      const std::vector<std::string>& pass) {
  const DatasetInput& in = variant.in;
  const std::string& mode = variant.args.mode;
  nlohmann::json report = {{"mode", mode}, {"bag", in.bag_path}, {"scenario", in.scenario_path}};
  std::printf("iapsim vio --mode %s on %s\n", mode.c_str(), in.bag_path.c_str());
  std::printf("  %-12s %7s %9s %8s %12s %12s %18s\n", "body", "frames", "keyframes", "failures", "ATE RMSE m",
              "aligned m", "ms/frame fe|solve");
  double sequence_s = 0.0;
  for (std::size_t i = 0; i < in.setup.subs.size(); ++i) {
    const vio::SubAircraftSetup& sub = in.setup.subs[i];
    const SubAircraftResult& r = results[i];
    const double per_frame = r.frames > 0 ? 1.0 / r.frames : 0.0;
    bridge::AbsoluteTrajectoryError ate, ate_aligned;
    nlohmann::json& entry = report["sub_aircraft"][sub.body];
    entry = WriteTrajectory(variant.out_dir, sub.body, r.estimate, r.truth, &ate, &ate_aligned);
    entry["frames"] = r.frames;
    entry["keyframes"] = r.statistics.keyframes;
    entry["failures"] = r.statistics.failures;
    entry["ranges_used"] = r.statistics.ranges_used;
    entry["attitude_constraints"] = r.statistics.attitude_constraints;
    entry["kinematic_constraints"] = r.statistics.kinematic_constraints;
    entry["last_failure"] = r.statistics.last_failure;
    entry["ms_per_frame"] = {{"decode", r.decode_ms * per_frame},
                             {"front_end", r.front_end_ms * per_frame},
                             {"solve", r.statistics.solve_ms * per_frame},
                             {"marginalisation", r.statistics.marginalisation_ms * per_frame}};
    entry["sequence_s"] = r.sequence_s;
    std::printf("  %-12s %7d %9d %8d %12.4f %12.4f %8.1f|%-8.1f\n", sub.body.c_str(), r.frames,
                r.statistics.keyframes, r.statistics.failures, ate.rmse_m, ate_aligned.rmse_m,
                r.front_end_ms * per_frame, r.statistics.solve_ms * per_frame);
    sequence_s = std::max(sequence_s, r.sequence_s);
  }
  if (!in.setup.joints_P.empty()) {
    const std::string centre =
        in.setup.platform_truth_topic.substr(1, in.setup.platform_truth_topic.rfind('/') - 1) + "/platform";
    const CentreResult c = EstimateCentre(in, results, truth, attitudes);
    bridge::AbsoluteTrajectoryError ate, ate_aligned;
    report["centre"] = WriteTrajectory(variant.out_dir, centre, c.estimate, c.truth, &ate, &ate_aligned);
    report["centre"]["body"] = centre;
    std::printf("  %-12s %7zu %9s %8s %12.4f %12.4f   (from the sub-aircraft and the joints)\n",
                centre.c_str(), c.estimate.size(), "", "", ate.rmse_m, ate_aligned.rmse_m);
  }
  const double real_time = wall_s > 0.0 ? sequence_s / wall_s : 0.0;
  report["wall_s"] = wall_s;
  report["real_time_factor"] = real_time;
  std::string together;
  if (pass.size() > 1) {
    report["pass"] = pass;  // wall_s and real_time_factor are of them all
    for (const std::string& name : pass) together += (together.empty() ? "" : ", ") + name;
    together = ", estimating " + together + " in one pass";
  }
  const std::string report_path = (fs::path(variant.out_dir) / "vio.json").string();
  std::ofstream(report_path) << report.dump(2) << "\n";
  std::printf("  %.1f s of data in %.1f s (%.2fx real time%s); %s\n", sequence_s, wall_s, real_time,
              together.c_str(), report_path.c_str());
  return report;
}

// Estimates every variant (of one data set, see Variant) in one pass over the bag and returns their reports.
std::vector<nlohmann::json> RunPass(const std::vector<Variant>& variants) {
  const DatasetInput& in = variants.front().in;
  // before the estimation, so that an output folder that cannot be made fails at once
  for (const Variant& variant : variants) fs::create_directories(variant.out_dir);
  const Clock::time_point start = Clock::now();
  const bridge::BagReader bag(in.bag_path);
  for (const Variant& variant : variants) {
    for (const vio::SubAircraftSetup& sub : variant.in.setup.subs) CheckBag(bag, sub);
  }
  vio::PlatformAttitudes attitudes;
  const Truth truth = ReadTruth(bag, in, &attitudes);
  const std::vector<std::vector<SubAircraftResult>> results = EstimateAll(bag, variants, truth);
  const double wall_s = Milliseconds(start) * 1e-3;

  std::vector<std::string> pass;
  for (const Variant& variant : variants) pass.push_back(variant.name);
  std::vector<nlohmann::json> reports;
  for (std::size_t v = 0; v < variants.size(); ++v)
    reports.push_back(Report(variants[v], results[v], truth, attitudes, wall_s, pass));
  return reports;
}

// Runs `variants` (each a name and the arguments of one run, its output in <out_dir>/<name>) in one pass over
// their bag and returns the ATE RMSE of each body and the centre by variant ({body: {variant: m}}), the
// bodies in the runs' order.
nlohmann::json RunVariants(const std::vector<std::pair<std::string, VioOfflineArgs>>& variants,
                           const fs::path& out_dir, std::vector<std::string>* bodies) {
  std::vector<Variant> pass;
  for (const auto& [name, args] : variants)
    pass.push_back(MakeVariant(name, args, (out_dir / name).string()));
  nlohmann::json table = nlohmann::json::object();
  const std::vector<nlohmann::json> reports = RunPass(pass);
  for (std::size_t v = 0; v < pass.size(); ++v) {
    const nlohmann::json& report = reports[v];
    const std::string& name = pass[v].name;
    for (const auto& [body, entry] : report["sub_aircraft"].items()) {
      if (!table.contains(body)) bodies->push_back(body);
      table[body][name] = entry["ate"]["rmse_m"];
    }
    if (report.contains("centre")) {
      const std::string centre = report["centre"]["body"];
      if (!table.contains(centre)) bodies->push_back(centre);
      table[centre][name] = report["centre"]["ate"]["rmse_m"];
    }
  }
  return table;
}

fs::path SeriesFolder(const VioOfflineArgs& args, const std::string& name) {
  const fs::path input_dir =
      fs::is_directory(args.input) ? fs::path(args.input) : fs::path(args.input).parent_path();
  return args.out_dir.empty() ? input_dir / name : fs::path(args.out_dir);
}

std::string Cell(double value) {
  char cell[32];
  std::snprintf(cell, sizeof(cell), " %.4f |", value);
  return cell;
}

// Writes table.md and table.json, then the plots of tools/plot_vio.py `kind` (a failed plot is reported on
// stderr; the tables stay).
void WriteTable(const fs::path& out_dir, const std::string& md, const nlohmann::json& table,
                const std::string& kind) {
  std::ofstream(out_dir / "table.md") << md;
  std::ofstream(out_dir / "table.json") << table.dump(2) << "\n";
  std::printf("\n%s\n%s\n", md.c_str(), (out_dir / "table.md").c_str());
  if (RunPlotScript(IAPSIM_PLOT_VIO, {kind, out_dir.string()})) {
    std::printf("plots in %s: %s\n", out_dir.c_str(),
                kind == "modes" ? "ate_boxplot.png, trajectories.png" : "anchors.png");
  }
}

// `--mode all`: the three modes on the same data, each in its own folder, and a table like the seed's
// Table VIII (ATE RMSE of each sub-aircraft and the centre by mode, and VIRPO's gain over VIO+UWB) as
// table.md and table.json.
void CompareModes(const VioOfflineArgs& args) {
  const std::vector<std::string> modes{"vio", "vio_uwb", "virpo"};
  const fs::path out_dir = SeriesFolder(args, "vio_all");
  std::vector<std::pair<std::string, VioOfflineArgs>> variants;
  for (const std::string& mode : modes) {
    variants.emplace_back(mode, args);
    variants.back().second.mode = mode;
  }
  std::vector<std::string> bodies;
  nlohmann::json table = RunVariants(variants, out_dir, &bodies);
  std::string md =
      "ATE RMSE (m) of `iapsim vio --mode all` on " + args.input + " (seed Table VIII's layout)\n\n|";
  std::string rule = "|";
  for (const std::string& body : bodies) {
    for (const char* mode : {"VIO", "VIO+UWB", "VIRPO"}) {
      md += " " + body + " " + mode + " |";
      rule += "---|";
    }
  }
  md += "\n" + rule + "\n|";
  double gain_sum = 0.0;
  for (const std::string& body : bodies) {
    for (const std::string& mode : modes) md += Cell(table[body][mode].get<double>());
    const double uwb = table[body]["vio_uwb"].get<double>(), virpo = table[body]["virpo"].get<double>();
    table[body]["virpo_gain_over_vio_uwb"] = uwb > 0.0 ? 1.0 - virpo / uwb : 0.0;
    gain_sum += table[body]["virpo_gain_over_vio_uwb"].get<double>();
  }
  char mean[160];
  std::snprintf(mean, sizeof(mean), "\n\nVIRPO's mean gain over VIO+UWB: %.1f %% (the seed's: 24.07 %%)\n",
                100.0 * gain_sum / static_cast<double>(bodies.size()));
  md += mean;
  WriteTable(out_dir, md, table, "modes");
}

// `--mode anchors`: the seed's Table VII, VIO with 0 anchors, then VIO+UWB ranging to the scenario's first
// 1, 2, ... anchors (in its order), each in <out>/anchors_<n>, and the ATE RMSE of each sub-aircraft by
// anchor count as table.md and table.json (with whether it decreases as anchors are added, as in the seed).
void CompareAnchorCounts(const VioOfflineArgs& args) {
  VioOfflineArgs uwb = args;
  uwb.mode = "vio_uwb";
  const std::vector<std::string> names =
      ReadDataset(uwb, vio::LoadVioConfig(args.config, args.overrides)).setup.anchor_names;
  const fs::path out_dir = SeriesFolder(args, "vio_anchors");
  std::vector<std::pair<std::string, VioOfflineArgs>> variants;
  std::string chosen;
  for (std::size_t n = 0; n <= names.size(); ++n) {
    if (n > 0) chosen += (n > 1 ? "," : "") + names[n - 1];
    variants.emplace_back("anchors_" + std::to_string(n), uwb);
    VioOfflineArgs& variant = variants.back().second;
    if (n == 0) variant.mode = "vio";
    variant.overrides.push_back("uwb.anchors=[" + chosen + "]");
  }
  std::vector<std::string> bodies;
  nlohmann::json table = RunVariants(variants, out_dir, &bodies);
  std::string md = "ATE RMSE (m) by the number of UWB anchors, `iapsim vio --mode anchors` on " + args.input +
                   " (seed Table VII's layout; anchors added in the scenario's order: " + chosen +
                   ")\n\n| number of anchors |";
  std::string rule = "|---|";
  for (std::size_t n = 0; n <= names.size(); ++n) {
    md += " " + std::to_string(n) + " |";
    rule += "---|";
  }
  md += " decreasing |\n" + rule + "---|\n";
  for (const std::string& body : bodies) {
    md += "| " + body + " |";
    bool decreasing = true;
    for (std::size_t n = 0; n <= names.size(); ++n) {
      const double rmse = table[body]["anchors_" + std::to_string(n)].get<double>();
      md += Cell(rmse);
      if (n > 0 && rmse > table[body]["anchors_" + std::to_string(n - 1)].get<double>()) decreasing = false;
    }
    table[body]["decreasing"] = decreasing;
    md += decreasing ? " yes |\n" : " no |\n";
  }
  if (names.size() == 4) md += "| seed, one aircraft | 0.66 | 0.53 | 0.50 | 0.19 | 0.13 | yes |\n";
  WriteTable(out_dir, md, table, "anchors");
}

}  // namespace

int VioOffline(const VioOfflineArgs& args) {
  try {
    if (args.mode == "all") {
      CompareModes(args);
    } else if (args.mode == "anchors") {
      CompareAnchorCounts(args);
    } else {
      RunPass({MakeVariant("", args, args.out_dir)});
    }
    return 0;
  } catch (const bridge::ConfigError& error) {
    std::fprintf(stderr, "iapsim vio: %s\n", error.what());
    return 2;
  } catch (const std::invalid_argument& error) {
    std::fprintf(stderr, "iapsim vio: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "iapsim vio: %s\n", error.what());
    return 1;
  }
}

}  // namespace iapsim::tools
