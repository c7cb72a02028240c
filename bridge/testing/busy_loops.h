#pragma once
// Busy loops, two per core, as on a machine busy with other work (a build, a training run): for the bus's
// test and benchmark of spinning on an oversubscribed machine. The loops are processes, killed when this
// goes out of scope, so a failing assertion never leaves them behind.

#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdint>
#include <thread>
#include <vector>

namespace iapsim::bridge::testing {

class BusyLoops {
 public:
  BusyLoops() {
    const pid_t parent = getpid();
    const unsigned count = 2 * std::max(1u, std::thread::hardware_concurrency());
    for (unsigned i = 0; i < count; ++i) {
      const pid_t pid = fork();
      if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGKILL);  // never left behind, even if the test is killed
        if (getppid() != parent) _exit(0);
        for (volatile uint64_t n = 0;; n = n + 1) {
        }
      }
      if (pid > 0) pids_.push_back(pid);
    }
  }
  BusyLoops(const BusyLoops&) = delete;
  BusyLoops& operator=(const BusyLoops&) = delete;
  ~BusyLoops() {
    for (const pid_t pid : pids_) kill(pid, SIGKILL);
    for (const pid_t pid : pids_) waitpid(pid, nullptr, 0);
  }
  size_t count() const { return pids_.size(); }

 private:
  std::vector<pid_t> pids_;
};

}  // namespace iapsim::bridge::testing
