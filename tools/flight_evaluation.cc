#include "tools/flight_evaluation.h"

#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/Setpoint.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <stdexcept>

#include "bridge/bag.h"
#include "bridge/config.h"
#include "bridge/eigen_msgs.h"
#include "bridge/message.h"
#include "tools/plot_script.h"
#include "tools/run_evaluation.h"

namespace iapsim::tools {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr std::array<const char*, 3> kAxes = {"x", "y", "z"};
constexpr std::array<const char*, 3> kAngles = {"roll", "pitch", "yaw"};

struct Pose {
  Eigen::Vector3d p_m;
  Eigen::Vector3d rpy_rad;  // ZYX Euler angles
};

Pose PoseOf(const geometry_msgs::Pose& pose) {
  return {bridge::FromMsg(pose.position), EulerZyx(bridge::FromMsg(pose.orientation))};
}

double WrapPi(double a) { return std::remainder(a, 2.0 * M_PI); }

// Per-axis RMSE and max |e| accumulated over the samples.
struct ErrorStats {
  Eigen::Vector3d sum_squares = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_abs = Eigen::Vector3d::Zero();
  void Add(const Eigen::Vector3d& e) {
    sum_squares += e.cwiseAbs2();
    max_abs = max_abs.cwiseMax(e.cwiseAbs());
  }
  nlohmann::json Json(const std::array<const char*, 3>& names, double scale, size_t n, bool rms) const {
    nlohmann::json out;
    for (int i = 0; i < 3; ++i) {
      out[names[i]] = scale * (rms ? std::sqrt(sum_squares[i] / static_cast<double>(n)) : max_abs[i]);
    }
    return out;
  }
};

}  // namespace

Eigen::Vector3d EulerZyx(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  return Eigen::Vector3d(std::atan2(R(2, 1), R(2, 2)), -std::asin(std::clamp(R(2, 0), -1.0, 1.0)),
                         std::atan2(R(1, 0), R(0, 0)));
}

std::optional<TrackingEvaluation> ReadTrackingEvaluation(bridge::YamlMap& evaluation) {
  if (!evaluation.Has("tracking")) return std::nullopt;
  TrackingEvaluation out;
  bridge::YamlMap tracking = evaluation.Map("tracking");
  tracking.Optional("vehicle", &out.vehicle);
  tracking.Optional("controller", &out.controller);
  tracking.Optional("plots", &out.plots);
  tracking.Finish();
  return out;
}

nlohmann::json EvaluateTracking(const std::string& run_dir, const bridge::BagReader& bag,
                                const TrackingEvaluation& evaluation) {
  const std::string& bag_path = bag.path();
  const std::string state_topic = "/" + evaluation.vehicle + "/state";
  const std::string setpoint_topic = "/" + evaluation.vehicle + "/setpoint";

  // States by physics stamp; each setpoint is stamped with the state it answered.
  std::map<int64_t, Pose> states;
  uint64_t mixer_saturated_steps = 0;
  std::vector<std::pair<int64_t, Pose>> references;
  bool five_dof = false;
  std::string error;
  // decoded into the same messages each time: their vectors and strings keep their storage
  iapsim_msgs::IapState state_message;
  iapsim_msgs::Setpoint setpoint_message;
  bag.ForEach({state_topic, setpoint_topic}, [&](const bridge::BagMessage& m) {
    if (m.topic == state_topic) {
      iapsim_msgs::IapState& state = state_message;
      if (!bridge::Decode(m.bytes, &state, &error) || state.bodies.empty()) return false;
      if (bridge::ToNanoseconds(state.header.stamp) < evaluation.start_ns) return true;  // the lead-in
      states[bridge::ToNanoseconds(state.header.stamp)] = PoseOf(state.bodies[0].pose_W);
      for (const auto& sub : state.sub_aircraft) {
        if (sub.saturated) {
          ++mixer_saturated_steps;
          break;
        }
      }
    } else {
      iapsim_msgs::Setpoint& setpoint = setpoint_message;
      if (!bridge::Decode(m.bytes, &setpoint, &error)) return false;
      if (bridge::ToNanoseconds(setpoint.header.stamp) < evaluation.start_ns) return true;
      five_dof = five_dof || setpoint.dof == iapsim_msgs::Setpoint::DOF_5;
      references.emplace_back(bridge::ToNanoseconds(setpoint.header.stamp), PoseOf(setpoint.pose_W));
    }
    return true;
  });
  if (!error.empty()) throw std::runtime_error(bag_path + ": undecodable message: " + error);
  if (states.empty() || references.empty()) {
    throw std::runtime_error(bag_path + ": tracking needs " + state_topic + " and " + setpoint_topic +
                             " recorded (found " + std::to_string(states.size()) + " states, " +
                             std::to_string(references.size()) + " setpoints)");
  }

  const std::string csv_path = run_dir + "/tracking.csv";
  std::ofstream csv(csv_path);
  csv << "t_s,x_ref_m,y_ref_m,z_ref_m,x_m,y_m,z_m,roll_ref_deg,pitch_ref_deg,yaw_ref_deg,roll_deg,pitch_deg,"
         "yaw_deg\n";
  ErrorStats position, attitude;
  size_t n = 0, unmatched = 0;
  const int64_t t0_ns = references.front().first;
  for (const auto& [stamp_ns, reference] : references) {
    const auto state = states.find(stamp_ns);
    if (state == states.end()) {  // a state not recorded (recording filters, a lost message): reported
      ++unmatched;
      continue;
    }
    const Pose& actual = state->second;
    position.Add(actual.p_m - reference.p_m);
    Eigen::Vector3d e_rpy;
    for (int i = 0; i < 3; ++i) e_rpy[i] = WrapPi(actual.rpy_rad[i] - reference.rpy_rad[i]);
    attitude.Add(e_rpy);
    ++n;
    char line[512];
    std::snprintf(line, sizeof line, "%.3f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f\n",
                  static_cast<double>(stamp_ns - t0_ns) * 1e-9, reference.p_m.x(), reference.p_m.y(),
                  reference.p_m.z(), actual.p_m.x(), actual.p_m.y(), actual.p_m.z(),
                  reference.rpy_rad.x() * kRadToDeg, reference.rpy_rad.y() * kRadToDeg,
                  reference.rpy_rad.z() * kRadToDeg, actual.rpy_rad.x() * kRadToDeg,
                  actual.rpy_rad.y() * kRadToDeg, actual.rpy_rad.z() * kRadToDeg);
    csv << line;
  }
  csv.close();
  if (n == 0) throw std::runtime_error(bag_path + ": no setpoint has a state of the same stamp");

  nlohmann::json tracking;
  tracking["vehicle"] = evaluation.vehicle;
  tracking["samples"] = n;
  tracking["unmatched_setpoints"] = unmatched;
  tracking["duration_s"] = static_cast<double>(references.back().first - t0_ns) * 1e-9;
  tracking["five_dof"] = five_dof;
  tracking["position_rmse_m"] = position.Json(kAxes, 1.0, n, true);
  tracking["position_max_m"] = position.Json(kAxes, 1.0, n, false);
  tracking["attitude_rmse_deg"] = attitude.Json(kAngles, kRadToDeg, n, true);
  tracking["attitude_max_deg"] = attitude.Json(kAngles, kRadToDeg, n, false);
  tracking["mixer_saturated_steps"] = mixer_saturated_steps;
  tracking["csv"] = csv_path;

  // the controller's own count of allocations cut to the thrust limits, from the run's metrics
  const std::string metrics_path = run_dir + "/metrics.json";
  nlohmann::json metrics = ReadRunMetrics(run_dir);
  const auto& controller = metrics["processes"][evaluation.controller]["process"];
  if (!controller.contains("saturated_updates")) {
    throw std::runtime_error(metrics_path + ": process '" + evaluation.controller +
                             "' reports no saturated_updates (is it an iapsim_control in mode track?)");
  }
  tracking["saturated_updates"] = controller["saturated_updates"];
  // an under-actuated IAP's roll about its joint line is free whatever the reference says
  tracking["fully_actuated"] = controller.value("fully_actuated", true);

  if (evaluation.plots && RunPlotScript(IAPSIM_PLOT_TRACKING, {csv_path, run_dir, evaluation.vehicle})) {
    tracking["plots"] = {run_dir + "/tracking_pose.png", run_dir + "/tracking_error.png"};
  }
  SetRunMetric(run_dir, "tracking", tracking);
  return tracking;
}

void PrintTracking(const nlohmann::json& tracking) {
  const auto row = [&](const char* label, const char* key, const std::array<const char*, 3>& names,
                       const char* unit) {
    std::printf("    %-16s", label);
    for (const char* name : names) std::printf(" %s %8.4f", name, tracking[key][name].get<double>());
    std::printf("  %s\n", unit);
  };
  std::printf("  tracking of %s over %.1f s (%zu samples%s):\n",
              tracking["vehicle"].get<std::string>().c_str(), tracking["duration_s"].get<double>(),
              tracking["samples"].get<size_t>(),
              tracking["five_dof"].get<bool>() || !tracking["fully_actuated"].get<bool>()
                  ? ", under-actuated: roll is the free swing"
                  : "");
  row("position RMSE", "position_rmse_m", kAxes, "m");
  row("position max", "position_max_m", kAxes, "m");
  row("attitude RMSE", "attitude_rmse_deg", kAngles, "deg");
  row("attitude max", "attitude_max_deg", kAngles, "deg");
  if (tracking.value("unmatched_setpoints", uint64_t{0}) > 0) {
    std::printf("    %llu setpoints without a state of their stamp (not compared)\n",
                static_cast<unsigned long long>(tracking["unmatched_setpoints"].get<uint64_t>()));
  }
  std::printf("    saturation: %llu allocations cut, %llu steps with a mixer cut\n",
              static_cast<unsigned long long>(tracking["saturated_updates"].get<uint64_t>()),
              static_cast<unsigned long long>(tracking["mixer_saturated_steps"].get<uint64_t>()));
  std::printf("    %s\n", tracking["csv"].get<std::string>().c_str());
  if (tracking.contains("plots")) {
    for (const auto& plot : tracking["plots"]) std::printf("    %s\n", plot.get<std::string>().c_str());
  }
}

}  // namespace iapsim::tools
