// iapsim_rl: the commands of `iapsim rl` (tools/rl_commands.h), which `iapsim rl ...` execs.
//   iapsim rl eval [--policy expert|FILE.pt] [--episodes N] ... [--out DIR]
//   iapsim rl collect FILE.hdf5 [--policy expert|FILE.pt] [--episodes N] ...

#include <CLI/CLI.hpp>

#include "tools/rl_commands.h"

namespace {

// The options `iapsim rl eval` and `collect` share.
void AddEpisodeOptions(CLI::App* command, iapsim::tools::RlEpisodeArgs* args) {
  command->add_option("--task", args->task, "task YAML (default configs/rl/docking.yaml)")
      ->check(CLI::ExistingFile);
  command->add_option("--policy", args->policy, "expert (default) or a TorchScript policy (FILE.pt)");
  command->add_option("--episodes", args->episodes, "episodes (default 200)")->check(CLI::Range(1, 10000000));
  command->add_option("--seed", args->seed, "episode e starts from the stream (seed, e) (default 1)");
  command->add_option("--threads", args->threads, "threads (default 2)")->check(CLI::Range(1, 1024));
  command->add_option("--set", args->overrides, "override a task key: KEY=VALUE (repeatable)");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace iapsim::tools;
  CLI::App app("iapsim rl: the air-docking learning task (seed section VI-H)", "iapsim rl");
  app.require_subcommand(1);

  RlEvalArgs eval;
  auto* eval_cmd =
      app.add_subcommand("eval", "fly randomised docking episodes with a policy, print its success");
  AddEpisodeOptions(eval_cmd, &eval.episodes);
  eval_cmd->add_option("--out", eval.out_dir, "write summary.json, episodes.csv and traces.csv here");
  eval_cmd
      ->add_option("--trace", eval.trace_episodes, "episodes traced step by step in traces.csv (default 10)")
      ->check(CLI::Range(0, 1000000));

  RlCollectArgs collect;
  auto* collect_cmd = app.add_subcommand(
      "collect", "fly episodes with a policy, write their transitions as HDF5 (D4RL layout)");
  collect_cmd->add_option("output", collect.output, "the data set file (.hdf5)")->required();
  AddEpisodeOptions(collect_cmd, &collect.episodes);

  CLI11_PARSE(app, argc, argv);
  if (*eval_cmd) return RlEval(eval);
  return RlCollect(collect);
}
