// iapsim rl eval and collect (in the iapsim_rl program, tools/rl_commands.h): a policy's success on the
// air-docking task (seed §VI-H, Table XII, Fig. 19(b)) and its episodes as a data set, in process.

#include "tools/rl_commands.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "bridge/config.h"
#include "physics/physics_config.h"
#include "rl/dataset.h"
#include "rl/evaluation.h"
#include "rl/torchscript_policy.h"
#include "tools/plot_script.h"

namespace iapsim::tools {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

void WriteEpisodes(const std::vector<rl::EpisodeResult>& results, const std::string& out_dir) {
  std::filesystem::create_directories(out_dir);
  std::ofstream episodes(out_dir + "/episodes.csv");
  episodes << "episode,seed,outcome,steps,docked_step,return\n";
  std::ofstream traces(out_dir + "/traces.csv");
  traces << "episode,step,t_s,radial_error_m,axial_error_m,contact_force_y_N,latched\n";
  for (size_t e = 0; e < results.size(); ++e) {
    const rl::EpisodeResult& result = results[e];
    episodes << e << "," << result.seed << "," << rl::OutcomeName(result.outcome) << "," << result.steps
             << "," << result.docked_step << "," << result.episode_return << "\n";
    for (size_t k = 0; k < result.trace.size(); ++k) {
      const rl::TracePoint& point = result.trace[k];
      traces << e << "," << k + 1 << "," << (k + 1) * 0.005 << "," << point.radial_error_m << ","
             << point.axial_error_m << "," << point.contact_force_y_N << "," << int(point.latched) << "\n";
    }
  }
}

}  // namespace

nlohmann::json SummaryJson(const rl::EvaluationSummary& summary) {
  return {{"episodes", summary.episodes},
          {"success_rate", summary.success_rate},
          {"crashes", summary.crashes},
          {"separations", summary.separations},
          {"timeouts", summary.timeouts},
          {"docked_step_mean", summary.docked_step_mean},
          {"docked_step_p95", summary.docked_step_p95},
          {"return_mean", summary.return_mean}};
}

int RunRlCommand(const char* command, const std::function<int()>& body) {
  try {
    return body();
  } catch (const bridge::ConfigError& error) {
    std::fprintf(stderr, "iapsim rl %s: %s\n", command, error.what());
    return 2;
  } catch (const std::invalid_argument& error) {
    std::fprintf(stderr, "iapsim rl %s: %s\n", command, error.what());
    return 2;
  } catch (const std::runtime_error& error) {
    std::fprintf(stderr, "iapsim rl %s: %s\n", command, error.what());
    return 1;
  }
}

std::vector<rl::EpisodeResult> CollectDataset(const RlEpisodeArgs& args, const std::string& output) {
  const rl::DockingTaskConfig task = rl::ReadDockingTask(args.task, args.overrides);
  const auto make_policy = [&](const rl::DockingEnv& env) { return rl::MakePolicy(args.policy, env); };
  if (std::filesystem::path(output).has_parent_path()) {
    std::filesystem::create_directories(std::filesystem::path(output).parent_path());
  }
  rl::DatasetWriter writer(output);
  // in batches, so that memory holds a batch's transitions and not the whole set's
  const int batch = 16 * args.threads;
  std::vector<rl::EpisodeResult> episodes;
  for (int first = 0; first < args.episodes; first += batch) {
    std::vector<rl::EpisodeResult> results =
        rl::RunEpisodes(task, make_policy, std::min(batch, args.episodes - first), args.seed, args.threads,
                        {first, 0, true, args.action_noise});
    for (rl::EpisodeResult& result : results) {
      writer.Append(result.transitions);
      result.transitions = rl::Transitions();
      episodes.push_back(std::move(result));
    }
  }
  writer.Close({args.task, task.scenario, args.policy, args.seed, args.episodes, task.control_rate_hz,
                args.action_noise});
  return episodes;
}

int RlEval(const RlEvalArgs& eval) {
  const RlEpisodeArgs& args = eval.episodes;
  return RunRlCommand("eval", [&] {
    const rl::DockingTaskConfig task = rl::ReadDockingTask(args.task, args.overrides);
    const auto make_policy = [&](const rl::DockingEnv& env) { return rl::MakePolicy(args.policy, env); };
    const Clock::time_point start = Clock::now();
    const std::vector<rl::EpisodeResult> results = rl::RunEpisodes(
        task, make_policy, args.episodes, args.seed, args.threads, {0, eval.trace_episodes, false});
    const double wall_s = Seconds(start);
    const rl::EvaluationSummary summary = rl::Summarize(results);
    std::printf("policy %s on %s: %d episodes from seed %llu (%.1f s, %.0f control steps/s)\n",
                args.policy.c_str(), args.task.c_str(), summary.episodes,
                static_cast<unsigned long long>(args.seed), wall_s, summary.steps / wall_s);
    std::printf("  success      %5.1f %%  (%d; crash %d, separation %d, timeout %d)\n",
                100.0 * summary.success_rate, summary.successes, summary.crashes, summary.separations,
                summary.timeouts);
    if (summary.successes > 0) {
      std::printf("  docked at    step %.0f mean, %.0f p95 (%.2f s, %.2f s at %.0f Hz)\n",
                  summary.docked_step_mean, summary.docked_step_p95,
                  summary.docked_step_mean / task.control_rate_hz,
                  summary.docked_step_p95 / task.control_rate_hz, task.control_rate_hz);
    }
    std::printf("  return       %.1f mean\n", summary.return_mean);
    if (!eval.out_dir.empty()) {
      WriteEpisodes(results, eval.out_dir);
      nlohmann::json json = SummaryJson(summary);
      json["policy"] = args.policy;
      json["task"] = args.task;
      json["seed"] = args.seed;
      std::ofstream(eval.out_dir + "/summary.json") << json.dump(2) << "\n";
      const bool plotted =
          RunPlotScript(IAPSIM_PLOT_DOCKING, {eval.out_dir, args.policy + " on " + args.task});
      std::printf("  written to   %s (summary.json, episodes.csv, traces.csv%s)\n", eval.out_dir.c_str(),
                  plotted ? ", docking.png" : "");
    }
    return 0;
  });
}

int RlCollect(const RlCollectArgs& collect) {
  const RlEpisodeArgs& args = collect.episodes;
  return RunRlCommand("collect", [&] {
    const Clock::time_point start = Clock::now();
    const rl::EvaluationSummary summary = rl::Summarize(CollectDataset(args, collect.output));
    std::printf("%d episodes of %s with %s from seed %llu: %lld transitions in %.1f s\n", args.episodes,
                args.task.c_str(), args.policy.c_str(), static_cast<unsigned long long>(args.seed),
                static_cast<long long>(summary.steps), Seconds(start));
    std::printf("  success %.1f %% (crash %d, separation %d, timeout %d)\n", 100.0 * summary.success_rate,
                summary.crashes, summary.separations, summary.timeouts);
    std::printf("  written to %s (%.1f MiB, D4RL layout)\n", collect.output.c_str(),
                std::filesystem::file_size(collect.output) / 1048576.0);
    return 0;
  });
}

}  // namespace iapsim::tools
