#pragma once
// Starts a scenario's process graph, supervises it and leaves a complete run directory.
//
// A crashed process (any exit before the end, or a signal), a hung one (no heartbeat within its
// hang_timeout_s) or one that reports an error ends the run: every other process is told to stop, then
// SIGTERM, then SIGKILL, so that the run is over within about a second and nothing is left behind; the
// recorder is signalled only if it has not closed its bag 10 s after the others exited, and a killed
// recorder's bag is reindexed. Children also get SIGTERM if the launcher itself dies (PR_SET_PDEATHSIG).
//
// After the run, the launcher counts what each process missed of what the others published (see
// CountLosses in launcher.cc); a run that lost messages exits 3 and says which.

#include <string>
#include <vector>

#include "bridge/scenario.h"

namespace iapsim::bridge {

struct LaunchOptions {
  std::string scenario_path;
  std::vector<std::string> overrides;  // "key.path=value"
  std::string out_dir;                 // empty: runs/<name>-<UTC time>
  std::string bin_dir;                 // where process executables live
  bool progress = false;  // progress on stderr: a line redrawn on a terminal, else a plain line every 5 s
  // validate the scenario and every process's params (each process's --check), then return without a run
  // directory or a process started
  bool check_only = false;
};

struct LaunchResult {
  // 0 ok, 1 a process failed, 2 bad configuration, 3 completed but messages were lost (the run directory is
  // complete; metrics.json says which, per process and topic), 130 interrupted
  int exit_code = 0;
  std::string run_dir;  // empty when nothing was started
  std::string message;  // why it failed
};

LaunchResult Launch(const LaunchOptions& options);

/// The current UTC time as YYYYMMDD-HHMMSS (run folder names).
std::string UtcStamp();

/// Directory holding the running executable (where sibling process executables are found).
std::string ExecutableDir();

}  // namespace iapsim::bridge
