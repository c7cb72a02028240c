#pragma once
// `iapsim run` as a child process, a few at a time: how a sweep's local pool (tools/sweep.h) and the flights
// of `iapsim regress` (tools/commands.h) fly their runs. Each run is a program of its own, with its own bus,
// signal handling and evaluation, so runs side by side share nothing but the machine's cores.

#include <sys/types.h>

#include <csignal>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace iapsim::tools {

struct ChildRun {
  std::string scenario;
  std::vector<std::string> overrides;  // each a --set KEY=VALUE
  std::filesystem::path dir;           // --out; the child's output goes to DIR/iapsim.log
};

struct ChildExit {
  int exit_code = -1;  // `iapsim run`'s (tools/commands.h); 128 + N when signal N killed it
  std::string reason;  // for a code other than 0: the log's error line, the signal, or why fork failed
  double wall_s = 0.0;
};

/// How many runs a local pool runs at a time: `asked`, or the machine's cores when it is 0.
int LocalJobs(int asked);

/// Starts `iapsim run` (beside this program) for `run`, its output in run.dir/iapsim.log (the folder must
/// exist). The child gets SIGINT, and so ends its graph cleanly, if this process dies. -1 (errno set) when
/// fork fails.
pid_t StartChildRun(const ChildRun& run);

/// Why a run failed, from the end of its output: `iapsim run`'s own error line if there is one, else the last
/// line.
std::string ReasonFromLog(const std::filesystem::path& log);

/// How a child that ran in `dir` ended, from its wait status.
ChildExit ChildExitOf(int wait_status, const std::filesystem::path& dir, double wall_s);

/// Runs `runs` in order, at most `jobs` at a time, calling `ended(i, exit)` on this thread as each ends, in
/// the order they end. Once `stop` is set (by a signal handler, or by `ended`) no other run starts and the
/// running ones get SIGINT (the terminal's Ctrl-C reaches them anyway; a kill of this process does not);
/// returns when every started run has ended.
void RunChildren(const std::vector<ChildRun>& runs, int jobs, volatile std::sig_atomic_t& stop,
                 const std::function<void(size_t, const ChildExit&)>& ended);

/// While it lives, SIGINT and SIGTERM set `raised` instead of ending the process (without SA_RESTART, so a
/// blocking waitpid returns to look at it); the previous handlers are restored at its end. One at a time.
class InterruptFlag {
 public:
  InterruptFlag();
  ~InterruptFlag();
  InterruptFlag(const InterruptFlag&) = delete;
  InterruptFlag& operator=(const InterruptFlag&) = delete;

  static volatile std::sig_atomic_t raised;

 private:
  struct sigaction previous_int_ {};
  struct sigaction previous_term_ {};
};

}  // namespace iapsim::tools
