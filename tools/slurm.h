#pragma once
// Slurm job arrays through Slurm's own commands (sbatch, squeue, scancel of Debian's slurm-client): what
// `iapsim sweep --slurm` needs to submit its runs, follow them and cancel them. The commands, not libslurm:
// their interface is the one Slurm keeps stable across versions and sites, and a user can replay each one
// (the batch script is written beside the runs). tools/slurm_local_cluster.sh brings up a one-node cluster.

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace iapsim::tools {

struct SlurmError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SlurmOptions {
  std::string partition;  // empty: the cluster's default
  std::string time;       // a task's time limit as sbatch takes it ("30", "01:00:00"); empty: the partition's
  int cpus_per_task = 1;  // --cpus-per-task
  int max_running = 0;    // the array's %N: tasks at a time (0: as many as Slurm gives)
  std::vector<std::string> sbatch_args;  // anything else, each one sbatch argument ("--qos=short")
};

/// Writes `script`, a bash batch script whose task i runs `command` followed by `task_args[i]`
/// (#SBATCH lines for `options`, the job name, and each task's output in `output_dir`/JOB_TASK.out), and
/// submits it as one job array. Returns the job id. Throws SlurmError with sbatch's own message.
std::string SubmitArray(const std::filesystem::path& script, const std::string& job_name,
                        const SlurmOptions& options, const std::vector<std::string>& command,
                        const std::vector<std::string>& task_args, const std::filesystem::path& output_dir);

enum class SlurmJobState {
  kActive,      // some task is pending or running
  kEnded,       // none is: every task ended (or the job is no longer known)
  kUnreachable  // squeue failed: the controller does not answer
};

/// Where job array `job_id` stands, from squeue; `error` gets squeue's message when it fails.
SlurmJobState QueryArray(const std::string& job_id, std::string* error);

/// Stops job array `job_id` the way Ctrl-C stops a local run: its pending tasks are cancelled and each
/// running task's batch process (and only it) gets SIGINT, so that the task ends its run cleanly. (A plain
/// scancel, or the time limit, sends SIGTERM to every process of a task at once.)
void InterruptArray(const std::string& job_id);

/// scancel of the whole array: its running tasks' processes get SIGTERM, then SIGKILL after KillWait.
void CancelArray(const std::string& job_id);

/// The cluster's output file of task `task` of `job_id` in `output_dir` (SubmitArray's pattern).
std::filesystem::path TaskOutput(const std::filesystem::path& output_dir, const std::string& job_id,
                                 size_t task);

}  // namespace iapsim::tools
