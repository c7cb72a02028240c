// iapsim rl train: the seed's offline pipeline for the docking policy (§IV-E, Fig. 7), stage by stage into
// one folder, each stage resuming from what it left there.
//
//   DIR/expert/data.hdf5, summary.json      the expert's episodes (rl/dataset.h)
//   DIR/td3bc/checkpoint.pt                 learner, targets, optimisers, step (rl/td3bc.h)
//   DIR/td3bc/log.csv, curves.png           losses and evaluations per `eval_every` updates (Fig. 19(a))
//   DIR/td3bc/policy.pt                     the actor as TorchScript, for `iapsim rl eval --policy`
//   DIR/iql/...                             the same for IQL (rl/iql.h), the other offline learner
//   DIR/ppo/checkpoint.pt                   PPO from td3bc/ or iql/policy.pt (--offline; rl/ppo.h): networks,
//                                           σ, optimisers
//   DIR/ppo/log.csv, curves.png             rollouts and updates per iteration, evaluations every
//                                           `ppo_eval_every` iterations (Fig. 19(a))
//   DIR/ppo/policy.pt                       the deterministic actor as TorchScript
//   DIR/ppo/worker-R.log                    --ppo-workers N: the output of each worker this one started

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>

#include "rl/dataset.h"
#include "rl/evaluation.h"
#include "rl/iql.h"
#include "rl/ppo.h"
#include "rl/td3bc.h"
#include "rl/torchscript_policy.h"
#include "tools/plot_script.h"
#include "tools/rl_commands.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kPpoLogHeader =
    "iteration,env_steps,episodes,rollout_success_rate,rollout_return_mean,policy_loss,value_loss,approx_kl,"
    "anchor_kl,"
    "clip_fraction,explained_variance,std_mean,epochs,success_rate,docked_step_mean,return_mean,wall_s";

void ExpertStage(const RlTrainArgs& args, const fs::path& dir) {
  const fs::path data = dir / "data.hdf5";
  if (fs::exists(data)) {
    std::printf("expert: %s is there, kept\n", data.c_str());
    return;
  }
  RlEpisodeArgs expert = args.expert;
  expert.policy = "expert";
  const Clock::time_point start = Clock::now();
  const rl::EvaluationSummary summary = rl::Summarize(CollectDataset(expert, data.string()));
  std::ofstream(dir / "summary.json") << SummaryJson(summary).dump(2) << "\n";
  std::printf("expert: %d episodes, %lld transitions, %.1f %% docked (%.0f s) -> %s\n", summary.episodes,
              static_cast<long long>(summary.steps), 100.0 * summary.success_rate,
              std::chrono::duration<double>(Clock::now() - start).count(), data.c_str());
}

// Starts `log` afresh, or keeps its rows up to `step` (a resumed run drops what came after its checkpoint).
void StartLog(const fs::path& log, const char* header, int64_t step) {
  std::ifstream in(log);
  std::string line, kept = std::string(header) + "\n";
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    if (!line.empty() && std::stoll(line.substr(0, line.find(','))) <= step) kept += line + "\n";
  }
  in.close();
  std::ofstream(log) << kept;
}

// Flies the evaluation episodes (from the stream (seed + 1, e): the same starts every time) with a policy.
rl::EvaluationSummary Evaluate(const RlTrainArgs& args, const rl::DockingTaskConfig& task,
                               const std::string& policy) {
  return rl::Summarize(rl::RunEpisodes(
      task, [&](const rl::DockingEnv& env) { return rl::MakePolicy(policy, env); }, args.eval_episodes,
      args.expert.seed + 1, args.expert.threads));
}

// What each offline learner logs per row after its step, and how it is set up from the arguments.
std::vector<double> LossColumns(const rl::Td3BcLosses& l) {
  return {l.critic, l.actor, l.behaviour, l.q_mean};
}
std::vector<double> LossColumns(const rl::IqlLosses& l) {
  return {l.critic, l.value, l.actor, l.behaviour, l.q_mean, l.advantage_std};
}
struct Td3BcStageTraits {
  using Learner = rl::Td3Bc;
  static constexpr const char* kName = "td3bc";
  static constexpr const char* kTitle = "TD3-BC";
  static std::vector<std::string> Losses() {
    return {"critic_loss", "actor_loss", "behaviour_loss", "q_mean"};
  }
  static int64_t Steps(const RlTrainArgs& args) { return args.td3bc_steps; }
  static rl::Td3BcConfig Config(const RlTrainArgs& args) {
    rl::Td3BcConfig config;
    config.seed = args.expert.seed;  // one libtorch thread (rl/torch_networks.h); --threads flies evaluations
    config.alpha = args.td3bc_alpha;
    config.export_average = args.td3bc_policy == "average";
    return config;
  }
};
struct IqlStageTraits {
  using Learner = rl::Iql;
  static constexpr const char* kName = "iql";
  static constexpr const char* kTitle = "IQL";
  static std::vector<std::string> Losses() {
    return {"critic_loss", "value_loss", "actor_loss", "behaviour_loss", "q_mean", "advantage_std"};
  }
  static int64_t Steps(const RlTrainArgs& args) { return args.iql_steps; }
  static rl::IqlConfig Config(const RlTrainArgs& args) {
    rl::IqlConfig config;
    config.seed = args.expert.seed;  // one libtorch thread, as TD3-BC's
    config.expectile = args.iql_expectile;
    config.beta = args.iql_beta;
    config.export_average = args.iql_policy == "average";
    return config;
  }
};

// An offline learner (TD3-BC or IQL) on the expert's data set: updates in chunks of `eval_every`, after
// each an exported policy, an evaluation, a log row and a checkpoint.
template <class Traits>
void OfflineStage(const RlTrainArgs& args, const fs::path& dir, const fs::path& data_file) {
  const char* name = Traits::kName;
  if (!fs::exists(data_file)) {
    throw std::invalid_argument(data_file.string() + ": no expert data set; run --stage expert first");
  }
  const rl::Dataset data = rl::ReadDataset(data_file.string());
  const rl::DockingTaskConfig task = rl::ReadDockingTask(args.expert.task, args.expert.overrides);
  typename Traits::Learner learner(data, Traits::Config(args));
  const int64_t steps = Traits::Steps(args);
  const fs::path checkpoint = dir / "checkpoint.pt", log_file = dir / "log.csv", policy = dir / "policy.pt";
  if (fs::exists(checkpoint)) {
    learner.Load(checkpoint.string());
    std::printf("%s: resuming from %s at update %lld\n", name, checkpoint.c_str(),
                static_cast<long long>(learner.step()));
  }
  std::string header = "step";
  for (const std::string& column : Traits::Losses()) header += "," + column;
  StartLog(log_file, (header + ",success_rate,docked_step_mean,return_mean,wall_s").c_str(), learner.step());
  std::printf("%s: %lld transitions, %lld updates, evaluating %d episodes every %lld\n", name,
              static_cast<long long>(data.size()), static_cast<long long>(steps), args.eval_episodes,
              static_cast<long long>(args.eval_every));
  std::printf("  %8s", "update");
  for (const std::string& column : Traits::Losses()) {
    std::printf(" %14s", column.substr(0, column.find("_loss")).c_str());
  }
  std::printf(" %9s %9s %8s\n", "success", "docked", "wall");
  const Clock::time_point start = Clock::now();
  while (learner.step() < steps) {
    const int64_t chunk =
        std::min(args.eval_every - learner.step() % args.eval_every, steps - learner.step());
    std::vector<double> mean;
    for (int64_t k = 0; k < chunk; ++k) {
      const std::vector<double> columns = LossColumns(learner.Update());
      mean.resize(columns.size(), 0.0);
      for (size_t i = 0; i < columns.size(); ++i) mean[i] += columns[i] / chunk;
    }
    learner.ExportPolicy(policy.string());
    const rl::EvaluationSummary summary = Evaluate(args, task, policy.string());
    const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
    std::ofstream log(log_file, std::ios::app);
    log << learner.step();
    std::printf("  %8lld", static_cast<long long>(learner.step()));
    for (const double value : mean) {
      log << "," << value;
      std::printf(" %14.4g", value);
    }
    log << "," << summary.success_rate << "," << summary.docked_step_mean << "," << summary.return_mean << ","
        << wall_s << "\n";
    log.close();
    learner.Save(checkpoint.string());
    std::printf(" %8.0f%% %9.0f %7.0fs\n", 100.0 * summary.success_rate, summary.docked_step_mean, wall_s);
    std::fflush(stdout);
  }
  const bool plotted =
      learner.step() > 0 &&
      RunPlotScript(IAPSIM_PLOT_TRAINING, {log_file.string(), (dir / "curves.png").string(), Traits::kTitle});
  std::printf("%s: %s, %s%s\n", name, policy.c_str(), log_file.c_str(), plotted ? ", curves.png" : "");
}

// The workers after the first, started by it as this program with its own arguments, --stage ppo and their
// rank; each one's output in DIR/ppo/worker-R.log. They follow it if it dies (PR_SET_PDEATHSIG), and are
// stopped if it leaves early.
class LocalWorkers {
 public:
  LocalWorkers(const RlTrainArgs& args, const fs::path& dir, const std::string& rendezvous) {
    std::vector<std::string> common{"/proc/self/exe"};
    for (size_t i = 0; i < args.command_line.size(); ++i) {
      const std::string& a = args.command_line[i];
      if (a == "--stage") {
        ++i;  // and its value
      } else if (a.rfind("--stage=", 0) != 0) {
        common.push_back(a);
      }
    }
    common.insert(common.end(), {"--stage", "ppo", "--ppo-rendezvous", rendezvous});
    for (int rank = 1; rank < args.ppo_workers; ++rank) {
      std::vector<std::string> command = common;
      command.insert(command.end(), {"--ppo-rank", std::to_string(rank)});
      logs_.push_back((dir / ("worker-" + std::to_string(rank) + ".log")).string());
      std::vector<char*> argv;
      for (std::string& part : command) argv.push_back(part.data());
      argv.push_back(nullptr);
      const pid_t parent = getpid();
      const pid_t pid = fork();
      if (pid < 0) throw std::runtime_error("ppo: cannot start worker " + std::to_string(rank));
      if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGTERM);
        if (getppid() != parent) _exit(1);
        const int fd = open(logs_.back().c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
          dup2(fd, STDOUT_FILENO);
          dup2(fd, STDERR_FILENO);
          close(fd);
        }
        execv(argv[0], argv.data());
        _exit(127);
      }
      pids_.push_back(pid);
    }
    ended_.assign(pids_.size(), false);
    monitor_ = std::thread([this] { Monitor(); });
  }
  // Waits for each to end (one that fails ends this process, Monitor).
  void Wait() { monitor_.join(); }
  ~LocalWorkers() {
    // this worker's training failed, perhaps because Gloo saw a peer's death first ("Connection closed by
    // peer"): Monitor, which reaps a dead worker within 50 ms, gets the time to end the run naming it
    if (std::uncaught_exceptions() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(500));
    stop_ = true;
    if (monitor_.joinable()) monitor_.join();
    for (size_t i = 0; i < pids_.size(); ++i) {
      if (i < ended_.size() && ended_[i]) continue;
      kill(pids_[i], SIGTERM);
      waitpid(pids_[i], nullptr, 0);
    }
  }
  LocalWorkers(const LocalWorkers&) = delete;
  LocalWorkers& operator=(const LocalWorkers&) = delete;

 private:
  // Reaps the workers as they end. One that fails while this process trains would leave it waiting in a
  // collective for Gloo's timeout (600 s): the run ends at once instead, naming the worker's log (checkpoints
  // are written whole or not at all, and the other workers go with this process, PR_SET_PDEATHSIG).
  void Monitor() {
    size_t running = pids_.size();
    while (running > 0 && !stop_) {
      for (size_t i = 0; i < pids_.size(); ++i) {
        int status = 0;
        if (ended_[i] || waitpid(pids_[i], &status, WNOHANG) != pids_[i]) continue;
        ended_[i] = true;
        --running;
        if (WIFEXITED(status) && WEXITSTATUS(status) == 0) continue;
        const std::string how = WIFEXITED(status)
                                    ? "exited with status " + std::to_string(WEXITSTATUS(status))
                                    : "was killed by signal " + std::to_string(WTERMSIG(status));
        std::fprintf(stderr, "iapsim rl train: ppo: worker %zu %s; see %s\n", i + 1, how.c_str(),
                     logs_[i].c_str());
        std::_Exit(1);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }

  std::vector<pid_t> pids_;
  std::vector<std::string> logs_;
  std::vector<bool> ended_;
  std::atomic<bool> stop_{false};
  std::thread monitor_;
};

// Who this process is among PPO's workers: alone; the first of --ppo-workers N, which starts the others
// here; one of those (--ppo-rank); or task SLURM_PROCID of `srun --ntasks=N` (SLURM_STEP_NUM_TASKS = N),
// meeting the others through DIR/ppo/rendezvous-JOB.STEP. Gloo binds the address of the interface
// GLOO_SOCKET_IFNAME names (PyTorch's convention) or that of the host's name; 127.0.0.1 on one host.
// `start_others`: whether this process starts the others.
rl::PpoWorkers PpoWorkersOf(const RlTrainArgs& args, const fs::path& dir, bool* start_others) {
  *start_others = false;
  rl::PpoWorkers workers;
  workers.world = args.ppo_workers;
  workers.timeout_s = 600.0;  // the first worker evaluates and checkpoints while the others wait
  if (args.ppo_workers == 1) return workers;
  const char* step_tasks = std::getenv("SLURM_STEP_NUM_TASKS");
  const char* rank = std::getenv("SLURM_PROCID");
  if (args.ppo_rank == 0 && step_tasks && std::atoi(step_tasks) > 1) {
    if (std::atoi(step_tasks) != args.ppo_workers || !rank) {
      throw std::invalid_argument("--ppo-workers " + std::to_string(args.ppo_workers) + ": srun started " +
                                  step_tasks + " tasks; give it as many as workers");
    }
    const char* job = std::getenv("SLURM_JOB_ID");
    const char* step = std::getenv("SLURM_STEP_ID");
    if (!job || !step) {
      throw std::invalid_argument(
          "--ppo-workers under srun: SLURM_JOB_ID and SLURM_STEP_ID are not both set");
    }
    workers.rank = std::atoi(rank);
    workers.rendezvous_file = (dir / ("rendezvous-" + std::string(job) + "." + step)).string();
    if (const char* interface = std::getenv("GLOO_SOCKET_IFNAME")) workers.interface = interface;
    return workers;
  }
  workers.address = "127.0.0.1";
  workers.rank = args.ppo_rank;
  *start_others = args.ppo_rank == 0;
  workers.rendezvous_file = args.ppo_rank > 0
                                ? args.ppo_rendezvous
                                : (dir / ("rendezvous-" + std::to_string(getpid()) + "-" +
                                          std::to_string(Clock::now().time_since_epoch().count())))
                                      .string();
  return workers;
}

void PpoStage(const RlTrainArgs& args, const fs::path& dir, const fs::path& offline_dir) {
  const std::string initial = args.ppo_init.empty() ? (offline_dir / "policy.pt").string() : args.ppo_init;
  if (!fs::exists(initial)) {
    throw std::invalid_argument(initial + ": no policy to start PPO from; run --stage " + args.offline +
                                " first or pass --ppo-init");
  }
  const rl::DockingTaskConfig task = rl::ReadDockingTask(args.expert.task, args.expert.overrides);
  rl::PpoConfig config;
  config.envs = args.ppo_envs;
  config.rollout_steps = args.ppo_rollout_steps;
  config.minibatch = args.ppo_rollout_steps;
  config.actor_learning_rate = args.ppo_actor_learning_rate;
  config.initial_std = args.ppo_initial_std;
  config.value_warmup_iterations = args.ppo_value_warmup;
  config.discount = args.ppo_discount < 0.0 ? task.reward.discount : args.ppo_discount;
  config.anchor_coefficient = args.ppo_anchor;
  config.seed = args.expert.seed;
  config.threads = args.expert.threads;
  bool start_others = false;
  const rl::PpoWorkers workers = PpoWorkersOf(args, dir, &start_others);
  std::unique_ptr<LocalWorkers> started;
  if (start_others) started = std::make_unique<LocalWorkers>(args, dir, workers.rendezvous_file);
  rl::Ppo learner(task, config, initial, workers);  // the rendezvous file goes with the last worker
  const fs::path checkpoint = dir / "checkpoint.pt", log_file = dir / "log.csv", policy = dir / "policy.pt";
  if (fs::exists(checkpoint)) {
    learner.Load(checkpoint.string());
    if (workers.rank == 0) {
      std::printf("ppo: resuming from %s at iteration %lld\n", checkpoint.c_str(),
                  static_cast<long long>(learner.iteration()));
    }
  }
  if (workers.rank > 0) {  // the first worker logs, evaluates and checkpoints for all
    while (learner.iteration() < args.ppo_iterations) learner.Iterate();
    return;
  }
  StartLog(log_file, kPpoLogHeader, learner.iteration());
  std::printf(
      "ppo: from %s, %d worker%s x %d environments x %d steps per iteration, %lld iterations, evaluating %d "
      "episodes every %lld\n",
      initial.c_str(), workers.world, workers.world == 1 ? "" : "s", config.envs, config.rollout_steps,
      static_cast<long long>(args.ppo_iterations), args.eval_episodes,
      static_cast<long long>(args.ppo_eval_every));
  std::printf("  %9s %9s %9s %8s %6s %8s %6s %7s %8s %9s %7s\n", "iteration", "episodes", "rollout", "value",
              "expl.", "kl", "clip", "sigma", "success", "docked", "wall");
  const Clock::time_point start = Clock::now();
  while (learner.iteration() < args.ppo_iterations) {
    const rl::PpoStats stats = learner.Iterate();
    std::ofstream log(log_file, std::ios::app);
    log << stats.iteration << "," << stats.env_steps << "," << stats.episodes << ",";
    char rollout[16] = "        -";
    if (stats.episodes > 0) {  // no episode ended in the rollout: nothing to say about success
      const double rate = double(stats.successes) / stats.episodes;
      log << rate << "," << stats.return_mean;
      std::snprintf(rollout, sizeof rollout, "%8.0f%%", 100.0 * rate);
    } else {
      log << ",";
    }
    log << "," << stats.policy_loss << "," << stats.value_loss << "," << stats.approx_kl << ","
        << stats.anchor_kl << "," << stats.clip_fraction << "," << stats.explained_variance << ","
        << stats.std_mean << "," << stats.epochs << ",";
    std::string evaluated = "        -         -";
    if (stats.iteration % args.ppo_eval_every == 0 || stats.iteration == args.ppo_iterations) {
      learner.ExportPolicy(policy.string());
      const rl::EvaluationSummary summary = Evaluate(args, task, policy.string());
      log << summary.success_rate << "," << summary.docked_step_mean << "," << summary.return_mean;
      learner.Save(checkpoint.string());
      char text[64];
      std::snprintf(text, sizeof text, "%7.0f%% %9.0f", 100.0 * summary.success_rate,
                    summary.docked_step_mean);
      evaluated = text;
    } else {
      log << ",,";
    }
    const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
    log << "," << wall_s << "\n";
    std::printf("  %9lld %9d %s %8.3g %6.2f %8.3g %6.2f %7.3f %s %6.0fs\n",
                static_cast<long long>(stats.iteration), stats.episodes, rollout, stats.value_loss,
                stats.explained_variance, stats.approx_kl, stats.clip_fraction, stats.std_mean,
                evaluated.c_str(), wall_s);
    std::fflush(stdout);
  }
  if (started) started->Wait();
  const bool plotted =
      learner.iteration() > 0 &&
      RunPlotScript(IAPSIM_PLOT_TRAINING, {log_file.string(), (dir / "curves.png").string(), "PPO"});
  std::printf("ppo: %s, %s%s\n", policy.c_str(), log_file.c_str(), plotted ? ", curves.png" : "");
}

}  // namespace

int RlTrain(const RlTrainArgs& args) {
  return RunRlCommand("train", [&] {
    if (args.stage != "expert" && args.stage != "td3bc" && args.stage != "iql" && args.stage != "ppo" &&
        args.stage != "all") {
      throw std::invalid_argument("--stage: expected expert, td3bc, iql, ppo or all, got '" + args.stage +
                                  "'");
    }
    if (args.offline != "td3bc" && args.offline != "iql") {
      throw std::invalid_argument("--offline: expected td3bc or iql, got '" + args.offline + "'");
    }
    const char* step_tasks = std::getenv("SLURM_STEP_NUM_TASKS");
    if (args.ppo_workers > 1 && step_tasks && std::atoi(step_tasks) > 1 && args.stage != "ppo") {
      throw std::invalid_argument(
          "--stage " + args.stage + " under srun --ntasks=" + step_tasks +
          ": each task would run the expert and the offline learner; run those alone, then srun "
          "the PPO stage (--stage ppo)");
    }
    const fs::path out(args.out_dir);
    fs::create_directories(out / "expert");
    fs::create_directories(out / "ppo");
    const fs::path data = out / "expert" / "data.hdf5";
    if (args.stage == "expert" || args.stage == "all") ExpertStage(args, out / "expert");
    const bool all = args.stage == "all";
    if (args.stage == "td3bc" || (all && args.offline == "td3bc")) {
      fs::create_directories(out / "td3bc");
      OfflineStage<Td3BcStageTraits>(args, out / "td3bc", data);
    }
    if (args.stage == "iql" || (all && args.offline == "iql")) {
      fs::create_directories(out / "iql");
      OfflineStage<IqlStageTraits>(args, out / "iql", data);
    }
    if (args.stage == "ppo" || all) PpoStage(args, out / "ppo", out / args.offline);
    return 0;
  });
}

}  // namespace iapsim::tools
