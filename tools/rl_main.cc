// iapsim_rl: the commands of `iapsim rl` (tools/rl_commands.h), which `iapsim rl ...` execs.
//   iapsim rl eval [--policy expert|FILE.pt] [--episodes N] ... [--out DIR] [--graph]
//   iapsim rl collect FILE.hdf5 [--policy expert|FILE.pt] [--episodes N] ...
//   iapsim rl train DIR [--stage expert|td3bc|iql|ppo|all] [--offline td3bc|iql] [--td3bc-steps N]
//   [--ppo-iterations N] ...

#include <CLI/CLI.hpp>

#include "bridge/cli_usage.h"
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
  app.option_defaults()->always_capture_default();  // every --help shows each option's default

  RlEvalArgs eval;
  auto* eval_cmd =
      app.add_subcommand("eval", "fly randomised docking episodes with a policy, print its success");
  AddEpisodeOptions(eval_cmd, &eval.episodes);
  eval_cmd->add_option("--out", eval.out_dir, "write summary.json, episodes.csv and traces.csv here");
  eval_cmd
      ->add_option("--trace", eval.trace_episodes, "episodes traced step by step in traces.csv (default 10)")
      ->check(CLI::Range(0, 1000000));
  eval_cmd->add_flag(
      "--graph", eval.graph,
      "also fly each start as a run of the task's scenario, the policy in iapsim_policy, and compare "
      "(--threads runs side by side)");

  RlCollectArgs collect;
  auto* collect_cmd = app.add_subcommand(
      "collect", "fly episodes with a policy, write their transitions as HDF5 (D4RL layout)");
  collect_cmd->add_option("output", collect.output, "the data set file (.hdf5)")->required();
  AddEpisodeOptions(collect_cmd, &collect.episodes);
  collect_cmd
      ->add_option("--action-noise", collect.episodes.action_noise,
                   "sigma of Gaussian exploration noise on the policy's actions (default 0)")
      ->check(CLI::Range(0.0, 10.0));

  RlTrainArgs train;
  auto* train_cmd = app.add_subcommand(
      "train", "the expert's data set, then TD3-BC (or IQL) on it, then PPO from its actor");
  train_cmd->add_option("out_dir", train.out_dir, "where the stages write and resume from")->required();
  train_cmd->add_option("--stage", train.stage, "expert, td3bc, iql, ppo or all (default)")
      ->check(CLI::IsMember({"expert", "td3bc", "iql", "ppo", "all"}));
  train_cmd
      ->add_option("--offline", train.offline,
                   "the offline learner --stage all runs and PPO starts from: td3bc (default) or iql")
      ->check(CLI::IsMember({"td3bc", "iql"}));
  train_cmd->add_option("--task", train.expert.task, "task YAML (default configs/rl/docking.yaml)")
      ->check(CLI::ExistingFile);
  train_cmd->add_option("--set", train.expert.overrides, "override a task key: KEY=VALUE (repeatable)");
  train_cmd->add_option("--seed", train.expert.seed,
                        "data set episodes from (seed, e), evaluations from (seed + 1, e)");
  train_cmd->add_option("--threads", train.expert.threads, "threads (default 2)")->check(CLI::Range(1, 1024));
  train_cmd->add_option("--expert-episodes", train.expert.episodes, "episodes of the data set (default 200)")
      ->check(CLI::Range(1, 10000000));
  train_cmd
      ->add_option("--expert-action-noise", train.expert.action_noise,
                   "sigma of Gaussian exploration noise on the expert's actions in its data set (default 0)")
      ->check(CLI::Range(0.0, 10.0));
  train_cmd->add_option("--td3bc-steps", train.td3bc_steps, "TD3-BC updates in all (default 20000)")
      ->check(CLI::Range(int64_t{0}, int64_t{1} << 40));
  train_cmd
      ->add_option("--td3bc-alpha", train.td3bc_alpha, "TD3-BC's alpha (default 2.5; 0: behaviour cloning)")
      ->check(CLI::Range(0.0, 1e6));
  train_cmd
      ->add_option(
          "--td3bc-policy", train.td3bc_policy,
          "the policy TD3-BC exports and evaluates: average (the actor's Polyak average, default) or "
          "last (its last iterate)")
      ->check(CLI::IsMember({"average", "last"}));
  train_cmd->add_option("--iql-steps", train.iql_steps, "IQL updates in all (default 20000)")
      ->check(CLI::Range(int64_t{0}, int64_t{1} << 40));
  train_cmd->add_option("--iql-expectile", train.iql_expectile, "IQL's expectile tau")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1.0 - 1e-6));
  train_cmd
      ->add_option("--iql-beta", train.iql_beta, "IQL's inverse temperature on the advantage (0: cloning)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  train_cmd
      ->add_option("--iql-policy", train.iql_policy,
                   "the policy IQL exports and evaluates: average (default) or last")
      ->check(CLI::IsMember({"average", "last"}));
  train_cmd
      ->add_option("--eval-every", train.eval_every,
                   "updates between evaluations and checkpoints (default 2000)")
      ->check(CLI::Range(int64_t{1}, int64_t{1} << 40));
  train_cmd->add_option("--eval-episodes", train.eval_episodes, "episodes per evaluation (default 50)")
      ->check(CLI::Range(1, 1000000));
  train_cmd->add_option("--ppo-iterations", train.ppo_iterations, "PPO iterations in all (default 50)")
      ->check(CLI::Range(int64_t{0}, int64_t{1} << 40));
  train_cmd->add_option("--ppo-envs", train.ppo_envs, "PPO's environments per rollout")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  train_cmd
      ->add_option("--ppo-rollout-steps", train.ppo_rollout_steps,
                   "control steps per environment and PPO iteration")
      ->capture_default_str()
      ->check(CLI::Range(2, 10000000));
  train_cmd
      ->add_option("--ppo-eval-every", train.ppo_eval_every,
                   "PPO iterations between evaluations and checkpoints (default 5)")
      ->check(CLI::Range(int64_t{1}, int64_t{1} << 40));
  train_cmd->add_option("--ppo-actor-lr", train.ppo_actor_learning_rate, "PPO's actor learning rate")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  train_cmd
      ->add_option("--ppo-initial-std", train.ppo_initial_std,
                   "PPO's exploration sigma at the start, in actions of [-1, 1]")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 10.0));
  train_cmd
      ->add_option("--ppo-value-warmup", train.ppo_value_warmup,
                   "PPO iterations that fit the value network before the actor moves")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000000));
  train_cmd
      ->add_option("--ppo-discount", train.ppo_discount,
                   "PPO's discount gamma per control step (default: the task's reward.discount)")
      ->check(CLI::Range(0.0, 1.0));
  train_cmd
      ->add_option("--ppo-anchor", train.ppo_anchor,
                   "PPO's weight on the KL to its initial actor (0: plain PPO)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  train_cmd
      ->add_option("--ppo-init", train.ppo_init,
                   "the TorchScript policy PPO starts from (default DIR/td3bc/policy.pt, with --offline iql "
                   "DIR/iql/policy.pt)")
      ->check(CLI::ExistingFile);
  train_cmd
      ->add_option("--ppo-workers", train.ppo_workers,
                   "PPO workers, each with --ppo-envs environments, their gradients all-reduced (Gloo): this "
                   "process starts the others, or under `srun --ntasks=N` each task is one")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  // how the first worker starts the others
  train_cmd->add_option("--ppo-rank", train.ppo_rank)->group("")->check(CLI::Range(1, 4095));
  train_cmd->add_option("--ppo-rendezvous", train.ppo_rendezvous)->group("");

  eval_cmd->footer(
      "Examples:\n"
      "  iapsim rl eval --episodes 50\n"
      "  iapsim rl eval --policy runs/rl/ppo/policy.pt --out runs/rl/eval --graph");
  collect_cmd->footer(
      "Examples:\n"
      "  iapsim rl collect expert.hdf5 --episodes 200\n"
      "  iapsim rl collect noisy.hdf5 --action-noise 0.1 --seed 2");
  train_cmd->footer(
      "Examples:\n"
      "  iapsim rl train runs/rl --td3bc-alpha 0 --td3bc-steps 4000 --ppo-iterations 0\n"
      "  iapsim rl train runs/rl --expert-action-noise 0.14 --offline iql --iql-beta 0 --iql-steps 12000\n"
      "  iapsim rl train runs/rl --stage ppo --ppo-workers 2\n"
      "  srun --ntasks=4 iapsim rl train runs/rl --stage ppo --ppo-workers 4");
  iapsim::bridge::HideEmptyDefaults(app);
  app.footer("Examples:\n  iapsim rl eval\n  iapsim rl train runs/rl\n  iapsim rl COMMAND --help");
  if (argc > 1 && argv[1][0] != '-' && iapsim::bridge::AnswerUnknownSubcommand(app, "iapsim rl", argv[1]))
    return 2;
  train.command_line.assign(argv + 1, argv + argc);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return iapsim::bridge::AnswerParseError(app, e);
  }
  if (*eval_cmd) return RlEval(eval);
  if (*train_cmd) return RlTrain(train);
  return RlCollect(collect);
}
