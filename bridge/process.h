#pragma once
// The runtime every iapsim process shares: command line, configuration check, start-up handshake, the
// clock (lockstep / fast / realtime), heartbeats, clean shutdown. A process supplies only its logic.
//
// Lockstep protocol, per clock step k:
//   clock owner: Step(k) publishes state k, then the runtime publishes /clock and, last, tick k
//   participant: on tick k, if due: Step(k) publishes its outputs, then the runtime publishes ack k
//   clock owner: steps to k+1 once every awaited participant acked k (cmd k arrived before ack k: same
//   socket)
// A process that StepsAfterPeers (the recorder) acts on k only when every other due process acked k, so it
// has seen every message of step k. A process that may lag (the recorder, recording.max_lag_steps = L)
// acknowledges only every L/4 steps and the last step, and the clock owner waits for its ack of k - L (not
// k) before it publishes k + 1, and for its ack of the last step before the run ends.

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "bridge/bus.h"
#include "bridge/config.h"
#include "bridge/scenario.h"

namespace iapsim::bridge {

struct StepInfo {
  uint64_t step = 0;     // k
  int64_t stamp_ns = 0;  // t_k
  bool final = false;    // last step of the run
};

/// What a process gets to know about its run.
struct ProcessContext {
  const Scenario& scenario;
  const ProcessConfig& self;
  std::string run_dir;  // empty during --check
  uint64_t seed;        // for this process's random streams
};

class Process {
 public:
  virtual ~Process() = default;
  /// Advertise and subscribe (before the start-up handshake, so no message is missed).
  virtual void Setup(Bus& bus) = 0;
  /// Called at every step where the process is due. The clock owner publishes state k here.
  virtual void Step(const StepInfo& step) = 0;
  /// Act on step k only once every other due process acknowledged it (recorders).
  virtual bool StepsAfterPeers() const { return false; }
  /// A participant with inputs from outside the bus (the ROS bridge): called between bus reads, at least
  /// every poll_period, whether the process is due or not.
  virtual void Poll() {}
  virtual std::chrono::microseconds poll_period() const { return std::chrono::milliseconds(5); }
  /// The run is over (normally or not): flush outputs, add figures to the run's metrics.
  virtual void Finish(nlohmann::json* report) { (void)report; }
};

/// CPU time this process has used so far, all its threads (getrusage), in seconds.
struct CpuTime {
  double user_s = 0.0;
  double system_s = 0.0;
};
CpuTime ProcessCpuTime();

/// Bus options for a program that watches a run without being one of its processes (`iapsim echo`,
/// `iapsim topics`): it binds an ipc endpoint of its own and reads every process best effort, at its
/// observer endpoint (ZeroMQ) or at its endpoint (shared memory, which tells observers apart by name), with
/// the run's secret and size limits. It never holds the run, however slowly it reads.
BusOptions ObserverBusOptions(const Scenario& scenario, const std::string& node_name,
                              const std::string& secret);

/// Builds the process from its params (reading every key it knows; unknown keys are rejected after).
/// Must not touch the bus: it also runs for `--check`.
using ProcessFactory =
    std::function<std::unique_ptr<Process>(const ProcessContext& context, YamlMap& params)>;

/// The whole main() of a process executable:
///   EXEC --scenario FILE --node NAME [--run-dir DIR] [--set KEY=VALUE]... [--check]
/// --check validates the scenario and this process's params, prints the resolved params as YAML and exits
/// (0, or 2 with the error on stderr). Otherwise it runs under the launcher. Exit codes: 0 ok, 1 failure,
/// 2 bad configuration.
int ProcessMain(int argc, char** argv, const std::string& description, const ProcessFactory& factory);

/// ProcessMain for a process class constructed as T(const ProcessContext&, YamlMap& params).
template <class T>
int ProcessMainFor(int argc, char** argv, const std::string& description) {
  return ProcessMain(argc, argv, description, [](const ProcessContext& context, YamlMap& params) {
    return std::unique_ptr<Process>(std::make_unique<T>(context, params));
  });
}

}  // namespace iapsim::bridge
