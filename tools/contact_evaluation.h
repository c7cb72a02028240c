#pragma once
// Evaluation of the contact experiments of seed §VI-E (admittance peg-in-hole, Fig. 15) and §VI-F (direct
// wrench push on a wall, Fig. 16) from a run's recording: the true contact wrench (/<v>/wrench/external,
// every physics step) and its §VI-E low-pass (/<v>/wrench/filtered), the controller's wrench command
// (/<v>/wrench/target) and pose setpoint (/<v>/setpoint), and the state. Writes contact.csv, PNG plots
// (tools/plot_contact.py) and a "contact" section into the run's metrics.json.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "bridge/bag.h"
#include "bridge/config.h"

namespace iapsim::tools {

struct ContactEvaluation {
  enum class Task { kPegInHole, kWallPush };
  std::string vehicle = "iap";
  Task task = Task::kWallPush;
  double steady_window_s = 10.0;  // steady-state figures: means over the run's last window
  double settle_band = 0.1;       // settling: the error stays within this fraction of the command
  double contact_force_N = 0.1;   // the filtered force above which the pole counts as touching
  // peg-in-hole: the pole's tip in P, and the hole's entry point and axis (into the hole) in W; the
  // insertion depth is (p_tip − entry)·axis, the tip's radial offset its distance from the axis, and the tip
  // is in the hole when it is deeper than 0 and within hole_radius_m of the axis (the depth alone would
  // count a pole that passed beside the funnel)
  Eigen::Vector3d tip_P_m = Eigen::Vector3d(-1.0, 0.0, 0.0);
  Eigen::Vector3d hole_entry_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d hole_axis_W = -Eigen::Vector3d::UnitX();
  double hole_radius_m = 0.0;
  bool plots = true;
  // the scenario's time 0 as a physics stamp (after its lead-in): what comes before is not evaluated
  int64_t start_ns = 0;
};

/// The `contact: {vehicle, task: peg_in_hole | wall_push, steady_window_s, settle_band, contact_force_N,
/// tip_P_m, hole_entry_W_m, hole_axis_W, hole_radius_m, plots}` section of a scenario's `evaluation`, or
/// nothing when it has none. Throws bridge::ConfigError naming the scenario file and key.
std::optional<ContactEvaluation> ReadContactEvaluation(bridge::YamlMap& evaluation);

/// Evaluates run_dir/run.bag. Both tasks: first contact, the largest raw and filtered contact force (the
/// spikes and what the filter leaves of them), the time in contact over the steady window. Peg-in-hole:
/// the pitch command's settled value and spread, insertion depth (final, max), the tip's final radial offset
/// from the hole's axis, success (in the hole at the end and in contact over the window). Wall push: when
/// (21) engaged, the steady wrench and its error per axis (relative to the command where it is not zero),
/// settling time per commanded axis, steady pose error. Throws std::runtime_error naming the file when the
/// recording lacks a topic.
nlohmann::json EvaluateContact(const std::string& run_dir, const bridge::BagReader& bag,
                               const ContactEvaluation& evaluation);

void PrintContact(const nlohmann::json& contact);

}  // namespace iapsim::tools
