#pragma once
// The replayer process: plays a recorded command log into a run, re-stamped onto sim time, so a real
// flight's commands drive the sim. The log is
// - chosen topics of a bag (for example a real flight's geometry_msgs/PoseStamped setpoints), played as
//   recorded, or with `as_pose` each message's first pose (a nav_msgs/Odometry of another vehicle, a
//   TransformStamped, an iapsim state) as a geometry_msgs/PoseStamped;
// - or a pose file, TUM or CSV as `iapsim export` and trajectory tools write it (bridge/pose_file.h), each
//   line a geometry_msgs/PoseStamped on `topic`.
//
// Timing: a message's time t_m is its header.stamp when it starts with a std_msgs/Header and the stamp is
// set (not 0), or a file line's time, else its record time. It is due at sim time t = t_m - (earliest t_m of
// the log) + time_offset_s + the scenario's lead_in_s and is published during the step before t, so every
// consumer has it when it acts at step t (deterministic in lockstep). With restamp (default) header.stamp
// becomes t.
//
// params: bag (file), topics (list; empty: all), map (list of "FROM:=TO" renames), as_pose (bool),
// pose_field (with as_pose: a field path such as "bodies[0].pose_W"), or file (pose file), format (tum |
// csv), topic; frame_id (of converted poses; default "W"), time_offset_s (>= one clock step), restamp
// (bool).

#include <memory>

#include "bridge/process.h"

namespace iapsim::bridge {

std::unique_ptr<Process> MakeReplayer(const ProcessContext& context, YamlMap& params);

}  // namespace iapsim::bridge
