#include "rl/evaluation.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <random>
#include <stdexcept>
#include <string>

#include "physics/random.h"
#include "sensors/gaussian.h"

namespace iapsim::rl {
namespace {

void RunEpisode(DockingEnv& env, Policy& policy, uint64_t seed, bool trace, const EpisodeOptions& options,
                EpisodeResult* result) {
  const bool keep_transitions = options.transitions;
  result->seed = seed;
  Observation observation = env.Reset(seed);
  policy.Reset();
  // the exploration noise's own stream, next to the environment's
  std::mt19937_64 noise_random(physics::StreamSeed(seed, 1));
  StepResult step;
  Transitions& transitions = result->transitions;
  while (!step.terminated && !step.truncated) {
    Action action = policy.Act(observation);
    if (options.action_noise > 0.0) {
      for (int i = 0; i < kActionSize; ++i)
        action[i] += options.action_noise * sensors::StandardNormal(noise_random);
      action = action.cwiseMax(-1.0).cwiseMin(1.0);
    }
    if (keep_transitions) {
      transitions.observations.push_back(observation);
      transitions.actions.push_back(action);
    }
    step = env.Step(action, &observation);
    result->episode_return += step.reward;
    if (keep_transitions) {
      transitions.rewards.push_back(step.reward);
      transitions.next_observations.push_back(observation);
      transitions.terminals.push_back(step.terminated);
      transitions.timeouts.push_back(step.truncated);
      transitions.successes.push_back(step.info.outcome == Outcome::kSuccess);
    }
    if (trace) {
      result->trace.push_back({step.info.radial_error_m, step.info.axial_error_m, step.info.contact_force_y_N,
                               step.info.latched});
    }
  }
  result->outcome = step.info.outcome;
  result->steps = step.info.step;
  result->docked_step = step.info.docked_step;
}

}  // namespace

std::vector<EpisodeResult> RunEpisodes(const DockingTaskConfig& task, const PolicyFactory& make_policy,
                                       int episodes, uint64_t seed, int threads,
                                       const EpisodeOptions& options) {
  if (episodes < 1)
    throw std::invalid_argument("episodes must be at least 1, got " + std::to_string(episodes));
  if (threads < 1) throw std::invalid_argument("threads must be at least 1, got " + std::to_string(threads));
  std::vector<EpisodeResult> results(episodes);
  // an environment and a policy per thread, built before the threads start: a bad task or policy is
  // one exception on the caller's thread
  std::vector<std::unique_ptr<DockingEnv>> envs;
  std::vector<std::unique_ptr<Policy>> policies;
  for (int t = 0; t < threads; ++t) {
    envs.push_back(std::make_unique<DockingEnv>(task));
    policies.push_back(make_policy(*envs.back()));
  }
  // an exception must not leave an OpenMP region (it would terminate the program): the first is kept and
  // rethrown once every thread is done
  std::exception_ptr failure;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
  for (int e = 0; e < episodes; ++e) {
    try {
      RunEpisode(*envs[omp_get_thread_num()], *policies[omp_get_thread_num()],
                 physics::StreamSeed(seed, options.first + e), e < options.trace, options, &results[e]);
    } catch (...) {
#pragma omp critical(iapsim_rl_episode_failure)
      if (!failure) failure = std::current_exception();
    }
  }
  if (failure) std::rethrow_exception(failure);
  return results;
}

EvaluationSummary Summarize(const std::vector<EpisodeResult>& results) {
  EvaluationSummary summary;
  summary.episodes = static_cast<int>(results.size());
  std::vector<double> docked;
  for (const EpisodeResult& result : results) {
    summary.steps += result.steps;
    summary.return_mean += result.episode_return / std::max<size_t>(results.size(), 1);
    switch (result.outcome) {
      case Outcome::kSuccess:
        ++summary.successes;
        docked.push_back(result.docked_step);
        break;
      case Outcome::kCrash:
        ++summary.crashes;
        break;
      case Outcome::kSeparation:
        ++summary.separations;
        break;
      case Outcome::kTimeout:
      case Outcome::kRunning:
        ++summary.timeouts;
        break;
    }
  }
  if (summary.episodes > 0) summary.success_rate = static_cast<double>(summary.successes) / summary.episodes;
  if (!docked.empty()) {
    std::sort(docked.begin(), docked.end());
    for (const double step : docked) summary.docked_step_mean += step / docked.size();
    // the nearest-rank 95th percentile
    const size_t rank = static_cast<size_t>(std::ceil(0.95 * docked.size()));
    summary.docked_step_p95 = docked[std::max<size_t>(rank, 1) - 1];
  }
  return summary;
}

}  // namespace iapsim::rl
