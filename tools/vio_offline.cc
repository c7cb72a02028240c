#include "tools/vio_offline.h"

#include <iapsim_msgs/UwbRanges.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Imu.h>

#include <chrono>
#include <cstdio>
#include <deque>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>

#include "bridge/bag.h"
#include "bridge/config.h"
#include "bridge/eigen_msgs.h"
#include "bridge/message.h"
#include "bridge/message_format.h"
#include "bridge/scenario.h"
#include "model/vehicle.h"
#include "render/camera_rig.h"
#include "render/image.h"
#include "sensors/sensor_config.h"
#include "vio/estimator.h"
#include "vio/stereo_tracker.h"
#include "vio/trajectory_error.h"

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

struct SubAircraftInput {
  std::string body;  // "iap/sub1"
  render::CameraConfig camera;
  vio::StereoRig rig;
  Eigen::Isometry3d X_BI = Eigen::Isometry3d::Identity();
  sensors::ImuNoise imu_noise;
  std::string left_topic, right_topic, left_info_topic, imu_topic, truth_topic;
  // vio_uwb: the tag's ranges to the scenario's anchors (the tag is at the body's origin, sensors/uwb.h)
  std::string uwb_topic;
  std::map<std::string, Eigen::Vector3d> anchors_W;
  double range_sigma_m = 0.0;
};

struct TruthSample {
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v_WB_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_WB_B = Eigen::Vector3d::Zero();
};

struct SubAircraftResult {
  std::vector<bridge::StampedPose> estimate, truth;  // of the body B, at the image stamps
  vio::EstimatorStatistics statistics;
  double decode_ms = 0.0, front_end_ms = 0.0, wall_s = 0.0, sequence_s = 0.0;
  int frames = 0;
};

struct DatasetInput {
  std::string bag_path;
  std::string scenario_path;
  std::vector<SubAircraftInput> subs;
  // the platform centre, from the sub-aircraft estimates and the vehicle's joints (seed §VI-G), when every
  // sub-aircraft of the vehicle is estimated
  std::string platform_truth_topic;
  std::vector<Eigen::Vector3d> joints_P;  ///< d_i, in the order of `subs`
};

// The params of the first process that has `key` (the renderer's cameras, the sensors' imu).
std::optional<YAML::Node> FindParams(const bridge::Scenario& scenario, const std::string& key,
                                     std::string* process) {
  for (const bridge::ProcessConfig& p : scenario.processes) {
    if (p.params.IsMap() && p.params[key]) {
      *process = p.name;
      return p.params;
    }
  }
  return std::nullopt;
}

DatasetInput ReadDataset(const VioOfflineArgs& args) {
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

  std::string render_process, sensors_process;
  const std::optional<YAML::Node> render_params = FindParams(scenario, "cameras", &render_process);
  const std::optional<YAML::Node> sensors_params = FindParams(scenario, "imu", &sensors_process);
  if (!render_params) throw DatasetError(in.scenario_path + ": no process renders cameras (params.cameras)");
  if (!sensors_params) throw DatasetError(in.scenario_path + ": no process samples an IMU (params.imu)");
  bridge::YamlMap render_map(*render_params, scenario.file, "processes." + render_process + ".params");
  const std::vector<render::CameraConfig> cameras = render::ReadCameras(render_map, "cameras");
  bridge::YamlMap sensors_map(*sensors_params, scenario.file, "processes." + sensors_process + ".params");
  const sensors::SensorsConfig sensors_config = sensors::ReadSensorsConfig(sensors_map);
  bridge::YamlMap vehicle_map = sensors_map.Map("vehicle");
  std::string vehicle_name;
  vehicle_map.Required("name", &vehicle_name);
  const model::Vehicle vehicle = model::LoadVehicle(bridge::ReadFilePath(vehicle_map, "file", scenario.file));
  Eigen::Isometry3d X_BI = Eigen::Isometry3d::Identity();
  X_BI.linear() = sensors_config.imu.q_BI.toRotationMatrix();
  X_BI.translation() = sensors_config.imu.p_BI_m;

  const std::set<std::string> wanted(args.sub_aircraft.begin(), args.sub_aircraft.end());
  std::set<std::string> not_found = wanted;
  for (const render::CameraConfig& camera : cameras) {
    if (camera.mount.kind != render::CameraMount::Kind::kBody || !(camera.baseline_m > 0.0)) continue;
    if (!wanted.empty() && wanted.count(camera.mount.body) == 0) continue;
    not_found.erase(camera.mount.body);
    SubAircraftInput sub;
    sub.body = camera.mount.body;
    sub.camera = camera;
    sub.rig = vio::StereoRig::FromCamera(camera, X_BI);
    sub.X_BI = X_BI;
    sub.imu_noise = sensors_config.imu.noise;
    sub.left_topic = camera.TopicNamespace(0) + "/image_raw/compressed";
    sub.right_topic = camera.TopicNamespace(1) + "/image_raw/compressed";
    sub.left_info_topic = camera.TopicNamespace(0) + "/camera_info";
    sub.imu_topic = "/" + camera.mount.body + "/imu";
    sub.truth_topic = "/" + camera.mount.body + "/odom";
    if (args.mode == "vio_uwb") {
      if (sensors_config.uwb.anchors.empty()) {
        throw DatasetError(in.scenario_path + ": --mode vio_uwb needs UWB anchors (processes." +
                           sensors_process + ".params.uwb.anchors or anchors_file)");
      }
      sub.uwb_topic = "/" + camera.mount.body + "/uwb";
      for (const sensors::UwbAnchor& anchor : sensors_config.uwb.anchors)
        sub.anchors_W[anchor.name] = anchor.p_WA_m;
      sub.range_sigma_m = sensors_config.uwb.noise.sigma_m;
    }
    in.subs.push_back(sub);
  }
  if (!not_found.empty()) {
    throw DatasetError(in.scenario_path + ": no stereo camera on '" + *not_found.begin() + "' (--sub)");
  }
  if (in.subs.empty()) {
    throw DatasetError(in.scenario_path + ": no body-mounted stereo camera (baseline_m > 0)");
  }
  // The centre needs every joint: a sub-aircraft's origin is its joint (seed §III-A), so the estimated
  // origins are the joints in W.
  for (const SubAircraftInput& sub : in.subs) {
    for (const model::SubAircraft& s : vehicle.sub_aircraft) {
      if (sub.body == vehicle_name + "/" + s.name) in.joints_P.push_back(s.joint_P_m);
    }
  }
  if (in.joints_P.size() == vehicle.sub_aircraft.size() && in.joints_P.size() >= 2) {
    in.platform_truth_topic = "/" + vehicle_name + "/odom";
  } else {
    in.joints_P.clear();
  }
  return in;
}

// Every topic the estimation reads must be in the bag, and the recorded camera model must be the scenario's.
void CheckBag(const bridge::BagReader& bag, const SubAircraftInput& sub) {
  std::map<std::string, bridge::BagTopicInfo> topics;
  for (const bridge::BagTopicInfo& t : bag.Topics()) topics[t.topic] = t;
  for (const std::string* topic :
       {&sub.left_topic, &sub.right_topic, &sub.left_info_topic, &sub.imu_topic, &sub.truth_topic}) {
    if (topics.count(*topic) != 0 && topics[*topic].count > 0) continue;
    std::string images;
    for (const auto& [name, info] : topics) {
      if (info.datatype == "sensor_msgs/CompressedImage") images += " " + name;
    }
    throw DatasetError(
        bag.path() + ": no messages on " + *topic + " (" + sub.body + "'s stereo camera '" + sub.camera.name +
        "', its IMU and ground truth are needed); the bag's images:" + (images.empty() ? " none" : images));
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

std::vector<vio::StampedPosition> Positions(const std::vector<bridge::StampedPose>& poses) {
  std::vector<vio::StampedPosition> positions;
  for (const bridge::StampedPose& p : poses)
    positions.push_back({p.time_ns, {p.position[0], p.position[1], p.position[2]}});
  return positions;
}

std::vector<vio::StampedIsometry> Isometries(const std::vector<bridge::StampedPose>& poses) {
  std::vector<vio::StampedIsometry> out;
  for (const bridge::StampedPose& p : poses) {
    vio::StampedIsometry s;
    s.t_ns = p.time_ns;
    s.X.linear() = Eigen::Quaterniond(p.orientation_xyzw[3], p.orientation_xyzw[0], p.orientation_xyzw[1],
                                      p.orientation_xyzw[2])
                       .normalized()
                       .toRotationMatrix();
    s.X.translation() = Eigen::Vector3d(p.position[0], p.position[1], p.position[2]);
    out.push_back(s);
  }
  return out;
}

// The errors every trajectory gets in vio.json: ATE as it is and aligned, and RPE over one second.
constexpr int64_t kRpeDelta_ns = 1'000'000'000;

nlohmann::json ErrorsJson(const std::vector<bridge::StampedPose>& estimate,
                          const std::vector<bridge::StampedPose>& truth, vio::AbsoluteTrajectoryError* ate,
                          vio::AbsoluteTrajectoryError* ate_aligned) {
  *ate = vio::ComputeAte(Positions(estimate), Positions(truth), false);
  *ate_aligned = vio::ComputeAte(Positions(estimate), Positions(truth), true);
  const vio::RelativePoseError rpe = vio::ComputeRpe(Isometries(estimate), Isometries(truth), kRpeDelta_ns);
  const auto ate_json = [](const vio::AbsoluteTrajectoryError& e) {
    return nlohmann::json{
        {"rmse_m", e.rmse_m}, {"mean_m", e.mean_m}, {"max_m", e.max_m}, {"matched", e.matched}};
  };
  return {{"ate", ate_json(*ate)},
          {"ate_aligned", ate_json(*ate_aligned)},
          {"rpe_1s",
           {{"translation_rmse_m", rpe.translation_rmse_m},
            {"rotation_rmse_deg", rpe.rotation_rmse_deg},
            {"pairs", rpe.pairs}}}};
}

SubAircraftResult Estimate(const std::string& bag_path, const SubAircraftInput& sub) {
  const Clock::time_point start = Clock::now();
  const bridge::BagReader bag(bag_path);
  CheckBag(bag, sub);
  SubAircraftResult out;
  std::string error;

  std::map<int64_t, TruthSample> truth;
  nav_msgs::Odometry odometry;
  bag.ForEach({sub.truth_topic}, [&](const bridge::BagMessage& m) {
    if (!bridge::Decode(m.bytes, &odometry, &error))
      throw DatasetError(bag_path + ": " + m.topic + ": " + error);
    TruthSample& s = truth[bridge::ToNanoseconds(odometry.header.stamp)];
    s.X_WB = PoseOf(odometry.pose.pose);
    s.v_WB_W = s.X_WB.linear() * bridge::FromMsg(odometry.twist.twist.linear);  // the twist is in B (ROS)
    s.w_WB_B = bridge::FromMsg(odometry.twist.twist.angular);
    return true;
  });

  vio::StereoTracker tracker(sub.rig);
  vio::EstimatorOptions options;
  options.imu_noise = sub.imu_noise;
  options.p_IT_m = sub.X_BI.inverse().translation();  // the tag at the body's origin, in I
  vio::Estimator estimator(sub.rig, options);
  struct PendingPair {
    std::vector<uint8_t> left, right;
  };
  std::map<int64_t, PendingPair> pairs;               // by stamp, until both eyes are in
  std::deque<std::pair<int64_t, PendingPair>> ready;  // complete, waiting for the IMU to reach them
  double last_imu_t_s = -1.0;
  int64_t first_ns = -1, last_ns = 0;

  auto process = [&](int64_t t_ns, const PendingPair& pair) {
    const double t_s = static_cast<double>(t_ns) * 1e-9;
    Clock::time_point stage = Clock::now();
    const render::Image left = render::DecodeImage(pair.left, sub.left_topic);
    const render::Image right = render::DecodeImage(pair.right, sub.right_topic);
    out.decode_ms += Milliseconds(stage);
    stage = Clock::now();
    const vio::StereoFrame frame = tracker.Track(t_s, left, right);
    out.front_end_ms += Milliseconds(stage);
    if (out.frames == 0) {
      const auto it = truth.find(t_ns);
      if (it == truth.end()) {
        throw DatasetError(bag_path + ": " + sub.truth_topic +
                           " has no ground truth at the first image's stamp " + std::to_string(t_s) + " s");
      }
      const TruthSample& s = it->second;
      vio::NavState initial;
      const Eigen::Isometry3d X_WI = s.X_WB * sub.X_BI;
      initial.p_WI_m = X_WI.translation();
      initial.q_WI = Eigen::Quaterniond(X_WI.linear());
      initial.v_WI_W_mps = s.v_WB_W + s.X_WB.linear() * s.w_WB_B.cross(sub.X_BI.translation());
      estimator.SetInitialState(initial);
    }
    const vio::Estimate e = estimator.AddFrame(frame);
    Eigen::Isometry3d X_WI = Eigen::Isometry3d::Identity();
    X_WI.linear() = e.state.q_WI.normalized().toRotationMatrix();
    X_WI.translation() = e.state.p_WI_m;
    out.estimate.push_back(Stamped(t_ns, X_WI * sub.X_BI.inverse()));
    const auto it = truth.find(t_ns);
    if (it != truth.end()) out.truth.push_back(Stamped(t_ns, it->second.X_WB));
    ++out.frames;
  };
  auto drain = [&](bool all) {
    while (!ready.empty() && (all || static_cast<double>(ready.front().first) * 1e-9 <= last_imu_t_s)) {
      process(ready.front().first, ready.front().second);
      ready.pop_front();
    }
  };

  sensor_msgs::Imu imu;
  sensor_msgs::CompressedImage image;
  iapsim_msgs::UwbRanges ranges;
  std::vector<std::string> topics{sub.imu_topic, sub.left_topic, sub.right_topic};
  if (!sub.uwb_topic.empty()) topics.push_back(sub.uwb_topic);
  bag.ForEach(topics, [&](const bridge::BagMessage& m) {
    if (m.topic == sub.uwb_topic) {
      if (!bridge::Decode(m.bytes, &ranges, &error) || ranges.peers.size() != ranges.ranges_m.size()) {
        throw DatasetError(bag_path + ": " + m.topic + ": " +
                           (error.empty() ? "peers and ranges_m differ in length" : error));
      }
      const double t_s = static_cast<double>(bridge::ToNanoseconds(ranges.header.stamp)) * 1e-9;
      for (std::size_t i = 0; i < ranges.peers.size(); ++i) {
        const auto anchor = sub.anchors_W.find(ranges.peers[i]);
        if (anchor != sub.anchors_W.end())
          estimator.AddRange(t_s, anchor->second, ranges.ranges_m[i], sub.range_sigma_m);
      }
      return true;
    }
    if (m.topic == sub.imu_topic) {
      if (!bridge::Decode(m.bytes, &imu, &error))
        throw DatasetError(bag_path + ": " + m.topic + ": " + error);
      sensors::ImuSample sample;
      sample.f_I_mps2 = bridge::FromMsg(imu.linear_acceleration);
      sample.w_I_radps = bridge::FromMsg(imu.angular_velocity);
      last_imu_t_s = static_cast<double>(bridge::ToNanoseconds(imu.header.stamp)) * 1e-9;
      estimator.AddImu(last_imu_t_s, sample);
      drain(false);
      return true;
    }
    if (!bridge::Decode(m.bytes, &image, &error))
      throw DatasetError(bag_path + ": " + m.topic + ": " + error);
    const int64_t t_ns = bridge::ToNanoseconds(image.header.stamp);
    PendingPair& pair = pairs[t_ns];
    (m.topic == sub.left_topic ? pair.left : pair.right) = image.data;
    if (!pair.left.empty() && !pair.right.empty()) {
      ready.emplace_back(t_ns, std::move(pair));
      pairs.erase(t_ns);
      if (first_ns < 0) first_ns = t_ns;
      last_ns = t_ns;
    }
    drain(false);
    return true;
  });
  drain(true);

  out.statistics = estimator.statistics();
  out.sequence_s = first_ns < 0 ? 0.0 : static_cast<double>(last_ns - first_ns) * 1e-9;
  out.wall_s = Milliseconds(start) * 1e-3;
  return out;
}

struct CentreResult {
  std::vector<bridge::StampedPose> estimate, truth;
};

// The platform pose at each stamp every sub-aircraft has an estimate for: the rigid transform that best
// carries the joints d_i (in P) onto the estimated joints (in W), X_WP = UmeyamaRigid(d, J); its truth from
// the platform's ground-truth odometry.
CentreResult EstimateCentre(const DatasetInput& in, const std::vector<SubAircraftResult>& results) {
  CentreResult out;
  std::map<int64_t, std::vector<Eigen::Vector3d>> joints_W;
  for (const SubAircraftResult& r : results) {
    for (const bridge::StampedPose& p : r.estimate) {
      joints_W[p.time_ns].emplace_back(p.position[0], p.position[1], p.position[2]);
    }
  }
  for (const auto& [t_ns, joints] : joints_W) {
    if (joints.size() == in.joints_P.size())
      out.estimate.push_back(Stamped(t_ns, vio::UmeyamaRigid(in.joints_P, joints)));
  }
  std::set<int64_t> stamps;
  for (const bridge::StampedPose& p : out.estimate) stamps.insert(p.time_ns);
  const bridge::BagReader bag(in.bag_path);
  nav_msgs::Odometry odometry;
  std::string error;
  bag.ForEach({in.platform_truth_topic}, [&](const bridge::BagMessage& m) {
    if (!bridge::Decode(m.bytes, &odometry, &error))
      throw DatasetError(in.bag_path + ": " + m.topic + ": " + error);
    const int64_t t_ns = bridge::ToNanoseconds(odometry.header.stamp);
    if (stamps.count(t_ns) != 0) out.truth.push_back(Stamped(t_ns, PoseOf(odometry.pose.pose)));
    return true;
  });
  return out;
}

void WriteTum(const std::string& path, const std::vector<bridge::StampedPose>& poses) {
  std::ofstream file(path);
  file << "# t x y z qx qy qz qw (W NED, body FRD; iapsim vio)\n";
  for (const bridge::StampedPose& p : poses) file << bridge::FormatTum(p) << "\n";
  if (!file) throw std::runtime_error(path + ": cannot write");
}

// Writes <out_dir>/<body with _>_estimate.tum and _truth.tum and returns the body's entry of vio.json: the
// file names and its errors (ATE as it is and aligned, RPE over 1 s), whose ATEs it also hands back.
nlohmann::json WriteTrajectory(const std::string& out_dir, const std::string& body,
                               const std::vector<bridge::StampedPose>& estimate,
                               const std::vector<bridge::StampedPose>& truth,
                               vio::AbsoluteTrajectoryError* ate, vio::AbsoluteTrajectoryError* ate_aligned) {
  std::string stem = body;
  for (char& c : stem) c = c == '/' ? '_' : c;
  WriteTum((fs::path(out_dir) / (stem + "_estimate.tum")).string(), estimate);
  WriteTum((fs::path(out_dir) / (stem + "_truth.tum")).string(), truth);
  nlohmann::json entry = ErrorsJson(estimate, truth, ate, ate_aligned);
  entry["estimate_tum"] = stem + "_estimate.tum";
  entry["truth_tum"] = stem + "_truth.tum";
  return entry;
}

int Run(const VioOfflineArgs& args) {
  const DatasetInput in = ReadDataset(args);
  const std::string out_dir = args.out_dir.empty()
                                  ? (fs::path(in.bag_path).parent_path() / ("vio_" + args.mode)).string()
                                  : args.out_dir;
  fs::create_directories(out_dir);

  const Clock::time_point start = Clock::now();
  std::vector<SubAircraftResult> results(in.subs.size());
  std::vector<std::exception_ptr> failures(in.subs.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < in.subs.size(); ++i) {
    threads.emplace_back([&, i] {
      try {
        results[i] = Estimate(in.bag_path, in.subs[i]);
      } catch (...) {
        failures[i] = std::current_exception();
      }
    });
  }
  for (std::thread& t : threads) t.join();
  for (const std::exception_ptr& failure : failures) {
    if (failure) std::rethrow_exception(failure);
  }
  const double wall_s = Milliseconds(start) * 1e-3;

  nlohmann::json report = {{"mode", args.mode}, {"bag", in.bag_path}, {"scenario", in.scenario_path}};
  std::printf("iapsim vio --mode %s on %s\n", args.mode.c_str(), in.bag_path.c_str());
  std::printf("  %-12s %7s %9s %8s %12s %12s %18s\n", "body", "frames", "keyframes", "failures", "ATE RMSE m",
              "aligned m", "ms/frame fe|solve");
  double sequence_s = 0.0;
  for (std::size_t i = 0; i < in.subs.size(); ++i) {
    const SubAircraftInput& sub = in.subs[i];
    const SubAircraftResult& r = results[i];
    const double per_frame = r.frames > 0 ? 1.0 / r.frames : 0.0;
    vio::AbsoluteTrajectoryError ate, ate_aligned;
    nlohmann::json& entry = report["sub_aircraft"][sub.body];
    entry = WriteTrajectory(out_dir, sub.body, r.estimate, r.truth, &ate, &ate_aligned);
    entry["frames"] = r.frames;
    entry["keyframes"] = r.statistics.keyframes;
    entry["failures"] = r.statistics.failures;
    entry["ranges_used"] = r.statistics.ranges_used;
    entry["last_failure"] = r.statistics.last_failure;
    entry["ms_per_frame"] = {{"decode", r.decode_ms * per_frame},
                             {"front_end", r.front_end_ms * per_frame},
                             {"solve", r.statistics.solve_ms * per_frame},
                             {"marginalisation", r.statistics.marginalisation_ms * per_frame}};
    entry["sequence_s"] = r.sequence_s;
    entry["wall_s"] = r.wall_s;
    std::printf("  %-12s %7d %9d %8d %12.4f %12.4f %8.1f|%-8.1f\n", sub.body.c_str(), r.frames,
                r.statistics.keyframes, r.statistics.failures, ate.rmse_m, ate_aligned.rmse_m,
                r.front_end_ms * per_frame, r.statistics.solve_ms * per_frame);
    sequence_s = std::max(sequence_s, r.sequence_s);
  }
  if (!in.joints_P.empty()) {
    const std::string centre =
        in.platform_truth_topic.substr(1, in.platform_truth_topic.rfind('/') - 1) + "/platform";
    const CentreResult c = EstimateCentre(in, results);
    vio::AbsoluteTrajectoryError ate, ate_aligned;
    report["centre"] = WriteTrajectory(out_dir, centre, c.estimate, c.truth, &ate, &ate_aligned);
    report["centre"]["body"] = centre;
    std::printf("  %-12s %7zu %9s %8s %12.4f %12.4f   (from the sub-aircraft and the joints)\n",
                centre.c_str(), c.estimate.size(), "", "", ate.rmse_m, ate_aligned.rmse_m);
  }
  report["wall_s"] = wall_s;
  report["real_time_factor"] = wall_s > 0.0 ? sequence_s / wall_s : 0.0;
  const std::string report_path = (fs::path(out_dir) / "vio.json").string();
  std::ofstream(report_path) << report.dump(2) << "\n";
  std::printf("  %.1f s of data in %.1f s (%.2fx real time); %s\n", sequence_s, wall_s,
              wall_s > 0.0 ? sequence_s / wall_s : 0.0, report_path.c_str());
  return 0;
}

}  // namespace

int VioOffline(const VioOfflineArgs& args) {
  try {
    return Run(args);
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
