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

/// An episode's transitions, in D4RL's fields (rl/dataset.h): what was observed, done and given.
struct Transitions {
  std::vector<Observation> observations;
  std::vector<Action> actions;
  std::vector<double> rewards;
  std::vector<Observation> next_observations;
  std::vector<uint8_t> terminals;  // the episode's own end (success, crash, separation)
  std::vector<uint8_t> timeouts;   // truncated for time
  std::vector<uint8_t> successes;  // the step that made the episode a success
  size_t size() const { return rewards.size(); }
};

struct EpisodeResult {
  uint64_t seed = 0;
  Outcome outcome = Outcome::kRunning;
  int steps = 0;
  int docked_step = -1;  // the step at which the latch closed, or −1
  double episode_return = 0.0;
  std::vector<TracePoint> trace;  // where EpisodeOptions::trace asked for it
  Transitions transitions;        // where EpisodeOptions::transitions asked for them
};

struct EpisodeOptions {
  int first = 0;             // the first episode's index (its stream)
  int trace = 0;             // episodes traced, from the first
  bool transitions = false;  // keep every episode's transitions
  // σ of Gaussian noise added to every action the policy takes (then clipped to [−1, 1]), from each
  // episode's own stream: exploration around the expert for an offline data set, whose transitions hold
  // the actions as flown
  double action_noise = 0.0;
};

struct EvaluationSummary {
  int episodes = 0;
  int64_t steps = 0;  // control steps over all episodes
  int successes = 0, crashes = 0, separations = 0, timeouts = 0;
  double success_rate = 0.0;
  // over the successful episodes: the control step at which the latch closed
  double docked_step_mean = 0.0;
  double docked_step_p95 = 0.0;
  double return_mean = 0.0;
};

using PolicyFactory = std::function<std::unique_ptr<Policy>(const DockingEnv& env)>;

/// Runs episodes first .. first + episodes − 1 of `task` with a policy from `make_policy` per thread.
std::vector<EpisodeResult> RunEpisodes(const DockingTaskConfig& task, const PolicyFactory& make_policy,
                                       int episodes, uint64_t seed, int threads,
                                       const EpisodeOptions& options = EpisodeOptions());

EvaluationSummary Summarize(const std::vector<EpisodeResult>& results);

}  // namespace iapsim::rl
