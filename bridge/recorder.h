#pragma once
// The recorder process: writes every bus topic (minus recording.exclude) to <run>/run.bag.
//
// Determinism: messages are not written in arrival order (which interleaves publishers by chance) but per
// step: a publisher's messages up to its acknowledgement (or tick) of step k are written when the recorder
// closes step k, publishers in name order, each in its own send order. In lockstep the recorder is a
// participant that closes k only after every other process acknowledged k, so it loses nothing and two runs
// write byte-identical bags. It is off the clock's critical path: the clock may run recording.max_lag_steps
// ahead of it (process.h), so writing overlaps the simulation, and what it holds stays bounded.
//
// Cost per message: its stream (publisher, topic) found by number (MessageInfo::stream) and a copy into the
// publisher's buffer, reused from step to step; closing a step copies the messages into the bag's chunk. The
// report in metrics.json says where the time went (receiving, building records, compressing, writing) and
// what was written.

#include <memory>

#include "bridge/process.h"

namespace iapsim::bridge {

std::unique_ptr<Process> MakeRecorder(const ProcessContext& context, YamlMap& params);

}  // namespace iapsim::bridge
