// iapsim bench rl: how fast the air-docking task's environments step (issue 17's throughput target) over
// whole episodes flown by the expert, and where one thread's time goes.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "physics/physics_config.h"
#include "physics/random.h"
#include "rl/docking_expert.h"
#include "rl/vector_env.h"
#include "tools/commands.h"

namespace iapsim::tools {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

}  // namespace

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
    std::vector<std::unique_ptr<rl::DockingExpert>> experts;
    for (int i = 0; i < kEnvs; ++i) experts.push_back(std::make_unique<rl::DockingExpert>(envs.env(i)));
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
  auto expert = std::make_unique<rl::DockingExpert>(env);
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
