// iapsim rl eval and iapsim bench rl: a policy's success on the air-docking task (seed §VI-H, Table XII,
// Fig. 19(b)), and how fast the task's environments step (issue 17's throughput target), both in process.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "bridge/config.h"
#include "physics/physics_config.h"
#include "physics/random.h"
#include "rl/dataset.h"
#include "rl/evaluation.h"
#include "rl/vector_env.h"
#include "tools/commands.h"

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

// Runs a command's body: a bad task or policy is exit 2, a file that cannot be written exit 1, each with the
// command's name and the reason.
template <typename Body>
int Guarded(const char* command, Body body) {
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

}  // namespace

int RlEval(const RlEvalArgs& eval) {
  const RlEpisodeArgs& args = eval.episodes;
  return Guarded("eval", [&] {
    const rl::DockingTaskConfig task = rl::ReadDockingTask(args.task, args.overrides);
    const auto make_policy = [&](const rl::DockingEnv& env) { return rl::MakePolicy(args.policy, env); };
    const Clock::time_point start = Clock::now();
    const std::vector<rl::EpisodeResult> results = rl::RunEpisodes(
        task, make_policy, args.episodes, args.seed, args.threads, {0, eval.trace_episodes, false});
    const double wall_s = Seconds(start);
    const rl::EvaluationSummary summary = rl::Summarize(results);
    int steps = 0;
    for (const rl::EpisodeResult& result : results) steps += result.steps;
    std::printf("policy %s on %s: %d episodes from seed %llu (%.1f s, %.0f control steps/s)\n",
                args.policy.c_str(), args.task.c_str(), summary.episodes,
                static_cast<unsigned long long>(args.seed), wall_s, steps / wall_s);
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
      nlohmann::json json = {{"policy", args.policy},
                             {"task", args.task},
                             {"episodes", summary.episodes},
                             {"seed", args.seed},
                             {"success_rate", summary.success_rate},
                             {"crashes", summary.crashes},
                             {"separations", summary.separations},
                             {"timeouts", summary.timeouts},
                             {"docked_step_mean", summary.docked_step_mean},
                             {"docked_step_p95", summary.docked_step_p95},
                             {"return_mean", summary.return_mean}};
      std::ofstream(eval.out_dir + "/summary.json") << json.dump(2) << "\n";
      std::printf("  written to   %s (summary.json, episodes.csv, traces.csv)\n", eval.out_dir.c_str());
    }
    return 0;
  });
}

int RlCollect(const RlCollectArgs& collect) {
  const RlEpisodeArgs& args = collect.episodes;
  return Guarded("collect", [&] {
    const rl::DockingTaskConfig task = rl::ReadDockingTask(args.task, args.overrides);
    const auto make_policy = [&](const rl::DockingEnv& env) { return rl::MakePolicy(args.policy, env); };
    if (std::filesystem::path(collect.output).has_parent_path()) {
      std::filesystem::create_directories(std::filesystem::path(collect.output).parent_path());
    }
    rl::DatasetWriter writer(collect.output);
    const Clock::time_point start = Clock::now();
    // in batches, so that memory holds a batch's transitions and not the whole set's
    const int batch = 16 * args.threads;
    std::vector<rl::EpisodeResult> episodes;
    for (int first = 0; first < args.episodes; first += batch) {
      std::vector<rl::EpisodeResult> results =
          rl::RunEpisodes(task, make_policy, std::min(batch, args.episodes - first), args.seed, args.threads,
                          {first, 0, true});
      for (rl::EpisodeResult& result : results) {
        writer.Append(result.transitions);
        result.transitions = rl::Transitions();
        episodes.push_back(std::move(result));
      }
    }
    writer.Close({args.task, task.scenario, args.policy, args.seed, args.episodes, task.control_rate_hz});
    const rl::EvaluationSummary summary = rl::Summarize(episodes);
    std::printf("%d episodes of %s with %s from seed %llu: %lld transitions in %.1f s\n", args.episodes,
                args.task.c_str(), args.policy.c_str(), static_cast<unsigned long long>(args.seed),
                static_cast<long long>(writer.size()), Seconds(start));
    std::printf("  success %.1f %% (crash %d, separation %d, timeout %d)\n", 100.0 * summary.success_rate,
                summary.crashes, summary.separations, summary.timeouts);
    std::printf("  written to %s (%.1f MiB, D4RL layout)\n", collect.output.c_str(),
                std::filesystem::file_size(collect.output) / 1048576.0);
    return 0;
  });
}

int BenchRl(const std::string& task_file, nlohmann::json* report) {
  const rl::DockingTaskConfig task = rl::ReadDockingTask(task_file);
  nlohmann::json& out = (*report)["rl"];
  std::printf("RL docking environment (%s): the expert flies whole episodes\n", task_file.c_str());

  // 1. Throughput: a vector of environments, the expert acting for each on the caller's thread.
  constexpr int kEnvs = 16;
  constexpr int kStepsPerEnv = 2000;  // one full-length episode's worth each
  std::printf("  %-9s %14s %12s %10s\n", "threads", "control st/s", "per thread", "episodes");
  for (const int threads : {1, 2}) {
    rl::VectorEnv envs(task, kEnvs, threads);
    std::vector<std::unique_ptr<rl::Policy>> experts;
    for (int i = 0; i < kEnvs; ++i) experts.push_back(rl::MakePolicy("expert", envs.env(i)));
    rl::RowMatrix actions(kEnvs, rl::kActionSize);
    const Clock::time_point start = Clock::now();
    envs.Reset(1);
    int episodes = 0;
    for (int k = 0; k < kStepsPerEnv; ++k) {
      for (int i = 0; i < kEnvs; ++i)
        actions.row(i) = experts[i]->Act(envs.observations().row(i).transpose());
      envs.Step(actions);
      for (int i = 0; i < kEnvs; ++i) {
        if (envs.terminated()[i] || envs.truncated()[i]) {
          experts[i]->Reset();
          ++episodes;
        }
      }
    }
    const double steps_per_s = kEnvs * kStepsPerEnv / Seconds(start);
    std::printf("  %-9d %14.0f %12.0f %10d\n", threads, steps_per_s, steps_per_s / threads, episodes);
    out["throughput"].push_back({{"threads", threads},
                                 {"envs", kEnvs},
                                 {"control_steps_per_s", steps_per_s},
                                 {"episodes_ended", episodes}});
  }

  // 2. Where a step's time goes, on one thread: the policy, the environment (observation, reward, resets)
  // and its physics, which a bare simulation replaying the same setpoints times, split into the steps with
  // a contact or a closed latch and those in the air.
  constexpr int kEpisodes = 8;
  rl::DockingEnv env(task);
  std::unique_ptr<rl::Policy> expert = rl::MakePolicy("expert", env);
  const physics::SimulationConfig scenario = physics::LoadScenarioPhysics(task.scenario).simulation;
  double policy_s = 0.0, env_s = 0.0, physics_air_s = 0.0, physics_contact_s = 0.0;
  int steps = 0, contact_steps = 0;
  for (int e = 0; e < kEpisodes; ++e) {
    Clock::time_point start = Clock::now();
    rl::Observation observation = env.Reset(physics::StreamSeed(2, e));
    env_s += Seconds(start);
    expert->Reset();
    physics::SimulationConfig world = scenario;
    for (int v = 0; v < env.simulation().vehicle_count(); ++v)
      world.vehicles[v] = env.simulation().vehicle(v);
    std::vector<rl::Action> actions;
    rl::StepResult result;
    while (!result.terminated && !result.truncated) {
      start = Clock::now();
      actions.push_back(expert->Act(observation));
      policy_s += Seconds(start);
      start = Clock::now();
      result = env.Step(actions.back(), &observation);
      env_s += Seconds(start);
    }
    physics::Simulation physics_alone(world);
    const int latch = physics_alone.FindLatch(task.latch);
    for (const rl::Action& action : actions) {
      start = Clock::now();
      for (int i = 0; i < 2; ++i) physics_alone.SetCommand(i, 0, env.Setpoint(i, action));
      bool touching = false;
      for (int k = 0; k < env.physics_substeps(); ++k) {
        physics_alone.Step();
        touching = touching || !physics_alone.world().contacts().empty();
      }
      touching = touching || physics_alone.latch_output(latch).latched;
      (touching ? physics_contact_s : physics_air_s) += Seconds(start);
      contact_steps += touching;
      ++steps;
    }
  }
  const double total_s = policy_s + env_s;
  const double physics_s = physics_air_s + physics_contact_s;
  std::printf("  one thread, %d episodes, %d control steps (%d with contact or latched):\n", kEpisodes, steps,
              contact_steps);
  std::printf("    policy (expert) %5.1f %%\n", 100.0 * policy_s / total_s);
  std::printf("    physics         %5.1f %%  (in contact or latched %.1f %%, in the air %.1f %%)\n",
              100.0 * physics_s / total_s, 100.0 * physics_contact_s / total_s,
              100.0 * physics_air_s / total_s);
  std::printf("    environment     %5.1f %%  (observation, noise, reward, resets)\n",
              100.0 * std::max(0.0, env_s - physics_s) / total_s);
  std::printf("    %.1f us a control step: %.1f us in the air, %.1f us in contact (physics only)\n",
              1e6 * total_s / steps, 1e6 * physics_air_s / std::max(steps - contact_steps, 1),
              1e6 * physics_contact_s / std::max(contact_steps, 1));
  out["breakdown"] = {{"episodes", kEpisodes},
                      {"control_steps", steps},
                      {"contact_steps", contact_steps},
                      {"policy_share", policy_s / total_s},
                      {"physics_share", physics_s / total_s},
                      {"physics_contact_share", physics_contact_s / total_s},
                      {"environment_share", std::max(0.0, env_s - physics_s) / total_s}};
  return 0;
}

}  // namespace iapsim::tools
