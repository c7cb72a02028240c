#include "tools/child_run.h"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <thread>

#include "bridge/launcher.h"

namespace iapsim::tools {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

int LocalJobs(int asked) {
  return asked > 0 ? asked : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

pid_t StartChildRun(const ChildRun& run) {
  const std::string program = bridge::ExecutableDir() + "/iapsim";
  std::vector<std::string> args = {program, "run", run.scenario, "--out", run.dir.string()};
  for (const std::string& o : run.overrides) {
    args.push_back("--set");
    args.push_back(o);
  }
  const std::string log = (run.dir / "iapsim.log").string();
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid != 0) return pid;
  prctl(PR_SET_PDEATHSIG, SIGINT);
  if (getppid() != parent) _exit(130);
  const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd >= 0) {
    dup2(fd, STDOUT_FILENO);
    dup2(fd, STDERR_FILENO);
    close(fd);
  }
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  execv(program.c_str(), argv.data());
  std::fprintf(stderr, "iapsim: cannot start %s: %s\n", program.c_str(), std::strerror(errno));
  _exit(127);
}

std::string ReasonFromLog(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last, error;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    last = line;
    if (line.rfind("iapsim: ", 0) == 0 && line.rfind("iapsim: partial outputs", 0) != 0)
      error = line.substr(8);
  }
  return error.empty() ? last : error;
}

ChildExit ChildExitOf(int wait_status, const fs::path& dir, double wall_s) {
  ChildExit exit;
  exit.wall_s = wall_s;
  if (WIFEXITED(wait_status)) {
    exit.exit_code = WEXITSTATUS(wait_status);
    if (exit.exit_code != 0) exit.reason = ReasonFromLog(dir / "iapsim.log");
  } else {
    const int signal = WTERMSIG(wait_status);
    exit.exit_code = 128 + signal;
    exit.reason = std::string("killed by signal ") + std::to_string(signal) + " (" + strsignal(signal) + ")";
  }
  return exit;
}

void RunChildren(const std::vector<ChildRun>& runs, int jobs, volatile std::sig_atomic_t& stop,
                 const std::function<void(size_t, const ChildExit&)>& ended) {
  struct Running {
    size_t run;
    Clock::time_point start;
  };
  std::map<pid_t, Running> running;
  size_t next = 0;
  bool forwarded = false;
  while (next < runs.size() || !running.empty()) {
    while (!stop && next < runs.size() && static_cast<int>(running.size()) < jobs) {
      const size_t i = next++;
      const pid_t pid = StartChildRun(runs[i]);
      if (pid < 0) {
        ended(i, ChildExit{1, std::string("fork: ") + std::strerror(errno), 0.0});
        continue;
      }
      running[pid] = Running{i, Clock::now()};
    }
    if (stop && !forwarded) {
      for (const auto& [pid, r] : running) kill(pid, SIGINT);
      forwarded = true;
    }
    if (running.empty()) break;
    int status = 0;
    const pid_t pid = waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      break;
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    const Running run = it->second;
    running.erase(it);
    ended(run.run, ChildExitOf(status, runs[run.run].dir,
                               std::chrono::duration<double>(Clock::now() - run.start).count()));
  }
}

volatile std::sig_atomic_t InterruptFlag::raised = 0;

namespace {
extern "C" void OnChildRunsInterrupt(int) { InterruptFlag::raised = 1; }
}  // namespace

InterruptFlag::InterruptFlag() {
  struct sigaction action {};
  action.sa_handler = OnChildRunsInterrupt;  // no SA_RESTART: waitpid returns at once
  sigaction(SIGINT, &action, &previous_int_);
  sigaction(SIGTERM, &action, &previous_term_);
  raised = 0;
}

InterruptFlag::~InterruptFlag() {
  sigaction(SIGINT, &previous_int_, nullptr);
  sigaction(SIGTERM, &previous_term_, nullptr);
}

}  // namespace iapsim::tools
