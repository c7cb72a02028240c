#pragma once
// Evaluating a policy on the docking task (seed §VI-H, Fig. 19, Table XII): whole episodes from seeded
// random starts, run in parallel, each episode's outcome and its docking errors over time. Episode e starts
// from physics::StreamSeed(seed, e), so the results are the same for any thread count.

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "rl/docking_env.h"
#include "rl/policy.h"

namespace iapsim::rl {

/// One control step of an episode's trace (Fig. 19(b)): the latch's errors and the contact force.
struct TracePoint {
  double radial_error_m = 0.0;  // d_xz
  double axial_error_m = 0.0;   // d_y
  double contact_force_y_N = 0.0;
  bool latched = false;
};

struct EpisodeResult {
  uint64_t seed = 0;
  Outcome outcome = Outcome::kRunning;
  int steps = 0;
  int docked_step = -1;  // the step at which the latch closed, or −1
  double episode_return = 0.0;
  std::vector<TracePoint> trace;  // for the first `trace_episodes` episodes only
};

struct EvaluationSummary {
  int episodes = 0;
  int successes = 0, crashes = 0, separations = 0, timeouts = 0;
  double success_rate = 0.0;
  // over the successful episodes: the control step at which the latch closed
  double docked_step_mean = 0.0;
  double docked_step_p95 = 0.0;
  double return_mean = 0.0;
};

using PolicyFactory = std::function<std::unique_ptr<Policy>(const DockingEnv& env)>;

/// Runs `episodes` episodes of `task` with a policy from `make_policy` per thread.
std::vector<EpisodeResult> RunEpisodes(const DockingTaskConfig& task, const PolicyFactory& make_policy,
                                       int episodes, uint64_t seed, int threads, int trace_episodes = 0);

EvaluationSummary Summarize(const std::vector<EpisodeResult>& results);

}  // namespace iapsim::rl
