#include "tools/contact_evaluation.h"

#include <geometry_msgs/WrenchStamped.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/Setpoint.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <stdexcept>

#include "bridge/bag.h"
#include "bridge/config.h"
#include "bridge/eigen_msgs.h"
#include "bridge/message.h"
#include "model/vehicle.h"
#include "tools/flight_evaluation.h"
#include "tools/plot_script.h"
#include "tools/run_evaluation.h"

namespace iapsim::tools {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::array<const char*, 6> kWrenchAxes = {"fx", "fy", "fz", "tx", "ty", "tz"};
constexpr std::array<const char*, 6> kPoseAxes = {"x", "y", "z", "roll", "pitch", "yaw"};

Vector6d WrenchOf(const geometry_msgs::Wrench& w) {
  return (Vector6d() << bridge::FromMsg(w.force), bridge::FromMsg(w.torque)).finished();
}

// One row of contact.csv: everything at the stamp of one control step (a setpoint).
struct Sample {
  double t_s = 0.0;
  Vector6d raw = Vector6d::Zero();             // true contact wrench, P about its origin
  Vector6d filtered = Vector6d::Zero();        // §VI-E low-pass
  Vector6d target = Vector6d::Constant(kNaN);  // the wrench command, once (21) engaged
  Vector6d pose_error = Vector6d::Zero();      // state − setpoint: m in W, then ZYX Euler angles (rad)
  double pitch_command_rad = 0.0;
  double pitch_rad = 0.0;
  double depth_m = kNaN;   // peg-in-hole: the tip's insertion depth
  double radial_m = kNaN;  // and its distance from the hole's axis
};

nlohmann::json AxesJson(const std::array<const char*, 6>& names, const Vector6d& values) {
  nlohmann::json out;
  for (int i = 0; i < 6; ++i)
    out[names[i]] = std::isfinite(values[i]) ? nlohmann::json(values[i]) : nlohmann::json();
  return out;
}

}  // namespace

std::optional<ContactEvaluation> ReadContactEvaluation(bridge::YamlMap& evaluation) {
  if (!evaluation.Has("contact")) return std::nullopt;
  ContactEvaluation out;
  bridge::YamlMap contact = evaluation.Map("contact");
  contact.Optional("vehicle", &out.vehicle);
  std::string task;
  contact.Required("task", &task);
  contact.OptionalChoice("task", &task, {"peg_in_hole", "wall_push"});
  out.task = task == "peg_in_hole" ? ContactEvaluation::Task::kPegInHole : ContactEvaluation::Task::kWallPush;
  contact.OptionalInRange("steady_window_s", &out.steady_window_s, 0.1, 1e4);
  contact.OptionalInRange("settle_band", &out.settle_band, 1e-3, 1.0);
  contact.OptionalInRange("contact_force_N", &out.contact_force_N, 0.0, 1e4);
  if (out.task == ContactEvaluation::Task::kPegInHole) {
    model::OptionalVector3(contact, "tip_P_m", &out.tip_P_m);
    for (const char* key : {"hole_entry_W_m", "hole_radius_m"}) {
      if (!contact.Has(key)) contact.Fail(key, "is required for task peg_in_hole");
    }
    model::OptionalVector3(contact, "hole_entry_W_m", &out.hole_entry_W_m);
    model::OptionalVector3(contact, "hole_axis_W", &out.hole_axis_W);
    if (out.hole_axis_W.norm() < 1e-9) contact.Fail("hole_axis_W", "must not be zero");
    out.hole_axis_W.normalize();
    contact.OptionalInRange("hole_radius_m", &out.hole_radius_m, 1e-6, 100.0);
  }
  contact.Optional("plots", &out.plots);
  contact.Finish();
  return out;
}

nlohmann::json EvaluateContact(const std::string& run_dir, const bridge::BagReader& bag,
                               const ContactEvaluation& evaluation) {
  const std::string& bag_path = bag.path();
  const std::string prefix = "/" + evaluation.vehicle;
  const std::string state_topic = prefix + "/state", setpoint_topic = prefix + "/setpoint",
                    filtered_topic = prefix + "/wrench/filtered", target_topic = prefix + "/wrench/target";
  const bool peg = evaluation.task == ContactEvaluation::Task::kPegInHole;

  // by physics stamp: the state's pose and raw wrench, the filtered wrench and the wrench command
  struct StateAt {
    Eigen::Vector3d p_WP_m;
    Eigen::Quaterniond q_WP;
    Vector6d raw;
  };
  std::map<int64_t, StateAt> states;
  std::map<int64_t, Vector6d> filtered, targets;
  std::vector<std::pair<int64_t, geometry_msgs::Pose>> setpoints;
  double max_raw_force_N = 0.0, max_raw_at_s = 0.0;
  std::optional<int64_t> first_contact_ns;
  std::string error;
  // decoded into the same messages each time: their vectors and strings keep their storage
  iapsim_msgs::IapState state_message;
  iapsim_msgs::Setpoint setpoint_message;
  geometry_msgs::WrenchStamped wrench_message;
  bag.ForEach({state_topic, setpoint_topic, filtered_topic, target_topic}, [&](const bridge::BagMessage& m) {
    if (m.topic == state_topic) {
      iapsim_msgs::IapState& state = state_message;
      if (!bridge::Decode(m.bytes, &state, &error) || state.bodies.empty()) return false;
      const int64_t stamp = bridge::ToNanoseconds(state.header.stamp);
      if (stamp < evaluation.start_ns) return true;  // the lead-in
      StateAt& at = states[stamp];
      at.p_WP_m = bridge::FromMsg(state.bodies[0].pose_W.position);
      at.q_WP = bridge::FromMsg(state.bodies[0].pose_W.orientation).normalized();
      at.raw = WrenchOf(state.external_wrench_P);
      if (!first_contact_ns && at.raw.head<3>().norm() > 0.0) first_contact_ns = stamp;
      // every physics step, so the single-step spikes of Bullet's contact impulses are all seen
      if (at.raw.head<3>().norm() > max_raw_force_N) {
        max_raw_force_N = at.raw.head<3>().norm();
        max_raw_at_s = static_cast<double>(stamp) * 1e-9;
      }
    } else if (m.topic == setpoint_topic) {
      iapsim_msgs::Setpoint& setpoint = setpoint_message;
      if (!bridge::Decode(m.bytes, &setpoint, &error)) return false;
      if (bridge::ToNanoseconds(setpoint.header.stamp) < evaluation.start_ns) return true;
      setpoints.emplace_back(bridge::ToNanoseconds(setpoint.header.stamp), setpoint.pose_W);
    } else {
      geometry_msgs::WrenchStamped& wrench = wrench_message;
      if (!bridge::Decode(m.bytes, &wrench, &error)) return false;
      if (bridge::ToNanoseconds(wrench.header.stamp) < evaluation.start_ns) return true;
      (m.topic == filtered_topic ? filtered : targets)[bridge::ToNanoseconds(wrench.header.stamp)] =
          WrenchOf(wrench.wrench);
    }
    return true;
  });
  if (!error.empty()) throw std::runtime_error(bag_path + ": undecodable message: " + error);
  if (states.empty() || setpoints.empty() || filtered.empty()) {
    throw std::runtime_error(bag_path + ": the contact evaluation needs " + state_topic + ", " +
                             setpoint_topic + " and " + filtered_topic + " recorded (found " +
                             std::to_string(states.size()) + ", " + std::to_string(setpoints.size()) + ", " +
                             std::to_string(filtered.size()) + ")");
  }
  if (!peg && targets.empty()) {
    throw std::runtime_error(bag_path + ": no " + target_topic +
                             ": the direct wrench controller never engaged (no contact?)");
  }

  const int64_t t0_ns = setpoints.front().first;
  std::vector<Sample> samples;
  for (const auto& [stamp_ns, setpoint] : setpoints) {
    const auto state = states.find(stamp_ns);
    const auto low_passed = filtered.find(stamp_ns);
    if (state == states.end() || low_passed == filtered.end()) continue;
    Sample s;
    s.t_s = static_cast<double>(stamp_ns - t0_ns) * 1e-9;
    s.raw = state->second.raw;
    s.filtered = low_passed->second;
    if (const auto target = targets.find(stamp_ns); target != targets.end()) s.target = target->second;
    const Eigen::Vector3d rpy = EulerZyx(state->second.q_WP);
    const Eigen::Vector3d rpy_ref = EulerZyx(bridge::FromMsg(setpoint.orientation));
    s.pose_error.head<3>() = state->second.p_WP_m - bridge::FromMsg(setpoint.position);
    for (int i = 0; i < 3; ++i) s.pose_error[3 + i] = std::remainder(rpy[i] - rpy_ref[i], 2.0 * M_PI);
    s.pitch_command_rad = rpy_ref.y();
    s.pitch_rad = rpy.y();
    if (peg) {
      const Eigen::Vector3d from_entry_W_m =
          state->second.p_WP_m + state->second.q_WP * evaluation.tip_P_m - evaluation.hole_entry_W_m;
      s.depth_m = from_entry_W_m.dot(evaluation.hole_axis_W);
      s.radial_m = (from_entry_W_m - s.depth_m * evaluation.hole_axis_W).norm();
    }
    samples.push_back(s);
  }
  if (samples.size() < 2)
    throw std::runtime_error(bag_path + ": no setpoint has a state and a filtered wrench of its stamp");

  const std::string csv_path = run_dir + "/contact.csv";
  {
    std::ofstream csv(csv_path);
    csv << "t_s";
    for (const char* kind : {"raw", "filtered", "target"}) {
      for (const char* axis : kWrenchAxes) csv << "," << kind << "_" << axis;
    }
    for (const char* axis : kPoseAxes) csv << ",error_" << axis;
    csv << ",pitch_command_deg,pitch_deg,depth_m,radial_m\n";
    char number[32];
    for (const Sample& s : samples) {
      csv << s.t_s;
      for (const Vector6d* v : {&s.raw, &s.filtered, &s.target}) {
        for (int i = 0; i < 6; ++i) {
          std::snprintf(number, sizeof number, ",%.5f", (*v)[i]);
          csv << number;
        }
      }
      for (int i = 0; i < 6; ++i) {
        std::snprintf(number, sizeof number, ",%.6f", i < 3 ? s.pose_error[i] : s.pose_error[i] * kRadToDeg);
        csv << number;
      }
      std::snprintf(number, sizeof number, ",%.4f,%.4f", s.pitch_command_rad * kRadToDeg,
                    s.pitch_rad * kRadToDeg);
      csv << number << "," << s.depth_m << "," << s.radial_m << "\n";
    }
  }

  nlohmann::json contact;
  contact["vehicle"] = evaluation.vehicle;
  contact["task"] = peg ? "peg_in_hole" : "wall_push";
  contact["csv"] = csv_path;
  const double end_s = samples.back().t_s;
  const double window_start_s = std::max(0.0, end_s - evaluation.steady_window_s);
  contact["steady_window_s"] = {window_start_s, end_s};
  double max_filtered_force_N = 0.0;
  Vector6d steady_filtered = Vector6d::Zero(), steady_pose_error = Vector6d::Zero();
  double steady_pitch_command = 0.0, steady_pitch_command_sq = 0.0, depth_max = -1e9;
  size_t in_window = 0, touching_in_window = 0;
  for (const Sample& s : samples) {
    const double force_N = s.filtered.head<3>().norm();
    max_filtered_force_N = std::max(max_filtered_force_N, force_N);
    if (peg) depth_max = std::max(depth_max, s.depth_m);
    if (s.t_s < window_start_s) continue;
    ++in_window;
    if (force_N > evaluation.contact_force_N) ++touching_in_window;
    steady_filtered += s.filtered;
    steady_pose_error += s.pose_error;
    steady_pitch_command += s.pitch_command_rad;
    steady_pitch_command_sq += s.pitch_command_rad * s.pitch_command_rad;
  }
  const double n = static_cast<double>(in_window);
  steady_filtered /= n;
  steady_pose_error /= n;
  contact["first_contact_s"] = first_contact_ns
                                   ? nlohmann::json(static_cast<double>(*first_contact_ns - t0_ns) * 1e-9)
                                   : nlohmann::json();
  contact["max_raw_force_N"] = max_raw_force_N;
  contact["max_raw_force_at_s"] = max_raw_at_s - static_cast<double>(t0_ns) * 1e-9;
  contact["max_filtered_force_N"] = max_filtered_force_N;
  contact["contact_fraction"] = touching_in_window / n;
  contact["steady_wrench_P"] = AxesJson(kWrenchAxes, steady_filtered);
  Vector6d pose_error_display = steady_pose_error;
  pose_error_display.tail<3>() *= kRadToDeg;
  contact["steady_pose_error"] = AxesJson(kPoseAxes, pose_error_display);  // m, then degrees

  if (peg) {
    const double mean = steady_pitch_command / n;
    contact["pitch_command_settled_deg"] = mean * kRadToDeg;
    contact["pitch_command_std_deg"] =
        std::sqrt(std::max(0.0, steady_pitch_command_sq / n - mean * mean)) * kRadToDeg;
    contact["insertion_depth_final_m"] = samples.back().depth_m;
    contact["insertion_depth_max_m"] = depth_max;
    contact["tip_radial_offset_final_m"] = samples.back().radial_m;
    contact["hole_radius_m"] = evaluation.hole_radius_m;
    const bool in_hole = samples.back().depth_m > 0.0 && samples.back().radial_m <= evaluation.hole_radius_m;
    contact["success"] = in_hole && touching_in_window == in_window;
  } else {
    const Vector6d command = targets.rbegin()->second;
    const double engaged_at_s = static_cast<double>(targets.begin()->first - t0_ns) * 1e-9;
    contact["engaged_at_s"] = engaged_at_s;
    // (21) publishes its target only while engaged: each start of a run of targets is an engagement, the
    // first at the first contact and one more after each contact lost and found again
    int engagements = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
      if (std::isfinite(samples[i].target[0]) && (i == 0 || !std::isfinite(samples[i - 1].target[0]))) {
        ++engagements;
      }
    }
    contact["engagements"] = engagements;
    contact["command_wrench_P"] = AxesJson(kWrenchAxes, command);
    const Vector6d wrench_error = steady_filtered - command;
    Vector6d relative = Vector6d::Constant(kNaN), settling = Vector6d::Constant(kNaN);
    for (int i = 0; i < 6; ++i) {
      if (std::abs(command[i]) < 1e-9) continue;  // no command to be relative to: see the absolute error
      relative[i] = std::abs(wrench_error[i]) / std::abs(command[i]);
      // settling: from the switch, the last time the error left the band (NaN: it never settled)
      const double band = evaluation.settle_band * std::abs(command[i]);
      double last_out_s = engaged_at_s;
      for (const Sample& s : samples) {
        if (s.t_s >= engaged_at_s && std::abs(s.filtered[i] - command[i]) > band) last_out_s = s.t_s;
      }
      if (last_out_s < end_s) settling[i] = last_out_s - engaged_at_s;
    }
    contact["wrench_error"] = AxesJson(kWrenchAxes, wrench_error);
    contact["wrench_error_relative"] = AxesJson(kWrenchAxes, relative);
    contact["settling_time_s"] = AxesJson(kWrenchAxes, settling);
  }

  if (evaluation.plots &&
      RunPlotScript(IAPSIM_PLOT_CONTACT,
                    {csv_path, run_dir, contact["task"].get<std::string>(), evaluation.vehicle})) {
    contact["plots"] = peg ? nlohmann::json{run_dir + "/contact_wrench.png", run_dir + "/peg_in_hole.png"}
                           : nlohmann::json{run_dir + "/contact_wrench.png", run_dir + "/wall_push.png"};
  }
  SetRunMetric(run_dir, "contact", contact);
  return contact;
}

void PrintContact(const nlohmann::json& contact) {
  const auto axes = [](const nlohmann::json& values, const std::array<const char*, 6>& names,
                       const char* format) {
    for (const char* name : names) {
      if (values[name].is_null()) {
        std::printf("  %s    -   ", name);
      } else {
        std::printf(format, name, values[name].get<double>());
      }
    }
    std::printf("\n");
  };
  std::printf(
      "  contact (%s of %s): first contact at %.2f s; largest raw force %.1f N (at %.3f s), filtered %.2f N;"
      " in contact %.0f %% of the last %.0f s\n",
      contact["task"].get<std::string>().c_str(), contact["vehicle"].get<std::string>().c_str(),
      contact["first_contact_s"].is_null() ? -1.0 : contact["first_contact_s"].get<double>(),
      contact["max_raw_force_N"].get<double>(), contact["max_raw_force_at_s"].get<double>(),
      contact["max_filtered_force_N"].get<double>(), 100.0 * contact["contact_fraction"].get<double>(),
      contact["steady_window_s"][1].get<double>() - contact["steady_window_s"][0].get<double>());
  std::printf("    steady wrench (P)     ");
  axes(contact["steady_wrench_P"], kWrenchAxes, "  %s %7.3f");
  if (contact["task"] == "peg_in_hole") {
    std::printf(
        "    pitch command settles at %.2f deg (std %.2f; the seed reports about 12 deg); insertion depth "
        "%.3f m (max %.3f m), %.3f m off the hole's axis (radius %.3f m); %s\n",
        contact["pitch_command_settled_deg"].get<double>(), contact["pitch_command_std_deg"].get<double>(),
        contact["insertion_depth_final_m"].get<double>(), contact["insertion_depth_max_m"].get<double>(),
        contact["tip_radial_offset_final_m"].get<double>(), contact["hole_radius_m"].get<double>(),
        contact["success"].get<bool>() ? "in the hole and in contact" : "NOT in the hole and in contact");
    return;
  }
  std::printf("    command (P)           ");
  axes(contact["command_wrench_P"], kWrenchAxes, "  %s %7.3f");
  std::printf("    relative error        ");
  axes(contact["wrench_error_relative"], kWrenchAxes, "  %s %7.3f");
  std::printf("    settling time (s)     ");
  axes(contact["settling_time_s"], kWrenchAxes, "  %s %7.2f");
  std::printf("    steady pose error     ");
  axes(contact["steady_pose_error"], kPoseAxes, "  %s %7.3f");
  const int engagements = contact["engagements"].get<int>();
  std::printf("    (21) engaged at %.2f s", contact["engaged_at_s"].get<double>());
  if (engagements > 1)
    std::printf("; engaged %d times in all (the contact lost and found again)", engagements);
  std::printf("\n");
}

}  // namespace iapsim::tools
