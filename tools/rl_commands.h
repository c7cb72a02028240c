#pragma once
// The commands of `iapsim rl`. They run in their own program, iapsim_rl (tools/rl_main.cc), which
// `iapsim rl ...` becomes: they may fly learned policies, and loading libtorch costs a process 2 s that no
// other `iapsim` command should pay. Each returns the process exit code.

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "rl/evaluation.h"
#include "rl/iql.h"
#include "rl/ppo.h"

namespace iapsim::tools {

/// What `iapsim rl eval` and `collect` fly: episodes e = 0 .. episodes − 1 of a task, each from the stream
/// (seed, e), with a policy.
struct RlEpisodeArgs {
  std::string task = "configs/rl/docking.yaml";
  std::string policy = "expert";  // or a TorchScript file (*.pt)
  int episodes = 200;
  uint64_t seed = 1;
  int threads = 2;
  std::vector<std::string> overrides;  // --set KEY=VALUE on the task
  double action_noise = 0.0;           // collect: σ of exploration noise on the policy's actions
};

struct RlEvalArgs {
  RlEpisodeArgs episodes;
  std::string out_dir;      // summary.json, episodes.csv, traces.csv; empty: print only
  int trace_episodes = 10;  // episodes whose d_xz, d_y and f_y are written step by step
  bool graph = false;       // also fly each episode as a run of the task's scenario (iapsim_policy)
};
/// Flies `episodes` randomised docking episodes with a policy and prints its success rate and steps to
/// dock (seed §VI-H); with `graph`, flies the same starts again as runs of the task's scenario, the policy
/// in the iapsim_policy process, and prints both. Exit 2 on a bad task or policy, 1 when a run fails.
int RlEval(const RlEvalArgs& args);

struct RlCollectArgs {
  RlEpisodeArgs episodes;
  std::string output;  // the HDF5 data set
};
/// Flies `episodes` episodes with a policy and writes their transitions as an HDF5 data set in D4RL's layout
/// (rl/dataset.h). Exit 2 on a bad task or policy, 1 when the file cannot be written.
int RlCollect(const RlCollectArgs& args);

// Shared by the commands:

/// Runs a command's body: a bad task, policy or argument is exit 2, a file that cannot be read or written
/// exit 1, each printed with the command's name and the reason.
int RunRlCommand(const char* command, const std::function<int()>& body);

/// An evaluation's figures, as summary.json holds them.
nlohmann::json SummaryJson(const rl::EvaluationSummary& summary);

/// Flies the episodes of `args` and writes their transitions to `output` (rl/dataset.h); returns the
/// episodes without their transitions.
std::vector<rl::EpisodeResult> CollectDataset(const RlEpisodeArgs& args, const std::string& output);

struct RlTrainArgs {
  std::string
      out_dir;  // expert/ (data.hdf5, summary.json), td3bc/, iql/ and ppo/ (checkpoint, log, policy, curves)
  std::string stage = "all";      // expert, td3bc, iql, ppo or all
  std::string offline = "td3bc";  // the offline learner `all` runs and PPO starts from: td3bc or iql
  RlEpisodeArgs expert;           // the task, seed, threads, and how many expert episodes make the data set
  int64_t td3bc_steps = 20000;
  double td3bc_alpha = 2.5;  // TD3-BC's α: the Q term's weight against behaviour cloning (0: pure cloning)
  std::string td3bc_policy = "average";  // the actor's Polyak average, or "last": its last iterate
  int64_t iql_steps = 20000;
  double iql_expectile = rl::IqlConfig().expectile;
  double iql_beta = rl::IqlConfig().beta;  // the advantage's inverse temperature
  std::string iql_policy = "average";
  int64_t eval_every = 2000;  // updates between evaluations (and checkpoints)
  int eval_episodes = 50;     // from the stream (seed + 1, e): the same starts at every evaluation
  int64_t ppo_iterations = 50;
  int ppo_envs = rl::PpoConfig().envs;
  int ppo_rollout_steps = rl::PpoConfig().rollout_steps;  // per environment and iteration
  int64_t ppo_eval_every = 5;                             // iterations between evaluations (and checkpoints)
  std::string ppo_init;  // the policy PPO starts from; empty: <offline>/policy.pt
  double ppo_actor_learning_rate = rl::PpoConfig().actor_learning_rate;
  double ppo_initial_std = rl::PpoConfig().initial_std;
  int ppo_value_warmup = rl::PpoConfig().value_warmup_iterations;
  double ppo_discount = -1.0;  // < 0: the task's reward.discount, which potential shaping needs
  double ppo_anchor = rl::PpoConfig().anchor_coefficient;
  // PPO's data-parallel workers (rl/ppo.h): this process and ppo_workers - 1 it starts, or the tasks of
  // `srun --ntasks=N`; each rolls out ppo_envs environments
  int ppo_workers = 1;
  int ppo_rank = 0;                       // a worker the first one started (hidden options)
  std::string ppo_rendezvous;             // ... and its rendezvous file
  std::vector<std::string> command_line;  // this process's arguments after the program, for the workers
};
/// The seed's offline-to-online pipeline (§IV-E, Fig. 7): the expert's data set, then TD3-BC (or IQL) on it,
/// then PPO from that actor, each evaluated and checkpointed as it goes; a stage whose output exists resumes
/// (expert: kept; TD3-BC, IQL and PPO: from their checkpoints). Each learner writes a CSV log, curves (PNG)
/// and its policy as TorchScript. Exit 2 on bad input.
int RlTrain(const RlTrainArgs& args);

}  // namespace iapsim::tools
