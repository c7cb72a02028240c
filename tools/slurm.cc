#include "tools/slurm.h"

#include <fstream>

#include "tools/batch.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;

std::string Trimmed(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  return text;
}

// `text` as one bash word
std::string ShellQuoted(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

std::string SubmitArray(const fs::path& script, const std::string& job_name, const SlurmOptions& options,
                        const std::vector<std::string>& command, const std::vector<std::string>& task_args,
                        const fs::path& output_dir) {
  if (task_args.empty()) throw SlurmError("no tasks to submit");
  // on the command line rather than as #SBATCH lines: sbatch does not unquote those, and paths may hold
  // spaces
  std::vector<std::string> sbatch = {
      "sbatch",
      "--parsable",
      "--job-name=" + job_name,
      "--array=0-" + std::to_string(task_args.size() - 1) +
          (options.max_running > 0 ? "%" + std::to_string(options.max_running) : ""),
      "--cpus-per-task=" + std::to_string(options.cpus_per_task),
      "--output=" + (output_dir / "%A_%a.out").string()};
  if (!options.partition.empty()) sbatch.push_back("--partition=" + options.partition);
  if (!options.time.empty()) sbatch.push_back("--time=" + options.time);
  sbatch.insert(sbatch.end(), options.sbatch_args.begin(), options.sbatch_args.end());
  sbatch.push_back(script.string());

  std::string line;
  for (const std::string& a : sbatch) line += (line.empty() ? "" : " ") + ShellQuoted(a);
  std::ofstream out(script);
  out << "#!/bin/bash\n# " << task_args.size() << " tasks; submitted by iapsim as:\n#   " << line
      << "\n# task i runs the command with tasks[i]\ntasks=(";
  for (const std::string& a : task_args) out << "\n  " << ShellQuoted(a);
  out << "\n)\nexec";
  for (const std::string& a : command) out << " " << ShellQuoted(a);
  out << " \"${tasks[$SLURM_ARRAY_TASK_ID]}\"\n";
  out.close();
  if (!out) throw SlurmError("cannot write " + script.string());
  fs::permissions(script, fs::perms::owner_exec, fs::perm_options::add);

  const CommandResult result = RunCapturing(sbatch);
  const std::string output = Trimmed(result.output);
  if (result.exit_code != 0) {
    throw SlurmError("sbatch failed (exit " + std::to_string(result.exit_code) + "): " + output);
  }
  // --parsable: "JOBID" or "JOBID;CLUSTER", possibly after warnings on lines of their own
  std::string job =
      output.substr(output.find_last_of('\n') == std::string::npos ? 0 : output.find_last_of('\n') + 1);
  job = job.substr(0, job.find(';'));
  if (job.empty() || job.find_first_not_of("0123456789") != std::string::npos) {
    throw SlurmError("sbatch answered '" + output + "', not a job id");
  }
  return job;
}

SlurmJobState QueryArray(const std::string& job_id, std::string* error) {
  const CommandResult result = RunCapturing({"squeue", "--noheader", "--jobs=" + job_id, "--format=%i"});
  if (result.exit_code == 0)
    return Trimmed(result.output).empty() ? SlurmJobState::kEnded : SlurmJobState::kActive;
  // a job that ended long enough ago (MinJobAge) is no longer known
  if (result.output.find("Invalid job id") != std::string::npos) return SlurmJobState::kEnded;
  if (error) *error = Trimmed(result.output);
  return SlurmJobState::kUnreachable;
}

void InterruptArray(const std::string& job_id) {
  RunCapturing({"scancel", "--state=PENDING", job_id});
  RunCapturing({"scancel", "--batch", "--signal=INT", job_id});
}

void CancelArray(const std::string& job_id) { RunCapturing({"scancel", job_id}); }

fs::path TaskOutput(const fs::path& output_dir, const std::string& job_id, size_t task) {
  return output_dir / (job_id + "_" + std::to_string(task) + ".out");
}

}  // namespace iapsim::tools
