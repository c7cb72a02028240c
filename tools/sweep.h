#pragma once
// `iapsim sweep SWEEP.yaml`: many runs of one scenario, over a grid and/or random draws of scenario keys and
// over seeds, each an `iapsim run` of its own (evaluated as that command evaluates it), run N at a time on
// this machine; then one table of every run's metrics and per-group statistics over the seeds.
//
//   name: spiral_gains                   # default: the file's name
//   scenario: ../scenarios/x.yaml        # relative to the sweep file
//   set: {duration_s: 5}                 # every run (dotted keys, as --set)
//   grid:                                # every combination, in this order (the last key varies fastest)
//     processes.control.params.kp: [1.0, 2.0, 3.0]
//   random:                              # `draws` draws of these keys (seeded: the same draws every time)
//     draws: 4
//     seed: 1
//     keys: {clock.step_s: {choice: [0.001, 0.002]}, processes.x.params.gain: {uniform: [0.95, 1.05]},
//            processes.x.params.offset_m: {normal: [0.0, 0.01]}}
//   seeds: [1, 2]                        # each point of the grid and draw, once per seed
//   metrics: [tracking.position_rmse_m.z] # the table's columns (default: every number of metrics.json but
//                                        # the per-process and loss counters)
//   jobs: 2                              # runs at a time (default: the machine's cores; --jobs wins)
//   keep_bags: true                      # false: a finished run's run.bag is deleted after its evaluation
//   slurm:                               # with --slurm: one job array, a task per run (flags win)
//     partition: batch                   # default: the cluster's
//     time: "00:30:00"                   # a run's time limit, as sbatch takes it; default: the partition's
//     cpus_per_run: 1
//     sbatch: [--qos=short]              # any other sbatch arguments
//
// A run's id is a hash of its settings (its swept values and seed): stable across invocations and sweep
// file edits, so `--resume` skips every run already finished (exit 0, or 3: completed with losses) and
// runs the rest again. A run that fails is reported with its exit code and the reason its log gives, never
// dropped. Out: DIR/runs/ID/ (the run, and iapsim.log: its output), DIR/results.{csv,md} (a row per run),
// DIR/summary.{csv,md} (a row per group: mean, p50, p95 of each metric over its seeds, and its failures),
// DIR/sweep.json (the expanded runs and their outcomes), DIR/plot_KEY.png (each metric against each swept
// key, tools/plot_sweep.py).
//
// With --slurm the runs are the tasks of one Slurm job array (tools/slurm.h) instead of a local pool: each
// task is `iapsim sweep-task DIR ID`, which runs the run as the pool does and records its outcome in
// DIR/runs/ID/sweep_run.json, so both give the same tables. DIR (and this program) must be on a file system
// the cluster's nodes share. The sweep waits for the array, reporting runs as they end; a task that ends
// without an outcome (time limit, node failure, scancel) is a failed run with the cluster's reason from
// DIR/slurm/JOB_TASK.out; Ctrl-C cancels the array.

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tools/slurm.h"

namespace iapsim::tools {

struct SweepRandomKey {
  std::string key;
  std::string distribution;          // uniform | normal | choice
  std::vector<double> parameters;    // uniform: lo, hi; normal: mean, sigma
  std::vector<std::string> choices;  // choice: the values, as written
};

struct SweepSpec {
  std::string file;  // the sweep file
  std::string name;
  std::string scenario;                                                // path as the process can open it
  std::vector<std::string> overrides;                                  // `set`
  std::vector<std::pair<std::string, std::vector<std::string>>> grid;  // key -> values (flow YAML), in order
  int draws = 0;
  uint64_t random_seed = 1;
  std::vector<SweepRandomKey> random;
  std::vector<uint64_t> seeds;       // empty: the scenario's own seed
  std::vector<std::string> metrics;  // JSON pointers into metrics.json
  int jobs = 0;                      // 0: not set
  bool keep_bags = true;
  SlurmOptions slurm;  // `slurm:` (its max_running: jobs)
};

/// Reads and checks a sweep file. Throws bridge::ConfigError naming the file, line and key.
SweepSpec ReadSweep(const std::string& path);

struct SweepRun {
  size_t index = 0;   // in expansion order
  std::string id;     // 12 hex digits of a hash of `values` and `seed`
  std::string group;  // the id of `values` alone: runs that differ only by seed
  std::vector<std::pair<std::string, std::string>> values;  // swept key -> value, grid keys then random ones
  std::optional<uint64_t> seed;
  std::vector<std::string> overrides;  // every --set of the run: the sweep's set, values, seed
  std::string dir;                     // its run directory, relative to the sweep's folder: runs/ID
};

/// The runs of a sweep: grid points (the last key fastest) x draws x seeds.
std::vector<SweepRun> ExpandSweep(const SweepSpec& spec);

struct SweepOutcome {
  bool done = false;               // the run was started and ended, in this invocation or an earlier one
  int exit_code = -1;              // `iapsim run`'s; -1: none (its Slurm task ended without one)
  std::string status = "pending";  // completed, completed_with_losses, failed, interrupted, ...
  std::string reason;              // why it did not finish
  double wall_s = 0.0;
  nlohmann::json metrics;  // its metrics.json, when it has one
  bool Finished() const { return done && (exit_code == 0 || exit_code == 3); }
};

struct SweepExecution {
  int jobs = 0;        // at a time: the local pool's size (0: the cores); on Slurm the array's %N (0: none)
  bool slurm = false;  // one Slurm job array instead of the local pool
  SlurmOptions slurm_options;
};

/// Runs `runs` of `spec` (each an `iapsim run` in DIR/RUN.dir) on the local pool or on Slurm, skipping those
/// DIR already holds finished, and records them in DIR/sweep.json (written first: the Slurm tasks read it);
/// returns every run's outcome in order. SIGINT/SIGTERM stop the runs cleanly and set `interrupted`;
/// `submitted` is false when sbatch refused the array (its message printed).
std::vector<SweepOutcome> RunSweep(const SweepSpec& spec, const std::vector<SweepRun>& runs,
                                   const std::filesystem::path& dir, const SweepExecution& how,
                                   bool* interrupted, bool* submitted);

struct SweepArgs {
  std::string file;
  std::string out_dir;                 // default: sweeps/NAME-UTCTIME
  int jobs = 0;                        // 0: the sweep file's, else the machine's cores
  bool resume = false;                 // out_dir exists: skip its finished runs
  bool list = false;                   // print the runs and exit
  std::vector<std::string> overrides;  // --set for every run, after the sweep's own
  bool slurm = false;                  // one Slurm job array instead of the local pool
  std::string partition, time;         // override the sweep's slurm: block
  int cpus_per_run = 0;                // 0: the sweep's
};

/// The whole command. Exit codes: 0 every run finished, 1 some failed (the tables say which and why), 2 a bad
/// sweep file or arguments, 130 interrupted (finished runs are kept for --resume).
int Sweep(const SweepArgs& args);

/// `iapsim sweep-task DIR ID`: run ID of the sweep in DIR (its sweep.json) in the foreground and record its
/// outcome, as the local pool does; what each task of a --slurm array runs. Exits with the run's exit code.
int SweepTask(const std::string& dir, const std::string& id);

}  // namespace iapsim::tools
