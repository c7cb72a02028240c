// iapsim_vio: one sub-aircraft's estimator on the bus (seed §IV-D, Fig. 4), a lockstep participant, or the
// platform's from theirs (`platform: true`). A sub-aircraft's instance reads
// its stereo pair, IMU and, by mode, its UWB ranges and attitude estimate, and publishes its odometry at each
// image's stamp; in virpo mode it shares that odometry with the other sub-aircraft's instances and uses
// theirs. The estimator is vio/estimator.h, fed exactly as `iapsim vio` feeds it from a bag, so a recorded
// run's estimates can be checked against the offline runner's.
//
//   params      sub: NAME (a sub-aircraft of the sensors process's vehicle, with a stereo camera)
//               mode: vio | vio_uwb | virpo
//               settings: FILE (vio/config.h, relative to the scenario), and tracker, estimator, uwb,
//               virpo: the estimator's settings over it
//   subscribes  /<vehicle>/<sub>/<camera>/{left,right}/image_raw/compressed, /<vehicle>/<sub>/imu,
//               /<vehicle>/<sub>/odom (the first frame's ground truth ties the estimate to W, seed §VI-G),
//               /<vehicle>/<sub>/uwb (vio_uwb, virpo), /<vehicle>/<sub>/attitude and every other
//               sub-aircraft's /<vehicle>/<other>/vio/odom (virpo)
//   publishes   /<vehicle>/<sub>/vio/odom  nav_msgs/Odometry (body pose in W, twist in B), at the image stamp
//               /<vehicle>/<sub>/vio/imu_propagate  the same, the newest frame carried by the IMU to its
//               newest sample (vio/imu_propagator.h), at each step that has a newer sample
//
// Schedule: rate_hz = the IMU's (the camera's gives only the frames), `after: [render, sensors]` (a frame
// and its IMU arrive in the step they are drawn), and in virpo `after_previous: [the other instances]`: each
// uses the others' odometry of the frames before its own, as `iapsim vio` does, so the run is deterministic.
//
// With `platform: true` it estimates the platform from every sub-aircraft's odometry at each stamp
// (PlatformOdometryOf: the joints fitted rigidly) and publishes /<vehicle>/vio/odom (pose in W, twist in P,
// the form the controller's odometry_topic reads), and from their propagated odometry
// /<vehicle>/vio/imu_propagate; give it `after: [every instance]` and the instances' rate. Where the sensors
// process carries a platform_imu, the platform's roll, pitch and rate are that IMU's attitude EKF's
// (/<vehicle>/attitude) at each stamp, the yaw and the position the sub-aircraft's, as in `iapsim vio`.

#include <iapsim_msgs/UwbRanges.h>
#include <malloc.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Imu.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>

#include "bridge/eigen_msgs.h"
#include "bridge/process.h"
#include "render/image.h"
#include "vio/config.h"
#include "vio/estimator.h"
#include "vio/imu_propagator.h"
#include "vio/run_setup.h"
#include "vio/stereo_tracker.h"

namespace iapsim::vio {
namespace {

double Seconds(int64_t t_ns) { return static_cast<double>(t_ns) * 1e-9; }

class VioNode : public bridge::Process {
 public:
  VioNode(const bridge::ProcessContext& context, bridge::YamlMap& params) {
    std::string sub_name;
    params.Required("sub", &sub_name);
    params.OptionalChoice("mode", &mode_, {"vio", "vio_uwb", "virpo"});
    VioConfig settings;
    if (params.Has("settings")) {
      settings = LoadVioConfig(bridge::ReadFilePath(params, "settings", context.scenario.file), {});
    }
    const VioConfig config = ReadVioConfig(params, settings);
    params.Finish();
    const RunSetup all = ReadRunSetup(context.scenario, mode_, config, {});
    for (std::size_t i = 0; i < all.subs.size(); ++i) {
      if (all.subs[i].body == all.vehicle_name + "/" + sub_name) self_ = i;
    }
    if (self_ == kNone) params.Fail("sub", "'" + sub_name + "' has no stereo camera in this scenario");
    setup_ = all;
    const SubAircraftSetup& sub = setup_.subs[self_];
    tracker_.emplace(sub.rig, config.tracker);
    const EstimatorOptions options = EstimatorOptionsFor(setup_, self_, mode_, config);
    estimator_.emplace(sub.rig, options);
    propagator_.emplace(options.gravity_mps2, options.imu_noise);
  }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    const SubAircraftSetup& sub = setup_.subs[self_];
    bus.Subscribe<sensor_msgs::Imu>(
        sub.imu_topic, [this](const sensor_msgs::Imu& m, const bridge::MessageInfo&) {
          const double t_s = Seconds(bridge::ToNanoseconds(m.header.stamp));
          sensors::ImuSample sample;
          sample.f_I_mps2 = bridge::FromMsg(m.linear_acceleration);
          sample.w_I_radps = bridge::FromMsg(m.angular_velocity);
          last_imu_t_s_ = t_s;
          inputs_.push_back([t_s, sample](Estimator& e) { e.AddImu(t_s, sample); });
          propagator_->AddImu(t_s, sample);
        });
    for (const std::string* eye : {&sub.left_topic, &sub.right_topic}) {
      const bool left = eye == &sub.left_topic;
      bus.Subscribe<sensor_msgs::CompressedImage>(
          *eye, [this, left](const sensor_msgs::CompressedImage& m, const bridge::MessageInfo&) {
            Pair& pair = pairs_[bridge::ToNanoseconds(m.header.stamp)];
            (left ? pair.left : pair.right) = m.data;
          });
    }
    bus.Subscribe<nav_msgs::Odometry>(sub.truth_topic,
                                      [this](const nav_msgs::Odometry& m, const bridge::MessageInfo&) {
                                        if (!started_) truth_[bridge::ToNanoseconds(m.header.stamp)] = m;
                                      });
    if (!sub.uwb_topic.empty()) {
      bus.Subscribe<iapsim_msgs::UwbRanges>(
          sub.uwb_topic, [this](const iapsim_msgs::UwbRanges& m, const bridge::MessageInfo&) {
            const SubAircraftSetup& s = setup_.subs[self_];
            const double t_s = Seconds(bridge::ToNanoseconds(m.header.stamp));
            for (std::size_t i = 0; i < m.peers.size() && i < m.ranges_m.size(); ++i) {
              const auto anchor = s.anchors_W.find(m.peers[i]);
              if (anchor == s.anchors_W.end()) continue;
              const Eigen::Vector3d p_WA = anchor->second;
              const double range = m.ranges_m[i], sigma = s.range_sigma_m;
              inputs_.push_back([=](Estimator& e) { e.AddRange(t_s, p_WA, range, sigma); });
            }
          });
    }
    if (!sub.attitude_topic.empty()) {
      bus.Subscribe<sensor_msgs::Imu>(
          sub.attitude_topic, [this](const sensor_msgs::Imu& m, const bridge::MessageInfo&) {
            const double t_s = Seconds(bridge::ToNanoseconds(m.header.stamp));
            const Eigen::Quaterniond q_WI = bridge::FromMsg(m.orientation).normalized() *
                                            Eigen::Quaterniond(setup_.subs[self_].X_BI.linear());
            last_attitude_t_s_ = t_s;
            inputs_.push_back([t_s, q_WI](Estimator& e) { e.AddAttitude(t_s, q_WI); });
          });
    }
    if (mode_ == "virpo") {
      // the others' odometry, kept until a frame after it is solved (peer index: order among the others)
      for (std::size_t o = 0, peer = 0; o < setup_.subs.size(); ++o) {
        if (o == self_) continue;
        bus.Subscribe<nav_msgs::Odometry>(
            setup_.subs[o].odometry_topic,
            [this, peer](const nav_msgs::Odometry& m, const bridge::MessageInfo&) {
              peer_odometry_[bridge::ToNanoseconds(m.header.stamp)].emplace_back(peer, m);
            });
        ++peer;
      }
    }
  }

  void Step(const bridge::StepInfo& step) override {
    // every complete pair up to this step whose IMU (and attitude) has arrived, in order
    while (!pairs_.empty() && pairs_.begin()->first <= step.stamp_ns) {
      const auto& [t_ns, pair] = *pairs_.begin();
      const double t_s = Seconds(t_ns);
      const bool inputs_in =
          last_imu_t_s_ >= t_s && (setup_.subs[self_].attitude_topic.empty() || last_attitude_t_s_ >= t_s);
      if (!pair.Complete() && pairs_.size() == 1) break;  // the other eye may still come
      if (pair.Complete() && !inputs_in && !step.final) break;
      if (pair.Complete()) Estimate(t_ns, pair);
      pairs_.erase(pairs_.begin());
    }
    const std::optional<vio::Estimate> latest = propagator_->Latest();
    if (latest && latest->t_s > last_propagated_t_s_) {
      last_propagated_t_s_ = latest->t_s;
      const int64_t t_ns = std::llround(latest->t_s * 1e9);  // an IMU or image stamp, exact in a double
      bus_->Publish(setup_.subs[self_].propagated_odometry_topic,
                    OdometryOf(*latest, setup_.subs[self_], t_ns));
      ++propagated_;
    }
  }

  void Finish(nlohmann::json* report) override {
    const EstimatorStatistics& s = estimator_->statistics();
    (*report)["frames"] = s.frames;
    (*report)["keyframes"] = s.keyframes;
    (*report)["failures"] = s.failures;
    (*report)["last_failure"] = s.last_failure;
    (*report)["ranges_used"] = s.ranges_used;
    (*report)["attitude_constraints"] = s.attitude_constraints;
    (*report)["kinematic_constraints"] = s.kinematic_constraints;
    (*report)["propagated"] = propagated_;
    const double per_frame = s.frames > 0 ? 1.0 / s.frames : 0.0;
    (*report)["ms_per_frame"] = {{"solve", s.solve_ms * per_frame},
                                 {"marginalisation", s.marginalisation_ms * per_frame}};
  }

 private:
  struct Pair {
    std::vector<uint8_t> left, right;
    bool Complete() const { return !left.empty() && !right.empty(); }
  };
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

  void Estimate(int64_t t_ns, const Pair& pair) {
    const SubAircraftSetup& sub = setup_.subs[self_];
    const StereoFrame frame = tracker_->Track(Seconds(t_ns), render::DecodeImage(pair.left, sub.left_topic),
                                              render::DecodeImage(pair.right, sub.right_topic));
    for (const auto& give : inputs_) give(*estimator_);
    inputs_.clear();
    // the others' odometry of the frames before this one (that of this frame is being solved beside it)
    while (!peer_odometry_.empty() && peer_odometry_.begin()->first < t_ns) {
      for (const auto& [peer, odometry] : peer_odometry_.begin()->second)
        estimator_->AddPeerJoint(peer, Seconds(peer_odometry_.begin()->first), PeerJointOf(odometry));
      peer_odometry_.erase(peer_odometry_.begin());
    }
    if (!started_) {
      const auto truth = truth_.find(t_ns);
      if (truth == truth_.end()) {
        throw std::runtime_error(sub.truth_topic + " has no ground truth at the first image's stamp " +
                                 std::to_string(Seconds(t_ns)) + " s");
      }
      estimator_->SetInitialState(ImuStateOf(truth->second, sub.X_BI));
      started_ = true;
      truth_.clear();
    }
    const vio::Estimate estimate = estimator_->AddFrame(frame);
    propagator_->SetFrame(estimate);
    bus_->Publish(sub.odometry_topic, OdometryOf(estimate, sub, t_ns));
  }

  std::string mode_ = "vio";
  RunSetup setup_;
  std::size_t self_ = kNone;
  std::optional<StereoTracker> tracker_;
  std::optional<Estimator> estimator_;
  std::optional<ImuPropagator> propagator_;
  bridge::Bus* bus_ = nullptr;
  std::map<int64_t, Pair> pairs_;
  std::vector<std::function<void(Estimator&)>> inputs_;
  std::map<int64_t, std::vector<std::pair<std::size_t, nav_msgs::Odometry>>> peer_odometry_;
  std::map<int64_t, nav_msgs::Odometry> truth_;
  bool started_ = false;
  double last_imu_t_s_ = -std::numeric_limits<double>::infinity();
  double last_attitude_t_s_ = -std::numeric_limits<double>::infinity();
  double last_propagated_t_s_ = -std::numeric_limits<double>::infinity();
  int propagated_ = 0;
};

class PlatformNode : public bridge::Process {
 public:
  PlatformNode(const bridge::ProcessContext& context, bridge::YamlMap& params) {
    bool platform = false;
    params.Required("platform", &platform);
    if (!platform)
      params.Fail("platform", "is true for the platform's instance; give `sub` for a sub-aircraft's");
    params.Finish();
    setup_ = ReadRunSetup(context.scenario, "vio", VioConfig{}, {});
    if (setup_.joints_P.empty()) {
      params.Fail("platform",
                  "needs a stereo camera on every sub-aircraft of vehicle '" + setup_.vehicle_name + "'");
    }
    frames_.topic = "/" + setup_.vehicle_name + "/vio/odom";
    propagated_.topic = "/" + setup_.vehicle_name + "/vio/imu_propagate";
    // in lockstep, a step's attitude is read only once its sender acknowledged the step: another process's
    // acknowledgement can arrive first, and the estimate would then depend on the timing
    const std::vector<std::string>& after = context.self.after;
    if (!setup_.platform_attitude_process.empty() && context.scenario.mode != bridge::ClockMode::kRealtime &&
        std::find(after.begin(), after.end(), setup_.platform_attitude_process) == after.end()) {
      throw bridge::ConfigError(context.scenario.file + ": processes." + context.self.name +
                                ".after: must name '" + setup_.platform_attitude_process +
                                "', whose platform_imu gives the platform's attitude at each step");
    }
  }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    for (std::size_t i = 0; i < setup_.subs.size(); ++i) {
      Subscribe(bus, setup_.subs[i].odometry_topic, i, &frames_);
      Subscribe(bus, setup_.subs[i].propagated_odometry_topic, i, &propagated_);
    }
    if (!setup_.platform_attitude_topic.empty()) {
      bus.Subscribe<sensor_msgs::Imu>(
          setup_.platform_attitude_topic, [this](const sensor_msgs::Imu& m, const bridge::MessageInfo&) {
            attitudes_[bridge::ToNanoseconds(m.header.stamp)] = PlatformAttitudeOf(m);
          });
    }
  }

  void Step(const bridge::StepInfo& step) override {
    for (Stream* stream : {&frames_, &propagated_}) {
      while (!stream->odometry.empty() && stream->odometry.begin()->first <= step.stamp_ns) {
        const int64_t t_ns = stream->odometry.begin()->first;
        std::vector<nav_msgs::Odometry> subs;
        for (const auto& odometry : stream->odometry.begin()->second) {
          if (odometry) subs.push_back(*odometry);
        }
        if (subs.size() == setup_.subs.size()) {
          bus_->Publish(stream->topic,
                        PlatformOdometryOf(setup_.joints_P, subs, setup_.vehicle_name, AttitudeAt(t_ns)));
          ++stream->published;
        } else {
          ++stream->incomplete;  // a sub-aircraft had no estimate at this stamp
        }
        stream->odometry.erase(stream->odometry.begin());
      }
    }
    // what the streams' next stamps can still need: the newest attitude at or before the oldest of them
    int64_t oldest_ns = step.stamp_ns;
    for (const Stream* stream : {&frames_, &propagated_}) {
      if (!stream->odometry.empty()) oldest_ns = std::min(oldest_ns, stream->odometry.begin()->first);
    }
    auto keep = attitudes_.upper_bound(oldest_ns);
    if (keep != attitudes_.begin()) attitudes_.erase(attitudes_.begin(), std::prev(keep));
  }

  void Finish(nlohmann::json* report) override {
    (*report)["published"] = frames_.published;
    (*report)["stamps_without_every_sub_aircraft"] = frames_.incomplete;
    (*report)["imu_propagate"] = {{"published", propagated_.published},
                                  {"stamps_without_every_sub_aircraft", propagated_.incomplete}};
    (*report)["attitude_topic"] = setup_.platform_attitude_topic.empty()
                                      ? nlohmann::json(nullptr)
                                      : nlohmann::json(setup_.platform_attitude_topic);
  }

 private:
  // the platform from one kind of the sub-aircraft's odometry: the frames' or the propagated
  struct Stream {
    std::string topic;                                                           // what it publishes
    std::map<int64_t, std::vector<std::optional<nav_msgs::Odometry>>> odometry;  // stamp -> per sub
    int published = 0;
    int incomplete = 0;
  };

  void Subscribe(bridge::Bus& bus, const std::string& topic, std::size_t sub, Stream* stream) {
    bus.Subscribe<nav_msgs::Odometry>(
        topic, [this, sub, stream](const nav_msgs::Odometry& m, const bridge::MessageInfo&) {
          auto& at = stream->odometry[bridge::ToNanoseconds(m.header.stamp)];
          at.resize(setup_.subs.size());
          at[sub] = m;
        });
  }

  const PlatformAttitude* AttitudeAt(int64_t t_ns) const {
    if (setup_.platform_attitude_topic.empty()) return nullptr;
    const PlatformAttitude* attitude = PlatformAttitudeAt(attitudes_, t_ns);
    if (!attitude) {
      throw std::runtime_error("no platform attitude on " + setup_.platform_attitude_topic +
                               " at or before t = " + std::to_string(Seconds(t_ns)) + " s");
    }
    return attitude;
  }

  RunSetup setup_;
  bridge::Bus* bus_ = nullptr;
  Stream frames_, propagated_;
  PlatformAttitudes attitudes_;  // with setup_.platform_attitude_topic
};

}  // namespace
}  // namespace iapsim::vio

int main(int argc, char** argv) {
  // as iapsim_vio_offline: keep image-sized buffers on the heap, not mmapped afresh at every frame
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  return iapsim::bridge::ProcessMain(
      argc, argv,
      "iapsim vio: a sub-aircraft's visual-inertial(-range-physical) odometry, or the platform's (seed IV-D)",
      [](const iapsim::bridge::ProcessContext& context,
         iapsim::bridge::YamlMap& params) -> std::unique_ptr<iapsim::bridge::Process> {
        if (params.Has("platform")) return std::make_unique<iapsim::vio::PlatformNode>(context, params);
        return std::make_unique<iapsim::vio::VioNode>(context, params);
      });
}
