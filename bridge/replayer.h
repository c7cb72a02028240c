#pragma once
// The replayer process: plays chosen topics of a recorded bag into a run, re-stamped onto sim time, so a
// recorded command log (for example a real flight's geometry_msgs/PoseStamped setpoints) drives the sim.
//
// Timing: a message's time t_m is its header.stamp when it starts with a std_msgs/Header, else its record
// time. It is due at sim time t = t_m - (earliest t_m of the selection) + time_offset_s and is published
// during the step before t, so every consumer has it when it acts at step t (deterministic in lockstep).
// With restamp (default) header.stamp becomes t.
//
// params: bag (file), topics (list; empty: all), map (list of "FROM:=TO" renames), time_offset_s (>= one
// clock step), restamp (bool).

#include <memory>

#include "bridge/process.h"

namespace iapsim::bridge {

std::unique_ptr<Process> MakeReplayer(const ProcessContext& context, YamlMap& params);

}  // namespace iapsim::bridge
