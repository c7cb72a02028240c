#include "bridge/process.h"

#include <iapsim_msgs/StepAck.h>
#include <iapsim_msgs/Tick.h>
#include <rosgraph_msgs/Clock.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <csignal>
#include <iostream>
#include <thread>

#include "bridge/cli_usage.h"
#include "bridge/control_channel.h"
#include "bridge/eigen_msgs.h"
#include "bridge/run_secret.h"

namespace iapsim::bridge {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr char kTickTopic[] = "/iapsim/tick";
constexpr char kAckTopic[] = "/iapsim/ack";
constexpr auto kHeartbeatPeriod = milliseconds(100);
constexpr auto kControlPollPeriod = milliseconds(5);
// at the end, what is still queued on the bus is read, unless reading it takes longer than this
constexpr auto kDrainLimit = std::chrono::seconds(1);
// 2 ms measured a little faster than 1 ms on the spiral (paired runs: recorded/unrecorded 1.28 against
// 1.32, 1.26 against 1.28); 0.5 ms and 3 ms slower
constexpr auto kLaggingPollPeriod = std::chrono::microseconds(2000);

// signals are process-wide by nature; the handler only records which one arrived
std::atomic<int> received_signal{0};

extern "C" void OnStopSignal(int signal) {
  received_signal = signal;
  alarm(3);  // backstop: a process that cannot wind down within 3 s is ended by SIGALRM's default action
}

nlohmann::json BusReport(const BusStats& stats) {
  nlohmann::json topics = nlohmann::json::object();
  for (const auto& [topic, c] : stats.topics) {
    topics[topic] = {{"sent", c.sent}, {"dropped", c.dropped},     {"received", c.received},
                     {"lost", c.lost}, {"oversized", c.oversized}, {"subscribed", c.subscribed}};
  }
  return {{"topics", topics},
          {"malformed", stats.malformed},
          {"refused_peers", stats.refused_peers},
          {"dropped_subscribers", stats.dropped_subscribers},
          {"sleeps", stats.sleeps},
          {"sleeps_timed_out", stats.sleeps_timed_out},
          {"contended_spins", stats.contended_spins}};
}

class Runtime {
 public:
  Runtime(const Scenario& scenario, const ProcessConfig& self, Process& process, ControlClient& control,
          const std::string& secret)
      : scenario_(scenario),
        self_(self),
        process_(process),
        schedule_(scenario),
        self_index_(schedule_.IndexOf(self.name)),
        control_(control),
        bus_(MakeBusOptions(scenario, self, secret)),
        last_ack_(schedule_.members().size(), -1) {
    // the peers whose step-k acks gate this process's step k: every one (recorders) or those it names; and
    // those whose acks of their last due step before k do (after_previous)
    const auto names = [](const std::vector<std::string>& list, const std::string& name) {
      return std::find(list.begin(), list.end(), name) != list.end();
    };
    for (size_t m = 0; m < schedule_.members().size(); ++m) {
      const std::string& name = schedule_.members()[m].name;
      if (static_cast<int>(m) == self_index_) continue;
      if (process_.StepsAfterPeers() || names(self.after, name)) gating_peers_.push_back(static_cast<int>(m));
      if (names(self.after_previous, name)) gating_previous_peers_.push_back(static_cast<int>(m));
    }
  }

  // Returns the exit code. Exceptions from the process or the protocol propagate to ProcessMain.
  int Run() {
    process_.Setup(bus_);
    bus_.Subscribe<iapsim_msgs::StepAck>(
        kAckTopic, [this](const iapsim_msgs::StepAck& ack, const MessageInfo&) { OnAck(ack); });
    if (self_.role != ProcessRole::kClock) {
      bus_.Subscribe<iapsim_msgs::Tick>(
          kTickTopic, [this](const iapsim_msgs::Tick& tick, const MessageInfo&) { OnTick(tick); });
    }
    spdlog::info("{} ({}, {}) on {}", self_.name, ToString(self_.role),
                 self_.rate_hz > 0 ? std::to_string(self_.rate_hz) + " Hz" : std::string("every step"),
                 scenario_.bus.endpoints.at(self_.name));
    if (!Handshake()) return Finish();
    spdlog::info("started in {} mode", ToString(scenario_.mode));
    if (self_.role == ProcessRole::kClock) {
      RunClock();
    } else {
      RunParticipant();
    }
    return Finish();
  }

 private:
  static BusOptions MakeBusOptions(const Scenario& scenario, const ProcessConfig& self,
                                   const std::string& secret) {
    BusOptions options;
    options.node_name = self.name;
    options.secret = secret;
    // lockstep waits for the run's own processes only: another subscriber (`iapsim echo`) never holds it
    for (const auto& p : scenario.processes) options.members.push_back(p.name);
    options.bind_endpoint = scenario.bus.endpoints.at(self.name);
    if (const auto it = scenario.bus.observer_endpoints.find(self.name);
        it != scenario.bus.observer_endpoints.end()) {
      options.observer_endpoint = it->second;
    }
    for (const auto& [name, endpoint] : scenario.bus.endpoints) {
      if (name != self.name) options.peer_endpoints.push_back(endpoint);
    }
    options.send_hwm = scenario.bus.send_hwm;
    options.receive_hwm = scenario.bus.receive_hwm;
    // realtime: the wall clock paces the run, so waiting processes sleep at once and leave the CPU to work
    options.spin =
        std::chrono::microseconds(scenario.mode == ClockMode::kRealtime ? 0 : scenario.bus.spin_us);
    options.shm_max_queue_bytes = static_cast<size_t>(scenario.bus.shm_queue_max_mib) << 20;
    options.message_limits = scenario.bus.message_limits;
    // a process that may lag (the recorder) reads its queues every 2 ms, in batches, and is never
    // woken: it neither spins on a core that physics and control need nor costs its publishers a wake-up
    if (self.max_lag_steps > 0 && scenario.mode != ClockMode::kRealtime) {
      options.spin = std::chrono::microseconds(0);
      options.poll_period = kLaggingPollPeriod;
    }
    // lockstep never lets queues fill; elsewhere a slow subscriber must not stall the clock
    options.drop_policy =
        scenario.mode == ClockMode::kLockstep ? DropPolicy::kBlock : DropPolicy::kDropNewest;
    return options;
  }

  std::vector<std::string> Peers() const {
    std::vector<std::string> peers;
    for (const auto& p : scenario_.processes) {
      if (p.name != self_.name) peers.push_back(p.name);
    }
    return peers;
  }

  bool Handshake() {
    last_launcher_message_ = Clock::now();
    control_.Send("hello");
    bus_.BeginHandshake();
    const auto peers = Peers();
    bool ready = false;
    while (true) {
      bus_.PublishHello();
      bus_.Spin(milliseconds(5));
      if (!ready && bus_.HandshakeComplete(peers)) {
        control_.Send("ready");
        ready = true;
      }
      if (StopRequested(/*poll_now=*/true)) return false;
      if (start_received_) break;
    }
    bus_.EndHandshake();
    return true;
  }

  // Polls the launcher (at most every kControlPollPeriod unless poll_now) and sends heartbeats.
  bool StopRequested(bool poll_now = false) {
    const auto now = Clock::now();
    if (now - last_heartbeat_ >= kHeartbeatPeriod) {
      control_.Send("heartbeat", std::to_string(sim_ns_));
      last_heartbeat_ = now;
    }
    if (poll_now || now - last_control_poll_ >= kControlPollPeriod) {
      last_control_poll_ = now;
      while (auto message = control_.Receive(milliseconds(0))) {
        last_launcher_message_ = now;
        if (message->kind == "start") start_received_ = true;
        if (message->kind == "stop") stop_received_ = true;
      }
      if (control_.Refused()) {  // a process started by hand with another run's secret, or under another name
        throw std::runtime_error(
            "the launcher at " + scenario_.bus.control_endpoint + " refused '" + self_.name +
            "': not a process of its run, or another run's secret (IAPSIM_RUN_SECRET, or "
            "RUN/secret through --run-dir)");
      }
      // a process on another host (external, or a Slurm job step) does not die with the launcher (no
      // PR_SET_PDEATHSIG across hosts): the launcher's messages are its heartbeat, as its are the launcher's
      const auto silent = std::chrono::duration<double>(now - last_launcher_message_);
      if (self_.host != ProcessHost::kLocal && silent.count() > self_.hang_timeout_s) {
        throw std::runtime_error("the launcher has been silent for " + std::to_string(silent.count()) +
                                 " s (hang_timeout_s): the run is gone, or this host cannot reach " +
                                 scenario_.bus.control_endpoint);
      }
    }
    if (received_signal != 0 && !stop_received_) {
      spdlog::info("{}: signal {} received, stopping", self_.name, received_signal.load());
      stop_received_ = true;
    }
    return stop_received_;
  }

  void RunClock() {
    const uint64_t last = scenario_.last_step();
    const int64_t step_ns = scenario_.step_ns();
    const auto wall_start = Clock::now();
    const auto ack_timeout = std::chrono::duration<double>(scenario_.clock.ack_timeout_s);
    late_acks_.assign(schedule_.members().size(), 0);
    lags_.assign(schedule_.members().size(), LagStats{});
    iapsim_msgs::Tick tick;
    rosgraph_msgs::Clock clock;
    for (uint64_t k = 0; k <= last; ++k) {
      if (StopRequested()) return;
      const StepInfo info{k, static_cast<int64_t>(k) * step_ns, k == last};
      sim_ns_ = info.stamp_ns;
      MuteProcessesNotDue(k);
      process_.Step(info);
      // the tick goes last: it closes step k for every receiver (recorder included)
      clock.clock = ToRosTime(info.stamp_ns);
      bus_.Publish("/clock", clock);
      tick.step = k;
      tick.stamp_ns = info.stamp_ns;
      tick.final = info.final;
      bus_.Publish(kTickTopic, tick);

      if (scenario_.mode == ClockMode::kRealtime) {
        const auto target =
            wall_start +
            std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                static_cast<double>(info.stamp_ns + step_ns) * 1e-9 / scenario_.clock.realtime_factor));
        // a step that ends after its slot: the clock itself (with the processes it waited on) fell behind
        if (const auto behind = Clock::now() - target; behind > Clock::duration::zero()) {
          ++behind_schedule_.steps;
          behind_schedule_.max = std::max(behind_schedule_.max, behind);
        }
        while (Clock::now() < target) {
          bus_.Spin(std::min(std::chrono::duration_cast<std::chrono::microseconds>(target - Clock::now()),
                             std::chrono::microseconds(1000)));
          if (StopRequested()) return;
        }
        CountLateAcks(k);
        continue;
      }
      MeasureLags(k);
      const auto deadline = Clock::now() + ack_timeout;
      int missing;
      bool held_by_lagging = false;
      while ((missing = FirstMissingAck(k)) >= 0) {
        // a process that may lag held the clock: it was max_lag_steps behind
        if (!held_by_lagging && schedule_.members()[missing].lag_steps > 0) {
          ++lags_[missing].waits;
          held_by_lagging = true;
        }
        bus_.Spin(milliseconds(1));
        if (StopRequested()) return;
        if (Clock::now() > deadline) {
          throw std::runtime_error("lockstep: process '" + schedule_.members()[missing].name +
                                   "' did not acknowledge step " + std::to_string(k) +
                                   " (t = " + std::to_string(static_cast<double>(info.stamp_ns) * 1e-9) +
                                   " s) within " + std::to_string(scenario_.clock.ack_timeout_s) + " s");
        }
      }
    }
    if (!WaitForFinalAcks(ack_timeout)) return;
    finished_ = true;
    control_.Send("done");
    while (!StopRequested(/*poll_now=*/true)) bus_.Spin(milliseconds(5));
  }

  // Lockstep and fast: the messages of step k (its state, /clock, the tick) reach only the processes due at
  // k, which act on the newest state they have when due anyway: a 200 Hz controller is not woken four
  // times in five for nothing. The last step reaches everyone (its tick ends the run). Realtime: every
  // process runs on the newest message, so all get everything.
  void MuteProcessesNotDue(uint64_t k) {
    if (scenario_.mode == ClockMode::kRealtime) return;
    not_due_.clear();
    for (size_t m = 0; m < schedule_.members().size(); ++m) {
      const int member = static_cast<int>(m);
      if (member != self_index_ && k != scenario_.last_step() && !schedule_.Due(member, k)) {
        not_due_.push_back(member);
      }
    }
    if (not_due_ == muted_) return;
    muted_ = not_due_;
    muted_names_.clear();
    for (const int member : muted_) muted_names_.push_back(schedule_.members()[member].name);
    bus_.SetMutedPeers(muted_names_);
  }

  // how many steps before k a process that may lag has not acknowledged yet, now that k is published (at
  // most its max_lag_steps): only the clock owner knows, a lagging process sees the clock's progress late
  void MeasureLags(uint64_t k) {
    for (size_t m = 0; m < lags_.size(); ++m) {
      if (schedule_.members()[m].lag_steps == 0) continue;
      const auto lag =
          static_cast<uint64_t>(std::max<int64_t>(0, static_cast<int64_t>(k) - 1 - last_ack_[m]));
      lags_[m].max = std::max(lags_[m].max, lag);
      lags_[m].sum += lag;
    }
  }

  // Realtime and fast do not wait for every process at every step; the run ends only once every process
  // has finished its last due step, so that what each sent for it reaches the others (and the recorder)
  // before they are told to stop. One that does not within the ack timeout is left behind (what it did not
  // send is counted as lost). False when a stop was requested.
  bool WaitForFinalAcks(std::chrono::duration<double> ack_timeout) {
    const auto deadline = Clock::now() + ack_timeout;
    int missing;
    while ((missing = FirstMissingAck(scenario_.last_step(), /*every_member=*/true)) >= 0) {
      bus_.Spin(milliseconds(1));
      if (StopRequested()) return false;
      if (Clock::now() > deadline) {
        spdlog::warn("'{}' did not acknowledge the last step within {} s; ending the run without it",
                     schedule_.members()[missing].name, scenario_.clock.ack_timeout_s);
        break;
      }
    }
    return true;
  }

  int FirstMissingAck(uint64_t k, bool every_member = false) const {
    const bool last = k == scenario_.last_step();
    for (size_t m = 0; m < last_ack_.size(); ++m) {
      const int member = static_cast<int>(m);
      if (member == self_index_) continue;
      if ((every_member || schedule_.Awaited(member, scenario_.mode)) &&
          last_ack_[m] < schedule_.AckNeeded(member, k, last)) {
        return member;
      }
    }
    return -1;
  }

  // realtime: a due participant whose ack for k has not arrived when k's wall-clock slot ends is late (one
  // that may lag: when the slot of k + max_lag_steps ends)
  void CountLateAcks(uint64_t k) {
    for (size_t m = 0; m < last_ack_.size(); ++m) {
      const int member = static_cast<int>(m);
      const uint64_t lag = schedule_.members()[m].lag_steps;
      if (k >= lag && schedule_.Due(member, k - lag) && last_ack_[m] < static_cast<int64_t>(k - lag)) {
        ++late_acks_[m];
      }
    }
  }

  void RunParticipant() {
    const auto period = std::min<std::chrono::microseconds>(milliseconds(5), process_.poll_period());
    while (!finished_ && !StopRequested()) {
      bus_.Spin(period);
      process_.Poll();
    }
    while (!StopRequested(/*poll_now=*/true)) bus_.Spin(milliseconds(5));
  }

  void OnAck(const iapsim_msgs::StepAck& ack) {
    const int member = schedule_.IndexOf(ack.node);
    if (member < 0) return;
    last_ack_[member] = std::max(last_ack_[member], static_cast<int64_t>(ack.step));
    if (!gating_peers_.empty() || !gating_previous_peers_.empty()) StepWaitingTicks();
  }

  void OnTick(const iapsim_msgs::Tick& tick) {
    sim_ns_ = tick.stamp_ns;
    if (!schedule_.Due(self_index_, tick.step)) {
      finished_ = finished_ || tick.final;
      return;
    }
    waiting_ticks_.push_back(StepInfo{tick.step, tick.stamp_ns, static_cast<bool>(tick.final)});
    StepWaitingTicks();
  }

  // steps every due tick whose prerequisites are met, in order (acts inside the bus callback, so in realtime
  // the process sees the messages of step k, not those of k+1 still queued behind the tick); a process that
  // may lag acknowledges only every AckInterval steps, so the others are not flooded with its acks
  void StepWaitingTicks() {
    size_t stepped = 0;
    while (stepped < waiting_ticks_.size() && PeersAcked(waiting_ticks_[stepped].step)) {
      const StepInfo info = waiting_ticks_[stepped++];
      process_.Step(info);
      if (info.final || info.step >= next_ack_step_) {
        ack_.step = info.step;
        ack_.node = self_.name;
        bus_.Publish(kAckTopic, ack_);
        next_ack_step_ = info.step + schedule_.AckInterval(self_index_);
      }
      finished_ = finished_ || info.final;
    }
    waiting_ticks_.erase(waiting_ticks_.begin(),
                         waiting_ticks_.begin() + static_cast<std::ptrdiff_t>(stepped));
  }

  bool PeersAcked(uint64_t k) const {
    for (const int member : gating_peers_) {
      if (schedule_.Due(member, k) && last_ack_[member] < static_cast<int64_t>(k)) return false;
    }
    for (const int member : gating_previous_peers_) {
      if (k == 0) break;
      const uint64_t period = schedule_.members()[member].period_steps;
      if (last_ack_[member] < static_cast<int64_t>((k - 1) / period * period)) return false;
    }
    return true;
  }

  int Finish() {
    // what peers sent before they stopped is read (and counted: the launcher compares what each process
    // received with what was published) when the run reached its end; the recorder reads it in any case,
    // since it writes whatever reached it (ticks and acks close their steps)
    if (finished_ || process_.StepsAfterPeers()) {
      const auto drain_end = Clock::now() + kDrainLimit;
      while (bus_.Spin(std::chrono::microseconds(0)) > 0 && Clock::now() < drain_end) {
      }
    }
    nlohmann::json process_report = nlohmann::json::object();
    process_.Finish(&process_report);
    nlohmann::json report = {{"bus", BusReport(bus_.stats())},
                             {"process", process_report},
                             {"completed", finished_},
                             {"sim_time_s", static_cast<double>(sim_ns_) * 1e-9}};
    // the launcher measures a local process's CPU time itself; one on another host reports its own
    const CpuTime cpu = ProcessCpuTime();
    report["cpu_s"] = {{"user", cpu.user_s}, {"system", cpu.system_s}};
    if (self_.role == ProcessRole::kClock && scenario_.mode == ClockMode::kRealtime) {
      report["behind_schedule"] = {
          {"steps", behind_schedule_.steps},
          {"max_ms", std::chrono::duration<double, std::milli>(behind_schedule_.max).count()}};
    }
    if (!late_acks_.empty()) {
      nlohmann::json late = nlohmann::json::object();
      for (size_t m = 0; m < late_acks_.size(); ++m) late[schedule_.members()[m].name] = late_acks_[m];
      report["late_acks"] = late;
    }
    // the clock owner's view of each process that may lag: steps behind (when a step is published), and the
    // steps at which the clock waited for it
    const double steps = static_cast<double>(sim_ns_ / scenario_.step_ns() + 1);
    for (size_t m = 0; m < lags_.size(); ++m) {
      const StepSchedule::Member& member = schedule_.members()[m];
      if (member.lag_steps == 0) continue;
      report["lag_steps"][member.name] = {{"max", lags_[m].max},
                                          {"mean", static_cast<double>(lags_[m].sum) / steps},
                                          {"limit", member.lag_steps},
                                          {"clock_waits", lags_[m].waits}};
    }
    spdlog::info("{} at t = {:.3f} s", finished_ ? "finished" : "stopped",
                 static_cast<double>(sim_ns_) * 1e-9);
    control_.Send("bye", report.dump());
    return 0;
  }

  const Scenario& scenario_;
  const ProcessConfig& self_;
  Process& process_;
  StepSchedule schedule_;
  int self_index_;
  ControlClient& control_;
  Bus bus_;
  std::vector<int64_t> last_ack_;           // per schedule member: highest step acknowledged
  std::vector<int> gating_previous_peers_;  // whose ack of their last due step before k it waits for
  std::vector<int> gating_peers_;  // schedule members whose ack of k this process waits for before step k
  std::vector<uint64_t> late_acks_;
  struct LagStats {
    uint64_t max = 0;
    uint64_t sum = 0;
    uint64_t waits = 0;  // steps at which the clock waited for it to catch up
  };
  std::vector<LagStats> lags_;  // per member; the clock owner's only
  struct {
    uint64_t steps = 0;
    Clock::duration max{};
  } behind_schedule_;  // realtime, the clock owner: steps done after their wall-clock slot, by how much
  std::vector<StepInfo> waiting_ticks_;
  std::vector<int> not_due_, muted_;  // clock owner: schedule members not due at a step; those muted now
  std::vector<std::string> muted_names_;
  uint64_t next_ack_step_ = 0;  // the first step this process acknowledges after the last it did
  iapsim_msgs::StepAck ack_;
  int64_t sim_ns_ = 0;
  bool start_received_ = false;
  bool stop_received_ = false;
  bool finished_ = false;
  Clock::time_point last_heartbeat_{};
  Clock::time_point last_control_poll_{};
  Clock::time_point last_launcher_message_{};
};

struct Arguments {
  std::string scenario;
  std::string node;
  std::string run_dir;
  std::vector<std::string> overrides;
  bool check = false;
};

}  // namespace

BusOptions ObserverBusOptions(const Scenario& scenario, const std::string& node_name,
                              const std::string& secret) {
  BusOptions options;
  options.node_name = node_name;
  options.bind_endpoint = "ipc://@" + node_name;
  for (const auto& [name, endpoint] : scenario.bus.endpoints) {
    const auto observer_endpoint = scenario.bus.observer_endpoints.find(name);
    options.peer_endpoints.push_back(
        observer_endpoint != scenario.bus.observer_endpoints.end() ? observer_endpoint->second : endpoint);
  }
  options.drop_policy = DropPolicy::kDropNewest;
  options.observer = true;
  options.message_limits = scenario.bus.message_limits;
  options.secret = secret;
  return options;
}

CpuTime ProcessCpuTime() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * t.tv_usec; };
  return {seconds(usage.ru_utime), seconds(usage.ru_stime)};
}

int ProcessMain(int argc, char** argv, const std::string& description, const ProcessFactory& factory) {
  Arguments args;
  CLI::App app(description);
  app.add_option("--scenario", args.scenario,
                 "scenario YAML (the run's scenario.resolved.yaml when launched)")
      ->required();
  app.add_option("--node", args.node, "this process's name in the scenario")->required();
  app.add_option("--run-dir", args.run_dir, "run directory for outputs");
  app.add_option("--set", args.overrides, "override a scenario key: KEY=VALUE");
  app.add_flag("--check", args.check, "validate the configuration, print the resolved params and exit");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return AnswerParseError(app, e);
  }

  spdlog::set_pattern("[%H:%M:%S.%e] [" + args.node + "] [%l] %v");
  std::unique_ptr<Process> process;
  Scenario scenario;
  const ProcessConfig* self = nullptr;
  try {
    scenario = LoadScenario(args.scenario, args.overrides);
    self = scenario.Find(args.node);
    if (!self) throw ConfigError(args.scenario + ": processes: no process named '" + args.node + "'");
    const ProcessContext context{scenario, *self, args.run_dir, scenario.SeedFor(self->name)};
    YamlMap params(self->params, args.scenario, "processes." + self->name + ".params");
    process = factory(context, params);
    params.Finish();
    if (args.check) {
      YAML::Emitter out;
      out << params.Resolved();
      std::cout << out.c_str() << std::endl;
      return 0;
    }
  } catch (const ConfigError& e) {
    std::cerr << e.what() << std::endl;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << args.node << ": " << e.what() << std::endl;
    return args.check ? 2 : 1;
  }

  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGINT, &action, nullptr);

  try {
    const std::string secret = ReadRunSecret(args.run_dir);
    ControlClient control(scenario.bus.control_endpoint, self->name, secret);
    try {
      Runtime runtime(scenario, *self, *process, control, secret);
      return runtime.Run();
    } catch (const std::exception& e) {
      control.Send("error", e.what());
      throw;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());  // stderr is the process's log file
    return 1;
  }
}

}  // namespace iapsim::bridge
