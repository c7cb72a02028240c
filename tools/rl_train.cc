// iapsim rl train: the seed's offline pipeline for the docking policy (§IV-E, Fig. 7), stage by stage into
// one folder, each stage resuming from what it left there.
//
//   DIR/expert/data.hdf5, summary.json      the expert's episodes (rl/dataset.h)
//   DIR/td3bc/checkpoint.pt                 learner, targets, optimisers, step (rl/td3bc.h)
//   DIR/td3bc/log.csv, curves.png           losses and evaluations per `eval_every` updates (Fig. 19(a))
//   DIR/td3bc/policy.pt                     the actor as TorchScript, for `iapsim rl eval --policy`

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "rl/dataset.h"
#include "rl/evaluation.h"
#include "rl/td3bc.h"
#include "rl/torchscript_policy.h"
#include "tools/plot_script.h"
#include "tools/rl_commands.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kLogHeader =
    "step,critic_loss,actor_loss,behaviour_loss,q_mean,success_rate,docked_step_mean,return_mean,wall_s";

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

// The log's rows up to `step` (a resumed run drops what came after its checkpoint).
std::string LogUpTo(const fs::path& log, int64_t step) {
  std::ifstream in(log);
  std::string line, kept = std::string(kLogHeader) + "\n";
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    if (!line.empty() && std::stoll(line.substr(0, line.find(','))) <= step) kept += line + "\n";
  }
  return kept;
}

void Td3BcStage(const RlTrainArgs& args, const fs::path& dir, const fs::path& data_file) {
  if (!fs::exists(data_file)) {
    throw std::invalid_argument(data_file.string() + ": no expert data set; run --stage expert first");
  }
  const rl::Dataset data = rl::ReadDataset(data_file.string());
  const rl::DockingTaskConfig task = rl::ReadDockingTask(args.expert.task, args.expert.overrides);
  rl::Td3BcConfig config;
  config.seed = args.expert.seed;
  config.threads = args.expert.threads;
  config.alpha = args.td3bc_alpha;
  rl::Td3Bc learner(data, config);
  const fs::path checkpoint = dir / "checkpoint.pt", log_file = dir / "log.csv", policy = dir / "policy.pt";
  if (fs::exists(checkpoint)) {
    learner.Load(checkpoint.string());
    std::printf("td3bc: resuming from %s at update %lld\n", checkpoint.c_str(),
                static_cast<long long>(learner.step()));
  }
  {
    const std::string kept =
        fs::exists(log_file) ? LogUpTo(log_file, learner.step()) : std::string(kLogHeader) + "\n";
    std::ofstream(log_file) << kept;
  }
  std::printf("td3bc: %lld transitions, %lld updates, evaluating %d episodes every %lld\n",
              static_cast<long long>(data.size()), static_cast<long long>(args.td3bc_steps),
              args.eval_episodes, static_cast<long long>(args.eval_every));
  std::printf("  %8s %10s %10s %10s %9s %9s %8s\n", "update", "critic", "actor", "BC", "success", "docked",
              "wall");
  const Clock::time_point start = Clock::now();
  while (learner.step() < args.td3bc_steps) {
    const int64_t chunk =
        std::min(args.eval_every - learner.step() % args.eval_every, args.td3bc_steps - learner.step());
    rl::Td3BcLosses mean;
    for (int64_t k = 0; k < chunk; ++k) {
      const rl::Td3BcLosses losses = learner.Update();
      mean.critic += losses.critic / chunk;
      mean.actor += losses.actor / chunk;
      mean.behaviour += losses.behaviour / chunk;
      mean.q_mean += losses.q_mean / chunk;
    }
    learner.ExportPolicy(policy.string());
    const std::string policy_path = policy.string();
    const rl::EvaluationSummary summary = rl::Summarize(rl::RunEpisodes(
        task, [&](const rl::DockingEnv& env) { return rl::MakePolicy(policy_path, env); }, args.eval_episodes,
        args.expert.seed + 1, args.expert.threads));
    const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
    std::ofstream(log_file, std::ios::app)
        << learner.step() << "," << mean.critic << "," << mean.actor << "," << mean.behaviour << ","
        << mean.q_mean << "," << summary.success_rate << "," << summary.docked_step_mean << ","
        << summary.return_mean << "," << wall_s << "\n";
    learner.Save(checkpoint.string());
    std::printf("  %8lld %10.4g %10.4g %10.4g %8.0f%% %9.0f %7.0fs\n", static_cast<long long>(learner.step()),
                mean.critic, mean.actor, mean.behaviour, 100.0 * summary.success_rate,
                summary.docked_step_mean, wall_s);
    std::fflush(stdout);
  }
  const bool plotted =
      RunPlotScript(IAPSIM_PLOT_TRAINING, {log_file.string(), (dir / "curves.png").string(), "TD3-BC"});
  std::printf("td3bc: %s, %s%s\n", policy.c_str(), log_file.c_str(), plotted ? ", curves.png" : "");
}

}  // namespace

int RlTrain(const RlTrainArgs& args) {
  return RunRlCommand("train", [&] {
    if (args.stage != "expert" && args.stage != "td3bc" && args.stage != "all") {
      throw std::invalid_argument("--stage: expected expert, td3bc or all, got '" + args.stage + "'");
    }
    const fs::path out(args.out_dir);
    fs::create_directories(out / "expert");
    fs::create_directories(out / "td3bc");
    if (args.stage == "expert" || args.stage == "all") ExpertStage(args, out / "expert");
    if (args.stage == "td3bc" || args.stage == "all") {
      Td3BcStage(args, out / "td3bc", out / "expert" / "data.hdf5");
    }
    return 0;
  });
}

}  // namespace iapsim::tools
