#pragma once
// A scenario: the process graph, its clock and bus, what is recorded. Loaded from YAML, validated strictly.

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "bridge/config.h"
#include "bridge/message_limits.h"

namespace iapsim::bridge {

/// lockstep: the clock waits for every participant and observer each step (deterministic, lossless).
/// fast: unpaced; the clock waits for participants only (commands are never stale), observers keep up as they
///       can and count what they miss. realtime: paced by the wall clock, waits for nobody, counts late acks.
enum class ClockMode { kLockstep, kFast, kRealtime };

/// clock: owns time (physics). participant: closes the loop (control). observer: only watches (recorder,
/// render, sensors that nothing waits for in fast mode).
enum class ProcessRole { kClock, kParticipant, kObserver };

const char* ToString(ClockMode mode);
const char* ToString(ProcessRole role);

struct ClockConfig {
  double step_s = 0.001;         // physics publish step: t_k = k * step
  double ack_timeout_s = 2.0;    // lockstep/fast: a participant silent this long stops the run
  double realtime_factor = 1.0;  // realtime: sim seconds per wall second
};

struct BusConfig {
  std::string transport = "shm";  // shm (shared memory), ipc (ZeroMQ, unix sockets), tcp (ZeroMQ)
  // tcp: the IPv4 address this host's processes and the launcher's control channel bind; a graph that spans
  // hosts names one its other hosts reach (nothing binds a non-loopback address unless the scenario says so)
  std::string tcp_address = "127.0.0.1";
  // tcp: process i binds tcp_base_port + i; 0 (the default): ports the kernel says are free, so that runs at
  // the same time never collide
  int tcp_base_port = 0;
  int send_hwm = 10000;  // ipc, tcp: messages queued per connection
  int receive_hwm = 10000;
  int spin_us = 200;  // shm, lockstep/fast: how long a waiting process looks for a message before it sleeps
  int shm_queue_max_mib = 64;  // shm: the most a connection queues (and the largest message)
  // bus.max_message_kib: {default: KiB, TOPIC: KiB, NAMESPACE/: KiB}; by default every topic may carry
  // what a queue holds
  MessageSizeLimits message_limits;
  // written by the launcher into scenario.resolved.yaml, so a process restarts from that file alone
  std::map<std::string, std::string> endpoints;  // process -> its publisher endpoint
  // ipc, tcp: process -> its publisher endpoint for subscribers that are not of the run (`iapsim echo`)
  std::map<std::string, std::string> observer_endpoints;
  std::string control_endpoint;  // the launcher's control socket
};

/// The name of the process the launcher adds when recording.enabled is true.
inline constexpr char kRecorderProcess[] = "recorder";

struct RecordingConfig {
  bool enabled = true;
  std::vector<std::string> include;              // topic prefixes; empty: every topic
  std::vector<std::string> exclude{"/iapsim/"};  // protocol topics are not recorded by default
  std::string compression = "none";              // of the bag's chunks: none | lz4
  // named lists of topic prefixes: a group's name in include, exclude and max_rate_hz stands for its prefixes
  std::map<std::string, std::vector<std::string>> groups;
  // topic prefix -> the most messages a second of sim time the bag keeps of each topic it covers (the
  // longest prefix wins; none: every message): the first message of each 1/rate window of record time
  std::map<std::string, double> max_rate_hz;
  // lockstep: how many steps the clock may run ahead of the recorder (0: it waits for the recorder every
  // step); bounds what the recorder holds in memory and in its bus queues. 500 at 1 kHz: the stereo
  // scenario's seven 210 KiB images at 20 Hz are 10 frames, 15 MiB in the render process's queue (of 64)
  uint64_t max_lag_steps = 500;

  /// Whether the recorder writes `topic` (by the include and exclude prefixes).
  bool Records(const std::string& topic) const;
  /// The rate the bag keeps of `topic` (max_rate_hz), 0 for every message.
  double MaxRateHz(const std::string& topic) const;
};

/// local: the launcher starts the process. external: someone else does (on another host, under a debugger):
/// the launcher prints the command, waits for it to connect and supervises it by its heartbeats. srun: the
/// launcher, inside a Slurm allocation, starts it on `slurm_node` as a job step.
enum class ProcessHost { kLocal, kExternal, kSrun };

struct ProcessConfig {
  std::string name;
  std::string exec;  // executable in the build's bin/ folder, or an absolute path
  ProcessHost host = ProcessHost::kLocal;
  // tcp, external or srun: the IPv4 address the process binds on its own host (empty: external, this host's
  // bus.tcp_address; srun, the address Slurm has for slurm_node)
  std::string address;
  std::string slurm_node;  // srun: the node of the allocation it runs on
  ProcessRole role = ProcessRole::kParticipant;
  double rate_hz = 0.0;         // 0: every clock step
  double hang_timeout_s = 2.0;  // no heartbeat this long: the process is hung (slack for loaded CI machines)
  double startup_timeout_s = 30.0;
  // lockstep and fast: acts on step k only after these processes acknowledged k, so it reads their step-k
  // outputs (a controller fed by the sensors' filtered wrench); no cycles
  std::vector<std::string> after;
  // acts on step k only after these processes acknowledged their last due step before k, so it reads what
  // they published then; may be mutual (processes exchanging estimates a step behind: seed Fig. 4's
  // sub-aircraft sharing odometry)
  std::vector<std::string> after_previous;
  // the clock may run this many steps ahead of the process's acknowledgements, which it sends every
  // max_lag_steps / 4 steps (and at the last step); only the recorder lags (recording.max_lag_steps)
  uint64_t max_lag_steps = 0;
  YAML::Node params;  // validated by the process itself (`EXEC --check`)
  int line = 0;       // line of the process's entry in the scenario file, for messages
};

struct Scenario {
  std::string file;
  std::string name;
  std::string description;
  ClockMode mode = ClockMode::kLockstep;
  double duration_s = 10.0;
  // the run flies this long before the scenario's time 0 (trajectories held at their start, gusts and the
  // evaluation shifted): a real flight's take-off and hover, in which the integrators settle in the wind
  double lead_in_s = 0.0;
  uint64_t seed = 1;
  // ideal: the scenario as written; a profile's name or file: its settings fill what the scenario leaves out
  std::string fidelity = "ideal";
  ClockConfig clock;
  BusConfig bus;
  RecordingConfig recording;
  std::vector<ProcessConfig> processes;  // recorder included when recording is enabled
  std::string clock_owner;               // the process with role clock
  YAML::Node evaluation;                 // after-run analysis of the recording (tools/ reads it)
  YAML::Node resolved;                   // every value as used, defaults included

  int64_t step_ns() const;
  uint64_t last_step() const;  // K: steps run are k = 0..K, t_K = lead_in + duration
  int64_t lead_in_ns() const;  // the physics stamp of the scenario's time 0
  double run_s() const { return lead_in_s + duration_s; }  // physics time the run lasts
  const ProcessConfig* Find(const std::string& process) const;
  /// Seed for one process's random streams, derived from the scenario seed and the process name.
  uint64_t SeedFor(const std::string& process) const;
};

/// Loads and validates `path` with `overrides` ("key.path=value") applied. Throws ConfigError.
Scenario LoadScenario(const std::string& path, const std::vector<std::string>& overrides = {});

/// Gives every process a publisher endpoint and the launcher a control endpoint, unique to `run_id`, and
/// records them in `scenario->resolved`.
void AssignEndpoints(Scenario* scenario, const std::string& run_id);

/// Which process must act (and acknowledge) at which step, and whom the clock waits for.
class StepSchedule {
 public:
  explicit StepSchedule(const Scenario& scenario);

  struct Member {
    std::string name;
    ProcessRole role;
    uint64_t period_steps;  // due when k % period_steps == 0
    uint64_t lag_steps;     // ProcessConfig::max_lag_steps
  };
  /// Every process except the clock owner, in scenario order.
  const std::vector<Member>& members() const { return members_; }
  int IndexOf(const std::string& name) const;
  bool Due(int member, uint64_t step) const { return step % members_[member].period_steps == 0; }
  /// Whether the clock owner waits for this member's acknowledgement in `mode`.
  bool Awaited(int member, ClockMode mode) const;
  /// The step the member's acknowledgements must have reached before the clock owner goes on from step k
  /// (publishes k + 1, or at the `last` step ends the run): the member's latest due step up to k, or up to
  /// k - lag_steps for a member that may lag, except at the last step; -1 when there is none yet.
  int64_t AckNeeded(int member, uint64_t k, bool last) const;
  /// How many steps apart a member sends its acknowledgements: every due step, or every lag_steps / 4.
  uint64_t AckInterval(int member) const;

 private:
  std::vector<Member> members_;
};

}  // namespace iapsim::bridge
