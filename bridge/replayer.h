#pragma once
// The replayer process: plays chosen topics of a recorded bag into a run, re-stamped onto sim time, so a
// recorded command log (for example a real flight's geometry_msgs/PoseStamped setpoints) drives the sim.
//
// Timing: a bag message recorded at t_b is due at sim time t = t_b - t_first + time_offset_s and is published
// during the step before t, so every consumer has it when it acts at step t (deterministic in lockstep).
// Messages that start with a std_msgs/Header get header.stamp = t.
//
// params: bag (file), topics (list; empty: all), map (list of "FROM:=TO" renames), time_offset_s (>= one
// clock step), restamp (bool).

#include <memory>

#include "bridge/process.h"

namespace iapsim::bridge {

std::unique_ptr<Process> MakeReplayer(const ProcessContext& context, YamlMap& params);

}  // namespace iapsim::bridge
