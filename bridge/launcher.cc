#include "bridge/launcher.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "bridge/bag.h"
#include "bridge/control_channel.h"
#include "bridge/run_secret.h"

namespace iapsim::bridge {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// how long the recorder may take, once every other process has exited, to write what it received and close
// its bag before it is signalled: a lagging recorder holds at most recording.max_lag_steps of messages
constexpr auto kRecorderCloseGrace = std::chrono::seconds(10);

// the launcher's own stop request (Ctrl-C, SIGTERM); signals are process-wide by nature
std::atomic<int> launcher_signal{0};
extern "C" void OnLauncherSignal(int signal) { launcher_signal = signal; }

struct Captured {
  int exit_code = -1;
  std::string out;
  std::string err;
};

std::string ReadAll(int fd) {
  std::string text;
  char buffer[4096];
  ssize_t n;
  while ((n = read(fd, buffer, sizeof(buffer))) != 0) {
    if (n < 0 && errno == EINTR) continue;  // the launcher's signal handler ran: the interrupt is seen later
    if (n < 0) break;
    text.append(buffer, static_cast<size_t>(n));
  }
  return text;
}

std::vector<char*> ArgvOf(std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  return argv;
}

// Runs a short command (a process's --check) and captures its output. stderr goes to a temporary file so
// that neither pipe can fill up and block the child.
Captured RunCaptured(std::vector<std::string> args) {
  Captured result;
  int out_pipe[2];
  if (pipe(out_pipe) != 0) throw std::runtime_error("pipe: " + std::string(std::strerror(errno)));
  FILE* err_file = std::tmpfile();
  auto argv = ArgvOf(args);
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(out_pipe[1], STDOUT_FILENO);
    dup2(fileno(err_file), STDERR_FILENO);
    close(out_pipe[0]);
    close(out_pipe[1]);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(out_pipe[1]);
  result.out = ReadAll(out_pipe[0]);
  close(out_pipe[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  std::rewind(err_file);
  result.err = ReadAll(fileno(err_file));
  std::fclose(err_file);
  return result;
}

std::string Trimmed(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  return text;
}

// how often the launcher tells processes started elsewhere that it is still there
constexpr auto kAlivePeriod = milliseconds(200);
// a process sends its bye (with its report) and then exits: how long the bye may still be on its way
constexpr auto kByeLimit = milliseconds(1000);

std::string DescribeExit(int status) {
  if (WIFEXITED(status)) return "exited with code " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    return "was killed by signal " + std::to_string(sig) + " (" + strsignal(sig) + ")";
  }
  return "ended (status " + std::to_string(status) + ")";
}

struct Child {
  std::string name;
  std::string log_path;
  pid_t pid = -1;
  ProcessHost host = ProcessHost::kLocal;
  // started elsewhere (host: external): no pid, its end is its bye; `command` is what starts it
  bool external() const { return host == ProcessHost::kExternal; }
  std::string command;
  bool exited = false;
  int status = 0;
  bool ready = false;
  bool said_bye = false;
  double hang_timeout_s = 2.0;
  double startup_timeout_s = 30.0;
  bool recorder = false;  // stops last (see Supervisor::Escalate)
  Clock::time_point last_heartbeat;
  Clock::time_point signal_at = Clock::time_point::max();  // stopping: when it gets its next signal
  bool terminated = false;                                 // SIGTERM sent: the next one is SIGKILL
  int64_t sim_ns = 0;
  nlohmann::json report;
  // its whole life's CPU time, once reaped (a process that crashed has no report of its own)
  double cpu_user_s = 0.0;
  double cpu_system_s = 0.0;
};

// The launcher's environment with IAPSIM_RUN_SECRET set to the run's (whatever the caller's shell had), made
// before fork: runs launched at once from one program each hand their own to their processes.
std::vector<std::string> EnvironmentWithSecret(const std::string& secret) {
  constexpr char kKey[] = "IAPSIM_RUN_SECRET=";
  std::vector<std::string> env;
  for (char** entry = environ; *entry != nullptr; ++entry) {
    if (std::strncmp(*entry, kKey, sizeof(kKey) - 1) != 0) env.emplace_back(*entry);
  }
  env.push_back(kKey + secret);
  return env;
}

pid_t Spawn(std::vector<std::string> args, std::vector<std::string> env, const std::string& log_path) {
  auto argv = ArgvOf(args);
  auto envp = ArgvOf(env);
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork failed: " + std::string(std::strerror(errno)));
  if (pid == 0) {
    // only async-signal-safe calls between fork and exec
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    prctl(PR_SET_PDEATHSIG, SIGTERM);  // launcher gone -> children go too
    if (getppid() != parent) _exit(1);
    setpgid(0, 0);  // Ctrl-C reaches the launcher only; it stops the children in order
    const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
    execve(argv[0], argv.data(), envp.data());
    _exit(127);
  }
  return pid;
}

// How a process ended, for metrics.json: its exit status, or for one started elsewhere whether it said bye.
std::string DescribeEnd(const Child& child) {
  if (!child.external()) return DescribeExit(child.status);
  return child.said_bye ? "said bye (started elsewhere)"
                        : "not heard from after the stop (started elsewhere)";
}

std::string LastLines(const std::string& path, size_t count) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  std::string out;
  for (size_t i = lines.size() > count ? lines.size() - count : 0; i < lines.size(); ++i) {
    out += "\n    " + lines[i];
  }
  return out;
}

class Supervisor {
 public:
  Supervisor(const Scenario& scenario, std::vector<Child> children, ControlServer& server,
             std::shared_ptr<spdlog::logger> log, bool progress)
      : scenario_(scenario),
        children_(std::move(children)),
        server_(server),
        log_(std::move(log)),
        progress_(progress && isatty(STDERR_FILENO)),
        plain_progress_(progress && !isatty(STDERR_FILENO)) {}

  // Returns the failure message, empty when the run completed.
  std::string Run() {
    started_ = Clock::now();
    for (auto& child : children_) child.last_heartbeat = started_;
    while (!AllExited()) {
      TellExternalsAlive();
      ReadControl();
      Reap();
      if (!stopping_) Watch();
      if (stopping_) Escalate();
      ShowProgress();
    }
    // the last exit can be reaped before its bye is read: metrics.json would lack that process's report
    const auto bye_limit = Clock::now() + kByeLimit;
    while (ByeOnItsWay() && Clock::now() < bye_limit) ReadControl();
    if (progress_) std::fprintf(stderr, "\n");
    return failure_;
  }

  const std::vector<Child>& children() const { return children_; }
  /// Wall time of the clock: from start to the clock owner's "done" (or to now, if it never came).
  double wall_s() const {
    const auto end = completed_ ? done_at_ : Clock::now();
    return std::chrono::duration<double>(end - running_since_).count();
  }
  bool interrupted() const { return interrupted_; }

 private:
  Child* Find(const std::string& name) {
    for (auto& c : children_) {
      if (c.name == name) return &c;
    }
    return nullptr;
  }

  bool AllExited() const {
    for (const auto& c : children_) {
      if (!c.exited) return false;
    }
    return true;
  }

  // a child started here that exited cleanly said bye before it exited
  bool ByeOnItsWay() const {
    return std::any_of(children_.begin(), children_.end(), [](const Child& c) {
      return !c.external() && !c.said_bye && WIFEXITED(c.status) && WEXITSTATUS(c.status) == 0;
    });
  }

  void TellExternalsAlive() {
    const auto now = Clock::now();
    if (now - last_alive_ < kAlivePeriod) return;
    last_alive_ = now;
    for (const auto& child : children_) {
      if (child.host != ProcessHost::kLocal && !child.exited) server_.Send(child.name, "alive");
    }
  }

  void ReadControl() {
    auto timeout = milliseconds(10);
    while (auto message = server_.Receive(timeout)) {
      timeout = milliseconds(0);
      Child* child = Find(message->process);
      if (!child) continue;
      child->last_heartbeat = Clock::now();
      if (message->kind == "ready") {
        child->ready = true;
      } else if (message->kind == "heartbeat") {
        child->sim_ns = std::atoll(message->body.c_str());
      } else if (message->kind == "done") {
        completed_ = true;
        done_at_ = Clock::now();
        log_->info("run complete: {} reached the end of the scenario", child->name);
        Stop(milliseconds(5000));
      } else if (message->kind == "error") {
        Fail("process '" + child->name + "' failed: " + message->body);
      } else if (message->kind == "bye") {
        child->said_bye = true;
        child->report = nlohmann::json::parse(message->body, nullptr, /*allow_exceptions=*/false);
        // on another host its CPU time is what it reported (srun's is not the process's)
        if (child->host != ProcessHost::kLocal) {
          const auto cpu = child->report.is_object() ? child->report.value("cpu_s", nlohmann::json::object())
                                                     : nlohmann::json::object();
          child->cpu_user_s = cpu.value("user", 0.0);
          child->cpu_system_s = cpu.value("system", 0.0);
        }
        // a process started elsewhere has ended with its bye (one started here when it is reaped)
        if (child->external()) {
          child->exited = true;
          if (!stopping_)
            Fail("process '" + child->name + "' (started elsewhere) ended before the end of the run");
        }
      }
    }
    for (const std::string& refusal : server_.TakeRefusals()) {
      log_->warn("control channel: refused {}", refusal);
    }
  }

  void Reap() {
    for (auto& child : children_) {
      if (child.exited || child.external()) continue;
      int status = 0;
      rusage usage{};
      if (wait4(child.pid, &status, WNOHANG, &usage) != child.pid) continue;
      child.exited = true;
      child.status = status;
      if (child.host == ProcessHost::kLocal) {
        child.cpu_user_s =
            static_cast<double>(usage.ru_utime.tv_sec) + 1e-6 * static_cast<double>(usage.ru_utime.tv_usec);
        child.cpu_system_s =
            static_cast<double>(usage.ru_stime.tv_sec) + 1e-6 * static_cast<double>(usage.ru_stime.tv_usec);
      }
      const bool clean = WIFEXITED(status) && WEXITSTATUS(status) == 0;
      if (!stopping_ || (!clean && !completed_ && failure_.empty())) {
        Fail("process '" + child.name + "' (pid " + std::to_string(child.pid) + ") " + DescribeExit(status) +
             (stopping_ ? "" : " before the end of the run") + "; its log " + child.log_path + ":" +
             LastLines(child.log_path, 5));
      } else if (!clean) {
        log_->warn("process '{}' {} while stopping", child.name, DescribeExit(status));
      }
    }
  }

  void Watch() {
    const auto now = Clock::now();
    if (launcher_signal != 0) {
      interrupted_ = true;
      Fail(std::string("interrupted by ") + strsignal(launcher_signal.load()));
      return;
    }
    if (!running_) {
      bool all_ready = true;
      for (auto& child : children_) {
        if (child.ready) continue;
        all_ready = false;
        if (now - started_ > std::chrono::duration<double>(child.startup_timeout_s)) {
          Fail("process '" + child.name + "' did not become ready within " +
               std::to_string(child.startup_timeout_s) + " s; " +
               (child.external() ? "it is started elsewhere, with: " + child.command
                                 : "its log " + child.log_path + ":" + LastLines(child.log_path, 5)));
          return;
        }
      }
      if (!all_ready) return;
      for (auto& child : children_) {
        server_.Send(child.name, "start");
        child.last_heartbeat = now;
      }
      running_ = true;
      running_since_ = now;
      last_progress_ = now;
      log_->info("all {} processes ready; clock started", children_.size());
      return;
    }
    for (auto& child : children_) {
      if (now - child.last_heartbeat > std::chrono::duration<double>(child.hang_timeout_s)) {
        const double silent_s = std::chrono::duration<double>(now - child.last_heartbeat).count();
        if (!child.external()) kill(child.pid, SIGKILL);  // a hung process will not answer a stop request
        Fail("process '" + child.name + "'" + (child.external() ? " (started elsewhere)" : "") +
             " is not responding (no heartbeat for " + std::to_string(silent_s) +
             " s, hang_timeout_s = " + std::to_string(child.hang_timeout_s) + ")");
        return;
      }
    }
  }

  void Fail(const std::string& message) {
    if (failure_.empty() && !completed_) {
      failure_ = message;
      log_->error("{}", message);
    }
    Stop(milliseconds(300));
  }

  void Stop(milliseconds grace) {
    if (stopping_) return;
    stopping_ = true;
    for (auto& child : children_) {
      if (child.exited) continue;
      server_.Send(child.name, "stop");
      if (!child.recorder) child.signal_at = Clock::now() + grace;
    }
  }

  // Stop request -> SIGTERM -> SIGKILL, 400 ms apart. The recorder is told to stop with the others but is
  // signalled only kRecorderCloseGrace after they have all exited: it writes what they sent, then closes its
  // bag (a killed recorder leaves it unindexed).
  void Escalate() {
    const auto now = Clock::now();
    const bool others_exited = std::all_of(children_.begin(), children_.end(),
                                           [](const Child& c) { return c.exited || c.recorder; });
    for (auto& child : children_) {
      if (child.exited) continue;
      if (child.recorder && others_exited && child.signal_at == Clock::time_point::max()) {
        child.signal_at = now + kRecorderCloseGrace;
      }
      if (now < child.signal_at) continue;
      if (child.external()) {
        // no signal reaches another host; it stops by itself once the launcher is silent (hang_timeout_s)
        log_->warn("process '{}' (started elsewhere) did not say bye after the stop; not waiting for it",
                   child.name);
        child.exited = true;
        continue;
      }
      const int sig = child.terminated ? SIGKILL : SIGTERM;
      log_->warn("process '{}' still running after stop; sending {}", child.name, strsignal(sig));
      kill(child.pid, sig);
      child.terminated = true;
      child.signal_at = now + milliseconds(400);
    }
  }

  // On a terminal a line redrawn 4 times a second; elsewhere (a CI log, a file) a plain line every 5 s, so
  // that a long run shows it is alive and when it will end.
  void ShowProgress() {
    if (!(progress_ || plain_progress_) || !running_ || stopping_) return;
    const auto now = Clock::now();
    if (now - last_progress_ < (progress_ ? milliseconds(250) : milliseconds(5000))) return;
    last_progress_ = now;
    const Child* owner = nullptr;
    for (const auto& c : children_) {
      if (c.name == scenario_.clock_owner) owner = &c;
    }
    const double sim_s = owner ? static_cast<double>(owner->sim_ns) * 1e-9 : 0.0;
    const double factor = sim_s / std::max(1e-9, wall_s());
    if (plain_progress_) {
      std::fprintf(stderr, "iapsim run: t = %.1f of %.1f s, %.2fx real time, about %.0f s to go\n", sim_s,
                   scenario_.run_s(), factor, factor > 0 ? (scenario_.run_s() - sim_s) / factor : 0.0);
      return;
    }
    std::string health;
    for (const auto& c : children_) {
      const bool late = now - c.last_heartbeat > std::chrono::duration<double>(c.hang_timeout_s / 2);
      health += " " + c.name + (c.exited ? ":exited" : late ? ":slow" : ":ok");
    }
    std::fprintf(stderr, "\33[2K\r t = %.3f / %.3f s  x%.2f |%s", sim_s, scenario_.run_s(), factor,
                 health.c_str());
  }

  const Scenario& scenario_;
  std::vector<Child> children_;
  ControlServer& server_;
  std::shared_ptr<spdlog::logger> log_;
  bool progress_, plain_progress_;
  Clock::time_point started_, running_since_, done_at_, last_progress_, last_alive_;
  bool running_ = false, stopping_ = false, completed_ = false, interrupted_ = false;
  std::string failure_;
};

std::string MakeRunDir(const LaunchOptions& options, const Scenario& scenario) {
  fs::path dir = options.out_dir.empty() ? fs::path("runs") / (scenario.name + "-" + UtcStamp())
                                         : fs::path(options.out_dir);
  if (options.out_dir.empty()) {
    const fs::path base = dir;
    for (int i = 2; fs::exists(dir); ++i) dir = base.string() + "-" + std::to_string(i);
  }
  fs::create_directories(dir / "logs");
  // runs/latest -> the newest run, --out ones included, for `iapsim topics` and `iapsim echo` (relative
  // when the run is in runs/, so that the folder can move)
  std::error_code ignored;
  const fs::path runs = "runs";
  fs::create_directories(runs, ignored);
  const fs::path absolute = fs::absolute(dir).lexically_normal();
  const fs::path target =
      absolute.parent_path() == fs::absolute(runs).lexically_normal() ? absolute.filename() : absolute;
  fs::remove(runs / "latest", ignored);
  fs::create_directory_symlink(target, runs / "latest", ignored);
  // RUN/launcher.pid: while that process lives the graph runs (the live commands give up once it is gone)
  std::ofstream(dir / "launcher.pid") << getpid() << "\n";
  return dir.string();
}

// What each process missed of what its peers published (sent, or dropped at the publisher), per topic,
// from the processes' bus counters: the recorder (the process that reports what it `recorded`) in every
// mode, for the topics it records, counted in its bag; every other process in realtime, where each gets
// every message it subscribed to (lockstep and fast mute the processes not due at a step, by design).
// Only non-zero counts appear.
nlohmann::json CountLosses(const Scenario& scenario, const nlohmann::json& processes, uint64_t* total) {
  std::map<std::string, std::map<std::string, uint64_t>> published;  // topic -> publisher -> messages
  for (const auto& [name, entry] : processes.items()) {
    if (!entry.contains("bus")) continue;
    for (const auto& [topic, c] : entry["bus"]["topics"].items()) {
      const uint64_t n = c.value("sent", uint64_t{0}) + c.value("dropped", uint64_t{0});
      if (n > 0) published[topic][name] = n;
    }
  }
  const auto published_by_others = [&](const std::string& topic, const std::string& self) {
    uint64_t n = 0;
    if (const auto it = published.find(topic); it != published.end()) {
      for (const auto& [publisher, count] : it->second) n += publisher == self ? 0 : count;
    }
    return n;
  };
  nlohmann::json losses = nlohmann::json::object();
  *total = 0;
  const auto add = [&](const std::string& process, const std::string& topic, uint64_t expected,
                       uint64_t got) {
    if (got >= expected) return;
    losses[process][topic] = expected - got;
    *total += expected - got;
  };
  for (const auto& [name, entry] : processes.items()) {
    if (!entry.contains("bus")) continue;
    if (entry.contains("process") && entry["process"].contains("recorded")) {
      const auto& recorded = entry["process"]["recorded"];
      const nlohmann::json thinned = entry["process"].value("thinned", nlohmann::json::object());
      for (const auto& [topic, by_publisher] : published) {
        if (scenario.recording.Records(topic)) {  // what recording.max_rate_hz left out is not lost
          add(name, topic, published_by_others(topic, name),
              recorded.value(topic, uint64_t{0}) + thinned.value(topic, uint64_t{0}));
        }
      }
    } else if (scenario.mode == ClockMode::kRealtime) {
      for (const auto& [topic, c] : entry["bus"]["topics"].items()) {
        if (c.value("subscribed", false)) {
          add(name, topic, published_by_others(topic, name), c.value("received", uint64_t{0}));
        }
      }
    }
  }
  return losses;
}

// A recorder that did not exit by itself (killed while hung, or after its close grace) leaves its bag
// unindexed: it is reindexed in place from its whole chunks, so that the run directory holds a complete bag.
// Returns what was done (empty: nothing to do).
std::string RepairKilledRecording(const Scenario& scenario, const std::vector<Child>& children,
                                  const std::string& run_dir, spdlog::logger& log) {
  const std::string bag = run_dir + "/run.bag";
  for (const Child& child : children) {
    if (!child.recorder || (WIFEXITED(child.status) && WEXITSTATUS(child.status) == 0)) continue;
    try {
      std::string note = BagReader(bag).note();
      if (note.empty()) return "";
      BagWriterOptions options;
      options.compression =
          scenario.recording.compression == "lz4" ? BagCompression::kLz4 : BagCompression::kNone;
      const uint64_t messages = ReindexBag(bag, bag + ".reindexed", options);
      fs::rename(bag + ".reindexed", bag);
      note = "the recorder " + DescribeExit(child.status) + "; its bag was " + note + "; now reindexed, " +
             std::to_string(messages) + " messages";
      log.warn("{}", note);
      return note;
    } catch (const std::exception& e) {
      log.error("the recorder {}; its bag {} cannot be repaired: {}", DescribeExit(child.status), bag,
                e.what());
      return std::string("not repaired: ") + e.what();
    }
  }
  return "";
}

std::string DescribeLosses(const nlohmann::json& losses, uint64_t total) {
  std::string text = std::to_string(total) + " message" + (total == 1 ? "" : "s") + " lost:";
  for (const auto& [process, topics] : losses.items()) {
    for (const auto& [topic, n] : topics.items()) {
      text += " " + process + " missed " + std::to_string(n.get<uint64_t>()) + " on " + topic + ";";
    }
  }
  text.back() = ' ';
  return text + "(metrics.json: losses)";
}

// Where `program` is on PATH, or "" (execve takes a path).
std::string FindOnPath(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::string folders = path ? path : "/usr/bin:/bin";
  for (size_t start = 0; start <= folders.size();) {
    const size_t end = std::min(folders.find(':', start), folders.size());
    const std::string candidate = folders.substr(start, end - start) + "/" + program;
    if (end > start && access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return "";
}

// The IPv4 address of `host` (a literal, or a name the resolver knows), or "".
std::string Ipv4Of(const std::string& host) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), nullptr, &hints, &found) != 0 || !found) return "";
  char text[INET_ADDRSTRLEN] = "";
  inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(found->ai_addr)->sin_addr, text, sizeof(text));
  freeaddrinfo(found);
  return text;
}

// A host: srun process runs as a job step of the allocation the launcher is in (salloc, sbatch), on its
// slurm_node, and binds the address Slurm has for that node (NodeAddr) unless the scenario names one. Checks
// both before anything starts; returns srun's path. Throws ConfigError naming the key.
std::string PrepareSrun(const std::string& scenario_path, ProcessConfig* p, YAML::Node resolved) {
  const std::string where = scenario_path + ":" + std::to_string(p->line) + ": processes." + p->name + ".";
  if (!std::getenv("SLURM_JOB_ID")) {
    throw ConfigError(where +
                      "host: srun starts the process in the Slurm allocation iapsim run is in, and "
                      "there is none (SLURM_JOB_ID is not set): run it inside salloc or sbatch");
  }
  const std::string srun = FindOnPath("srun"), scontrol = FindOnPath("scontrol");
  if (srun.empty() || scontrol.empty()) {
    throw ConfigError(where +
                      "host: srun needs Slurm's srun and scontrol on PATH (apt-get install slurm-client)");
  }
  if (p->address.empty()) {
    const Captured node = RunCaptured({scontrol, "show", "node", "-o", p->slurm_node});
    const size_t at = node.out.find("NodeAddr=");
    if (node.exit_code != 0 || at == std::string::npos) {
      throw ConfigError(where + "slurm_node: '" + p->slurm_node +
                        "' is not a node of the cluster (scontrol: " +
                        Trimmed(node.err.empty() ? node.out : node.err) + ")");
    }
    const std::string node_address = node.out.substr(at + 9, node.out.find(' ', at) - at - 9);
    p->address = Ipv4Of(node_address);
    if (p->address.empty()) {
      throw ConfigError(where + "slurm_node: no IPv4 address for its NodeAddr '" + node_address +
                        "'; give the process an address");
    }
    resolved["processes"][p->name]["address"] = p->address;
  }
  return srun;
}

// srun's part of a host: srun process's command: one task on its node, sharing the allocation's CPUs with
// the other steps (--overlap), its output in the process's log as a local one's
std::vector<std::string> SrunCommand(const std::string& srun_path, const ProcessConfig& p) {
  return {srun_path,
          "--jobid=" + std::string(std::getenv("SLURM_JOB_ID")),
          "--nodes=1",
          "--ntasks=1",
          "--nodelist=" + p.slurm_node,
          "--overlap",
          "--quiet",
          "--job-name=iapsim-" + p.name};
}

// The command that starts a process elsewhere, with absolute paths; written to RUN/external/NAME.sh too. It
// reads the run's secret from RUN/secret; a host without the run folder needs a copy of
// scenario.resolved.yaml (and every file it names, at the same paths) and IAPSIM_RUN_SECRET set.
std::string ExternalCommand(const std::string& exec, const std::string& resolved_path,
                            const std::string& node, const std::string& run_dir) {
  // a path as one shell word, whatever it holds (spaces, quotes)
  const auto quoted = [](const fs::path& path) {
    const std::string text = fs::absolute(path).lexically_normal().string();
    if (text.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789/._-+") ==
        std::string::npos) {
      return text;
    }
    std::string word = "'";
    for (const char c : text) word += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return word + "'";
  };
  const fs::path run = fs::absolute(run_dir).lexically_normal();
  const std::string command =
      quoted(exec) + " --scenario " + quoted(resolved_path) + " --node " + node + " --run-dir " + quoted(run);
  fs::create_directories(run / "external");
  const fs::path script = run / "external" / (node + ".sh");
  std::ofstream(script) << "#!/bin/sh\n# starts '" << node << "' of the run in " << run.string()
                        << " (the launcher waits for it)\nexec " << command << " \"$@\"\n";
  fs::permissions(script, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                  fs::perm_options::add);
  return command;
}

}  // namespace

std::string UtcStamp() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y%m%d-%H%M%S", &utc);
  return text;
}

std::string ExecutableDir() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  return error ? "." : self.parent_path().string();
}

LaunchResult Launch(const LaunchOptions& options) {
  LaunchResult result;
  // from the start: an interrupt while the processes check their params (Ctrl-C reaches them too, so their
  // checks fail) is reported as the interrupt. An interrupt is consumed where a launch reports it, not
  // cleared when one starts: one that came between two launches of a program (regress evaluating a flight)
  // stops the next, and the launch after that starts clean.
  struct sigaction action {};
  action.sa_handler = OnLauncherSignal;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  const auto interrupted = [&result] {
    const int signal = launcher_signal.exchange(0);
    if (signal == 0) return false;
    result.exit_code = 130;
    result.message = std::string("interrupted by ") + strsignal(signal);
    return true;
  };
  if (interrupted()) return result;
  Scenario scenario;
  std::map<std::string, std::string> executables;
  std::map<std::string, YAML::Node> resolved_params;
  std::string srun_path;
  try {
    scenario = LoadScenario(options.scenario_path, options.overrides);
    for (const auto& p : scenario.processes) {
      const std::string path =
          p.exec.find('/') == std::string::npos ? options.bin_dir + "/" + p.exec : p.exec;
      if (access(path.c_str(), X_OK) != 0) {
        throw ConfigError(options.scenario_path + ":" + std::to_string(p.line) + ": processes." + p.name +
                          ".exec: no executable '" + path + "'");
      }
      executables[p.name] = path;
      // each process validates its own params (unknown keys, types, files), with the scenario's line numbers
      std::vector<std::string> check{path, "--check", "--scenario", options.scenario_path, "--node", p.name};
      for (const auto& o : options.overrides) check.insert(check.end(), {"--set", o});
      const Captured checked = RunCaptured(check);
      if (checked.exit_code == 2) throw ConfigError(Trimmed(checked.err));
      if (checked.exit_code != 0) {
        throw std::runtime_error("process '" + p.name + "' (" + path + " --check) " +
                                 (checked.exit_code == 127 ? "could not be started" : "failed") + ": " +
                                 Trimmed(checked.err));
      }
      resolved_params[p.name] = YAML::Load(checked.out);
    }
    for (auto& p : scenario.processes) {
      if (p.host == ProcessHost::kSrun) srun_path = PrepareSrun(options.scenario_path, &p, scenario.resolved);
    }
  } catch (const ConfigError& e) {
    if (interrupted()) return result;
    result.exit_code = 2;
    result.message = e.what();
    return result;
  } catch (const std::exception& e) {
    if (interrupted()) return result;
    result.exit_code = 1;
    result.message = e.what();
    return result;
  }

  if (interrupted() || options.check_only) return result;

  // the run directory, with the configuration exactly as the processes will use it
  result.run_dir = MakeRunDir(options, scenario);
  const std::string secret = CreateRunSecret(result.run_dir);
  const std::string run_id =
      std::to_string(getpid()) + "-" + std::to_string(Clock::now().time_since_epoch().count() % 1000000007);
  AssignEndpoints(&scenario, run_id);
  for (const auto& [name, params] : resolved_params) {
    if (scenario.resolved["processes"][name]) scenario.resolved["processes"][name]["params"] = params;
  }
  const std::string resolved_path = result.run_dir + "/scenario.resolved.yaml";
  {
    YAML::Emitter out;
    out << scenario.resolved;
    std::ofstream(resolved_path) << out.c_str() << "\n";
  }

  auto stderr_sink = std::make_shared<spdlog::sinks::stderr_sink_mt>();
  auto file_sink = std::make_shared<spdlog::sinks::basic_file_sink_mt>(result.run_dir + "/log.txt", true);
  auto log = std::make_shared<spdlog::logger>("iapsim", spdlog::sinks_init_list{stderr_sink, file_sink});
  log->set_pattern("[%H:%M:%S.%e] [launcher] [%l] %v");
  stderr_sink->set_level(spdlog::level::warn);  // the terminal gets problems; log.txt gets everything
  log->flush_on(spdlog::level::info);           // log.txt is complete at every moment, crash or not
  log->info("scenario {} ({} mode, {} s, seed {}), run directory {}", options.scenario_path,
            ToString(scenario.mode), scenario.duration_s, scenario.seed, result.run_dir);

  const auto wall_start = Clock::now();
  std::vector<std::string> names;
  for (const auto& p : scenario.processes) names.push_back(p.name);
  ControlServer server(scenario.bus.control_endpoint, secret, names);
  std::vector<Child> children;
  for (const auto& p : scenario.processes) {
    Child child;
    child.name = p.name;
    child.log_path = result.run_dir + "/logs/" + p.name + ".log";
    child.hang_timeout_s = p.hang_timeout_s;
    child.startup_timeout_s = p.startup_timeout_s;
    child.recorder = p.name == kRecorderProcess && scenario.recording.enabled;
    child.host = p.host;
    if (p.host == ProcessHost::kExternal) {
      child.command = ExternalCommand(executables[p.name], resolved_path, p.name, result.run_dir);
      log->info("waiting for {} (started elsewhere): {}", p.name, child.command);
      std::fprintf(stderr, "iapsim run: waiting up to %.0f s for '%s', started elsewhere:\n  %s\n",
                   p.startup_timeout_s, p.name.c_str(), child.command.c_str());
    } else {
      std::vector<std::string> command{executables[p.name], "--scenario",  resolved_path, "--node", p.name,
                                       "--run-dir",         result.run_dir};
      if (p.host == ProcessHost::kSrun) {
        const std::vector<std::string> srun = SrunCommand(srun_path, p);
        command.insert(command.begin(), srun.begin(), srun.end());
      }
      child.pid = Spawn(command, EnvironmentWithSecret(secret), child.log_path);
      log->info("started {} (pid {}{}): {}", p.name, child.pid,
                p.host == ProcessHost::kSrun ? ", a job step on " + p.slurm_node : "", executables[p.name]);
    }
    children.push_back(child);
  }

  Supervisor supervisor(scenario, children, server, log, options.progress);
  const std::string failure = supervisor.Run();
  const std::string repaired = RepairKilledRecording(scenario, supervisor.children(), result.run_dir, *log);

  // metrics.json: what the run measured, and every process's own report
  nlohmann::json metrics;
  metrics["scenario"] = scenario.name;
  metrics["mode"] = ToString(scenario.mode);
  metrics["seed"] = scenario.seed;
  metrics["fidelity"] = scenario.fidelity;
  metrics["duration_s"] = scenario.duration_s;
  metrics["lead_in_s"] = scenario.lead_in_s;
  metrics["clock_step_s"] = scenario.clock.step_s;
  metrics["result"] = failure.empty() ? "completed" : "failed";
  if (!failure.empty()) metrics["failure"] = failure;
  if (!repaired.empty()) metrics["recording_repaired"] = repaired;
  metrics["control_refused"] = server.refused();
  const double wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
  metrics["wall_time_s"] = wall_s;
  for (const auto& child : supervisor.children()) {
    nlohmann::json entry = child.report.is_object() ? child.report : nlohmann::json::object();
    entry["exit"] = DescribeEnd(child);
    entry["cpu_s"] = {{"user", child.cpu_user_s}, {"system", child.cpu_system_s}};
    if (child.name == scenario.clock_owner && entry.contains("sim_time_s")) {
      metrics["sim_time_s"] = entry["sim_time_s"];
      metrics["real_time_factor"] = entry["sim_time_s"].get<double>() / std::max(1e-9, supervisor.wall_s());
    }
    metrics["processes"][child.name] = entry;
  }
  // what each process costs per simulated second: where a run's time goes
  if (metrics.contains("sim_time_s") && metrics["sim_time_s"].get<double>() > 0.0) {
    for (auto& [name, entry] : metrics["processes"].items()) {
      entry["cpu_s_per_sim_s"] =
          (entry["cpu_s"]["user"].get<double>() + entry["cpu_s"]["system"].get<double>()) /
          metrics["sim_time_s"].get<double>();
    }
  }
  uint64_t lost = 0;
  metrics["losses"] = CountLosses(scenario, metrics["processes"], &lost);
  metrics["messages_lost"] = lost;
  if (failure.empty() && lost > 0) metrics["result"] = "completed_with_losses";
  std::ofstream(result.run_dir + "/metrics.json") << metrics.dump(2) << "\n";

  if (!failure.empty()) {
    result.exit_code = supervisor.interrupted() ? 130 : 1;
    result.message = failure;
    if (supervisor.interrupted()) launcher_signal = 0;  // reported
  } else if (lost > 0) {
    result.exit_code = 3;
    result.message = DescribeLosses(metrics["losses"], lost);
    log->warn("{}", result.message);
  }
  log->info("run {} after {:.2f} s", metrics["result"].get<std::string>(), wall_s);
  log->flush();
  return result;
}

}  // namespace iapsim::bridge
