// iapsim rl eval and collect (in the iapsim_rl program, tools/rl_commands.h): a policy's success on the
// air-docking task (seed §VI-H, Table XII, Fig. 19(b)) and its episodes as a data set, in process.

#include "tools/rl_commands.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <thread>

#include "bridge/config.h"
#include "bridge/launcher.h"
#include "physics/physics_config.h"
#include "physics/random.h"
#include "rl/dataset.h"
#include "rl/evaluation.h"
#include "rl/torchscript_policy.h"
#include "tools/plot_script.h"

extern char** environ;

namespace iapsim::tools {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

// episode,seed,outcome,steps,docked_step[,return]: an episode flown in the graph has no return (the
// process does not see the latch's errors the reward needs)
void WriteOutcomes(const std::vector<rl::EpisodeResult>& results, const std::string& path, bool with_return) {
  std::ofstream episodes(path);
  episodes << "episode,seed,outcome,steps,docked_step" << (with_return ? ",return" : "") << "\n";
  for (size_t e = 0; e < results.size(); ++e) {
    const rl::EpisodeResult& result = results[e];
    episodes << e << "," << result.seed << "," << rl::OutcomeName(result.outcome) << "," << result.steps
             << "," << result.docked_step;
    if (with_return) episodes << "," << result.episode_return;
    episodes << "\n";
  }
}

void WriteEpisodes(const std::vector<rl::EpisodeResult>& results, const std::string& out_dir) {
  std::filesystem::create_directories(out_dir);
  WriteOutcomes(results, out_dir + "/episodes.csv", true);
  std::ofstream traces(out_dir + "/traces.csv");
  traces << "episode,step,t_s,radial_error_m,axial_error_m,contact_force_y_N,latched\n";
  for (size_t e = 0; e < results.size(); ++e) {
    const rl::EpisodeResult& result = results[e];
    for (size_t k = 0; k < result.trace.size(); ++k) {
      const rl::TracePoint& point = result.trace[k];
      traces << e << "," << k + 1 << "," << (k + 1) * 0.005 << "," << point.radial_error_m << ","
             << point.axial_error_m << "," << point.contact_force_y_N << "," << int(point.latched) << "\n";
    }
  }
}

void PrintSummary(const rl::EvaluationSummary& summary, double control_rate_hz) {
  std::printf("  success      %5.1f %%  (%d; crash %d, separation %d, timeout %d)\n",
              100.0 * summary.success_rate, summary.successes, summary.crashes, summary.separations,
              summary.timeouts);
  if (summary.successes > 0) {
    std::printf("  docked at    step %.0f mean, %.0f p95 (%.2f s, %.2f s at %.0f Hz)\n",
                summary.docked_step_mean, summary.docked_step_p95, summary.docked_step_mean / control_rate_hz,
                summary.docked_step_p95 / control_rate_hz, control_rate_hz);
  }
}

rl::Outcome OutcomeNamed(const std::string& name) {
  for (const rl::Outcome outcome :
       {rl::Outcome::kSuccess, rl::Outcome::kCrash, rl::Outcome::kSeparation, rl::Outcome::kTimeout}) {
    if (name == rl::OutcomeName(outcome)) return outcome;
  }
  return rl::Outcome::kRunning;
}

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

std::string Vector(const Eigen::Vector3d& v, double scale = 1.0) {
  return "[" + Number(scale * v.x()) + ", " + Number(scale * v.y()) + ", " + Number(scale * v.z()) + "]";
}

// Runs `iapsim run SCENARIO --out OUT_DIR --set ...` and waits for it; its terminal output goes to
// OUT_DIR/run.out. A child `iapsim run` rather than bridge::Launch in this process, so that runs can go side
// by side: each run owns its signal handling and its processes, and Ctrl-C reaches every run in the
// terminal's process group, each stopping its own graph. Throws std::runtime_error with the run's last words.
void RunScenario(const std::string& scenario, const std::vector<std::string>& overrides,
                 const std::filesystem::path& out_dir) {
  std::filesystem::create_directories(out_dir);
  const std::string program = bridge::ExecutableDir() + "/iapsim";
  const std::string output = (out_dir / "run.out").string();
  std::vector<std::string> words = {program, "run", scenario, "--out", out_dir.string()};
  for (const std::string& assignment : overrides) words.insert(words.end(), {"--set", assignment});
  std::vector<char*> argv;
  for (std::string& word : words) argv.push_back(word.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, output.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw std::runtime_error("cannot start " + program + ": " + std::strerror(spawned));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  std::ifstream in(output);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  throw std::runtime_error("iapsim run " +
                           (WIFSIGNALED(status)
                                ? "was killed by signal " + std::to_string(WTERMSIG(status))
                                : "exited with status " + std::to_string(WEXITSTATUS(status))) +
                           (last.empty() ? "" : ": " + last) + " (" + output + ")");
}

// The episodes flown again as runs of the task's scenario: each run starts A and B where the environment
// starts episode e (its stream (seed, e)), the policy flies in iapsim_policy, and the run's report says how
// the episode ended. Run e's folder is runs_dir/e. `args.threads` runs go side by side; each is lockstep and
// seeded, so the results do not depend on how many.
std::vector<rl::EpisodeResult> RunGraphEpisodes(const RlEpisodeArgs& args, const rl::DockingTaskConfig& task,
                                                const std::filesystem::path& runs_dir) {
  namespace fs = std::filesystem;
  rl::DockingEnv env(task);
  const std::string policy = args.policy == "expert" ? args.policy : fs::absolute(args.policy).string();
  constexpr double kRadToDeg = 180.0 / M_PI;
  std::vector<std::vector<std::string>> runs(args.episodes);
  for (int e = 0; e < args.episodes; ++e) {
    env.Reset(physics::StreamSeed(args.seed, e));
    std::vector<std::string>& overrides = runs[e];
    overrides = task.scenario_overrides;
    for (int i = 0; i < 2; ++i) {
      const physics::VehicleSpec& start = env.start(i);
      const std::string entry =
          "processes.physics.params.vehicles." + std::to_string(env.vehicle_index(i)) + ".";
      overrides.push_back(entry + "position_m=" + Vector(start.p_WP_m));
      overrides.push_back(entry + "roll_deg=" + Number(start.roll_rad * kRadToDeg));
      overrides.push_back(entry + "pitch_deg=" + Number(start.pitch_rad * kRadToDeg));
      overrides.push_back(entry + "yaw_deg=" + Number(start.yaw_rad * kRadToDeg));
      overrides.push_back(entry + "velocity_mps=" + Vector(start.v_WP_W_mps));
      overrides.push_back(entry + "angular_velocity_deg_s=" + Vector(start.w_WP_W_radps, kRadToDeg));
    }
    overrides.push_back("processes.policy.params.task=" + fs::absolute(task.file).string());
    overrides.push_back("processes.policy.params.policy=" + policy);
    // the task's own --set, as a list of strings (JSON is YAML's flow style)
    overrides.push_back("processes.policy.params.task_set=" + nlohmann::json(args.overrides).dump());
    overrides.push_back("duration_s=" + Number(task.termination.max_steps / task.control_rate_hz));
    overrides.push_back("seed=" + std::to_string(physics::StreamSeed(args.seed, e)));
    overrides.push_back("recording.enabled=false");
  }

  std::vector<rl::EpisodeResult> results(args.episodes);
  std::atomic<int> next{0};
  std::mutex mutex;  // guards done and failure
  int done = 0;
  std::string failure;
  const auto work = [&] {
    for (int e = next++; e < args.episodes; e = next++) {
      const fs::path out_dir = runs_dir / std::to_string(e);
      try {
        RunScenario(fs::absolute(task.scenario).string(), runs[e], out_dir);
        const nlohmann::json report =
            nlohmann::json::parse(std::ifstream(out_dir / "metrics.json"))["processes"]["policy"]["process"];
        rl::EpisodeResult& result = results[e];
        result.seed = physics::StreamSeed(args.seed, e);
        result.outcome = OutcomeNamed(report.value("outcome", ""));
        result.steps = report.value("outcome_step", report.value("control_steps", 0));
        result.docked_step = report.value("docked_step", -1);
      } catch (const std::exception& error) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (failure.empty()) failure = "episode " + std::to_string(e) + " in the graph: " + error.what();
        next = args.episodes;  // start no more runs
        return;
      }
      const std::lock_guard<std::mutex> lock(mutex);
      std::fprintf(stderr, "\r  graph: %d of %d episodes", ++done, args.episodes);
    }
  };
  std::vector<std::thread> workers;
  for (int t = 0; t < std::min(args.threads, args.episodes); ++t) workers.emplace_back(work);
  for (std::thread& worker : workers) worker.join();
  std::fprintf(stderr, "\n");
  if (!failure.empty()) throw std::runtime_error(failure);
  return results;
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
    PrintSummary(summary, task.control_rate_hz);
    std::printf("  return       %.1f mean\n", summary.return_mean);
    std::optional<rl::EvaluationSummary> graph;
    if (eval.graph) {
      namespace fs = std::filesystem;
      const Clock::time_point graph_start = Clock::now();
      const bool keep = !eval.out_dir.empty();
      const fs::path runs_dir = keep ? fs::path(eval.out_dir) / "graph"
                                     : fs::temp_directory_path() / ("iapsim_rl_graph_" + bridge::UtcStamp() +
                                                                    "_" + std::to_string(::getpid()));
      // the runs' folders go with the command unless --out keeps them, whatever ends it
      const std::unique_ptr<const fs::path, void (*)(const fs::path*)> temporary(
          keep ? nullptr : &runs_dir, [](const fs::path* path) { fs::remove_all(*path); });
      const std::vector<rl::EpisodeResult> graph_results = RunGraphEpisodes(args, task, runs_dir);
      graph = rl::Summarize(graph_results);
      std::printf("the same starts as runs of %s, the policy in iapsim_policy (%.1f s):\n",
                  task.scenario.c_str(), Seconds(graph_start));
      PrintSummary(*graph, task.control_rate_hz);
      int same = 0;
      for (size_t e = 0; e < results.size(); ++e) same += results[e].outcome == graph_results[e].outcome;
      std::printf("  difference   %+.1f points; %d of %d episodes end alike\n",
                  100.0 * (graph->success_rate - summary.success_rate), same, summary.episodes);
      if (keep) WriteOutcomes(graph_results, eval.out_dir + "/graph_episodes.csv", false);
    }
    if (!eval.out_dir.empty()) {
      WriteEpisodes(results, eval.out_dir);
      nlohmann::json json = SummaryJson(summary);
      json["policy"] = args.policy;
      json["task"] = args.task;
      json["seed"] = args.seed;
      if (graph) {
        json["graph"] = SummaryJson(*graph);
        json["graph"].erase("return_mean");
      }
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
