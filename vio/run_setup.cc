#include "vio/run_setup.h"

#include <algorithm>
#include <iterator>
#include <set>

#include "bridge/eigen_msgs.h"
#include "bridge/trajectory_error.h"
#include "model/vehicle.h"
#include "sensors/attitude_estimator.h"
#include "sensors/sensor_config.h"
#include "vio/so3.h"

namespace iapsim::vio {
namespace {

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

}  // namespace

RunSetup ReadRunSetup(const bridge::Scenario& scenario, const std::string& mode, const VioConfig& config,
                      const std::vector<std::string>& bodies) {
  const auto fail = [&](const std::string& what) { throw bridge::ConfigError(scenario.file + ": " + what); };
  std::string render_process, sensors_process;
  const std::optional<YAML::Node> render_params = FindParams(scenario, "cameras", &render_process);
  const std::optional<YAML::Node> sensors_params = FindParams(scenario, "imu", &sensors_process);
  if (!render_params) fail("no process renders cameras (params.cameras)");
  if (!sensors_params) fail("no process samples an IMU (params.imu)");
  bridge::YamlMap render_map(*render_params, scenario.file, "processes." + render_process + ".params");
  const std::vector<render::CameraConfig> cameras = render::ReadCameras(render_map, "cameras");
  bridge::YamlMap sensors_map(*sensors_params, scenario.file, "processes." + sensors_process + ".params");
  const sensors::SensorsConfig sensors_config = sensors::ReadSensorsConfig(sensors_map);
  bridge::YamlMap vehicle_map = sensors_map.Map("vehicle");
  RunSetup setup;
  vehicle_map.Required("name", &setup.vehicle_name);
  const model::Vehicle vehicle = model::LoadVehicle(bridge::ReadFilePath(vehicle_map, "file", scenario.file));
  Eigen::Isometry3d X_BI = Eigen::Isometry3d::Identity();
  X_BI.linear() = sensors_config.imu.q_BI.toRotationMatrix();
  X_BI.translation() = sensors_config.imu.p_BI_m;

  // The anchors ranged to: the scenario's, or those of uwb.anchors (Table VII's sweep over 0-4 anchors)
  std::map<std::string, Eigen::Vector3d> anchors_W;
  for (const sensors::UwbAnchor& anchor : sensors_config.uwb.anchors) {
    setup.anchor_names.push_back(anchor.name);
    if (!config.anchors) anchors_W[anchor.name] = anchor.p_WA_m;
  }
  for (const std::string& name : config.anchors.value_or(std::vector<std::string>{})) {
    const auto anchor = std::find_if(sensors_config.uwb.anchors.begin(), sensors_config.uwb.anchors.end(),
                                     [&](const sensors::UwbAnchor& a) { return a.name == name; });
    if (anchor == sensors_config.uwb.anchors.end()) {
      std::string known;
      for (const std::string& n : setup.anchor_names) known += (known.empty() ? "" : ", ") + n;
      throw bridge::ConfigError("uwb.anchors: no anchor '" + name + "' in " + scenario.file + " (processes." +
                                sensors_process + ".params.uwb has: " + (known.empty() ? "none" : known) +
                                ")");
    }
    anchors_W[name] = anchor->p_WA_m;
  }
  const std::set<std::string> wanted(bodies.begin(), bodies.end());
  std::set<std::string> not_found = wanted;
  for (const render::CameraConfig& camera : cameras) {
    if (camera.mount.kind != render::CameraMount::Kind::kBody || !(camera.baseline_m > 0.0)) continue;
    if (!wanted.empty() && wanted.count(camera.mount.body) == 0) continue;
    not_found.erase(camera.mount.body);
    SubAircraftSetup sub;
    sub.body = camera.mount.body;
    sub.camera = camera;
    sub.rig = StereoRig::FromCamera(camera, X_BI);
    sub.X_BI = X_BI;
    sub.imu_noise = sensors_config.imu.noise;
    sub.left_topic = camera.TopicNamespace(0) + "/image_raw/compressed";
    sub.right_topic = camera.TopicNamespace(1) + "/image_raw/compressed";
    sub.left_info_topic = camera.TopicNamespace(0) + "/camera_info";
    sub.imu_topic = "/" + camera.mount.body + "/imu";
    sub.truth_topic = "/" + camera.mount.body + "/odom";
    sub.odometry_topic = "/" + camera.mount.body + "/vio/odom";
    sub.propagated_odometry_topic = "/" + camera.mount.body + "/vio/imu_propagate";
    if (mode != "vio") {
      if (sensors_config.uwb.anchors.empty()) {
        fail("mode " + mode + " needs UWB anchors (processes." + sensors_process +
             ".params.uwb.anchors or anchors_file)");
      }
      sub.uwb_topic = "/" + camera.mount.body + "/uwb";
      sub.anchors_W = anchors_W;
      sub.range_sigma_m = config.range_sigma_m.value_or(sensors_config.uwb.noise.sigma_m);
    }
    if (mode == "virpo") sub.attitude_topic = "/" + camera.mount.body + "/attitude";
    for (const model::SubAircraft& s : vehicle.sub_aircraft) {
      if (sub.body == setup.vehicle_name + "/" + s.name) sub.joint_P = s.joint_P_m;
    }
    setup.subs.push_back(sub);
  }
  if (!not_found.empty()) fail("no stereo camera on '" + *not_found.begin() + "'");
  if (setup.subs.empty()) fail("no body-mounted stereo camera (baseline_m > 0)");
  // VIRPO ties each sub-aircraft to the others through the platform; the centre needs every joint. A
  // sub-aircraft's origin is its joint (seed §III-A), so the estimated origins are the joints in W.
  std::size_t on_vehicle = 0;
  for (const SubAircraftSetup& sub : setup.subs) on_vehicle += sub.joint_P.has_value();
  if (mode == "virpo" && (on_vehicle != setup.subs.size() || on_vehicle < 2)) {
    fail("mode virpo needs two or more sub-aircraft of vehicle '" + setup.vehicle_name +
         "' with stereo cameras (" + std::to_string(on_vehicle) + " given)");
  }
  if (on_vehicle == vehicle.sub_aircraft.size() && on_vehicle == setup.subs.size() && on_vehicle >= 2) {
    for (const SubAircraftSetup& sub : setup.subs) setup.joints_P.push_back(*sub.joint_P);
    setup.platform_truth_topic = "/" + setup.vehicle_name + "/odom";
    if (sensors_config.platform_imu) {
      setup.platform_attitude_topic = "/" + setup.vehicle_name + "/attitude";
      setup.platform_attitude_process = sensors_process;
    }
  }
  return setup;
}

EstimatorOptions EstimatorOptionsFor(const RunSetup& setup, std::size_t i, const std::string& mode,
                                     const VioConfig& config) {
  const SubAircraftSetup& sub = setup.subs[i];
  EstimatorOptions options = config.estimator;
  options.imu_noise = sub.imu_noise;
  options.p_IT_m = sub.X_BI.inverse().translation();  // the tag at the body's origin, in I
  options.physical.p_IJ_m = sub.X_BI.inverse().translation();
  if (mode == "virpo") {
    for (std::size_t o = 0; o < setup.subs.size(); ++o) {
      if (o != i) options.physical.link_lengths_m.push_back((*sub.joint_P - *setup.subs[o].joint_P).norm());
    }
  }
  return options;
}

nav_msgs::Odometry OdometryOf(const Estimate& estimate, const SubAircraftSetup& sub, int64_t t_ns) {
  Eigen::Isometry3d X_WI = Eigen::Isometry3d::Identity();
  X_WI.linear() = estimate.state.q_WI.normalized().toRotationMatrix();
  X_WI.translation() = estimate.state.p_WI_m;
  const Eigen::Isometry3d X_WB = X_WI * sub.X_BI.inverse();
  const PeerJoint origin = JointOf(estimate, sub.X_BI.inverse().translation());  // the body's origin
  nav_msgs::Odometry odometry;
  odometry.header.stamp = bridge::ToRosTime(t_ns);
  odometry.header.frame_id = "W";
  odometry.child_frame_id = sub.body;
  odometry.pose.pose.position = bridge::ToPointMsg(X_WB.translation());
  odometry.pose.pose.orientation = bridge::ToQuaternionMsg(Eigen::Quaterniond(X_WB.linear()));
  odometry.twist.twist.linear = bridge::ToVector3Msg(X_WB.linear().transpose() * origin.v_WJ_W_mps);
  odometry.twist.twist.angular = bridge::ToVector3Msg(sub.X_BI.linear() * estimate.w_I_radps);
  return odometry;
}

nav_msgs::Odometry PlatformOdometryOf(const std::vector<Eigen::Vector3d>& joints_P,
                                      const std::vector<nav_msgs::Odometry>& subs, const std::string& vehicle,
                                      const PlatformAttitude* attitude) {
  std::vector<PeerJoint> joints;
  std::vector<Eigen::Vector3d> joints_W;
  for (const nav_msgs::Odometry& sub : subs) {
    joints.push_back(PeerJointOf(sub));
    joints_W.push_back(joints.back().p_WJ_m);
  }
  Eigen::Isometry3d X_WP = bridge::UmeyamaRigid(joints_P, joints_W);
  Eigen::Vector3d v_W, w_W;
  if (attitude) {
    const Eigen::Vector3d tilt_rpy_rad = sensors::RollPitchYaw_rad(attitude->q_WP);
    const double yaw_rad = sensors::RollPitchYaw_rad(Eigen::Quaterniond(X_WP.linear())).z();
    X_WP.linear() = sensors::FromRollPitchYaw(tilt_rpy_rad.x(), tilt_rpy_rad.y(), yaw_rad).toRotationMatrix();
    w_W = X_WP.linear() * attitude->w_P_radps;
    X_WP.translation().setZero();
    v_W.setZero();
    for (std::size_t i = 0; i < subs.size(); ++i) {
      const Eigen::Vector3d r_W = X_WP.linear() * joints_P[i];
      X_WP.translation() += (joints[i].p_WJ_m - r_W) / static_cast<double>(subs.size());
      v_W += (joints[i].v_WJ_W_mps - w_W.cross(r_W)) / static_cast<double>(subs.size());
    }
  } else {
    // [I  −[r_i]×] [v_P; ω] = v_i for every joint, r_i = R_WP d_i
    Eigen::MatrixXd A(3 * subs.size(), 6);
    Eigen::VectorXd b(3 * subs.size());
    for (std::size_t i = 0; i < subs.size(); ++i) {
      A.block<3, 3>(3 * i, 0).setIdentity();
      A.block<3, 3>(3 * i, 3) = -Skew(X_WP.linear() * joints_P[i]);
      b.segment<3>(3 * i) = joints[i].v_WJ_W_mps;
    }
    const Eigen::Matrix<double, 6, 1> twist_W = A.colPivHouseholderQr().solve(b);
    v_W = twist_W.head<3>();
    w_W = twist_W.tail<3>();
  }
  nav_msgs::Odometry odometry;
  odometry.header = subs.front().header;
  odometry.child_frame_id = vehicle + "/platform";
  odometry.pose.pose.position = bridge::ToPointMsg(X_WP.translation());
  odometry.pose.pose.orientation = bridge::ToQuaternionMsg(Eigen::Quaterniond(X_WP.linear()));
  odometry.twist.twist.linear = bridge::ToVector3Msg(X_WP.linear().transpose() * v_W);
  odometry.twist.twist.angular = bridge::ToVector3Msg(X_WP.linear().transpose() * w_W);
  return odometry;
}

PlatformAttitude PlatformAttitudeOf(const sensor_msgs::Imu& attitude) {
  return {bridge::FromMsg(attitude.orientation).normalized(), bridge::FromMsg(attitude.angular_velocity)};
}

const PlatformAttitude* PlatformAttitudeAt(const PlatformAttitudes& attitudes, int64_t t_ns) {
  const auto after = attitudes.upper_bound(t_ns);
  return after == attitudes.begin() ? nullptr : &std::prev(after)->second;
}

NavState ImuStateOf(const nav_msgs::Odometry& odometry, const Eigen::Isometry3d& X_BI) {
  const Eigen::Quaterniond q_WB = bridge::FromMsg(odometry.pose.pose.orientation).normalized();
  const Eigen::Vector3d w_B = bridge::FromMsg(odometry.twist.twist.angular);  // the twist is in B (ROS)
  NavState state;
  state.q_WI = q_WB * Eigen::Quaterniond(X_BI.linear());
  state.p_WI_m = bridge::FromMsg(odometry.pose.pose.position) + q_WB * X_BI.translation();
  state.v_WI_W_mps = q_WB * (bridge::FromMsg(odometry.twist.twist.linear) + w_B.cross(X_BI.translation()));
  return state;
}

PeerJoint PeerJointOf(const nav_msgs::Odometry& odometry) {
  const Eigen::Quaterniond q_WB = bridge::FromMsg(odometry.pose.pose.orientation).normalized();
  return {bridge::FromMsg(odometry.pose.pose.position), q_WB * bridge::FromMsg(odometry.twist.twist.linear)};
}

}  // namespace iapsim::vio
