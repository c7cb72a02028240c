// Evaluating policies on the docking task: the same results on any number of threads, the summary's
// figures on hand-made episodes, and a failing policy as an exception, not a crash.
#include "rl/evaluation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "rl/docking_expert.h"
#include "rl/docking_task.h"

namespace iapsim::rl {
namespace {

DockingTaskConfig ShortTask() {
  return ReadDockingTask(std::string(IAPSIM_SOURCE_DIR) + "/configs/rl/docking.yaml",
                         {"termination.max_steps=60"});
}

TEST(RunEpisodes, GiveTheSameEpisodesOnAnyNumberOfThreads) {
  const PolicyFactory expert = [](const DockingEnv& env) { return std::make_unique<DockingExpert>(env); };
  const std::vector<EpisodeResult> one = RunEpisodes(ShortTask(), expert, 5, 3, 1, {0, 2, false});
  const std::vector<EpisodeResult> two = RunEpisodes(ShortTask(), expert, 5, 3, 2, {0, 2, false});
  ASSERT_EQ(one.size(), 5u);
  for (size_t e = 0; e < one.size(); ++e) {
    EXPECT_EQ(one[e].seed, two[e].seed);
    EXPECT_EQ(one[e].steps, 60);  // 0.3 s: too short to dock
    EXPECT_EQ(one[e].outcome, Outcome::kTimeout);
    EXPECT_EQ(one[e].episode_return, two[e].episode_return);
    EXPECT_EQ(one[e].trace.size(), e < 2 ? 60u : 0u);
  }
  EXPECT_NE(one[0].episode_return, one[1].episode_return);  // different starts
  EXPECT_EQ(one[1].trace.back().axial_error_m, two[1].trace.back().axial_error_m);
}

// Exploration noise: the actions flown and kept differ from the expert's by about σ, clipped to [−1, 1],
// and repeat for the same seed.
TEST(RunEpisodes, ActionNoiseExploresAroundThePolicyAndRepeats) {
  const PolicyFactory expert = [](const DockingEnv& env) { return std::make_unique<DockingExpert>(env); };
  const EpisodeOptions noisy{0, 0, true, 0.1};
  const std::vector<EpisodeResult> one = RunEpisodes(ShortTask(), expert, 2, 3, 1, noisy);
  const std::vector<EpisodeResult> two = RunEpisodes(ShortTask(), expert, 2, 3, 2, noisy);
  const std::vector<EpisodeResult> clean = RunEpisodes(ShortTask(), expert, 2, 3, 1, {0, 0, true});
  // the expert acting on the noisy run's observations: what it would have done
  DockingEnv env(ShortTask());
  DockingExpert replay(env);
  double sum_squares = 0.0;
  int count = 0;
  for (int e = 0; e < 2; ++e) {
    const Transitions& t = one[e].transitions;
    ASSERT_EQ(t.size(), two[e].transitions.size());
    replay.Reset();
    for (size_t k = 0; k < t.size(); ++k) {
      EXPECT_EQ(t.actions[k], two[e].transitions.actions[k]);
      EXPECT_LE(t.actions[k].cwiseAbs().maxCoeff(), 1.0);
      const Action deviation = t.actions[k] - replay.Act(t.observations[k]);
      sum_squares += deviation.squaredNorm();
      count += kActionSize;
    }
  }
  EXPECT_NEAR(std::sqrt(sum_squares / count), 0.1, 0.005);  // 1440 draws: σ within 5 %
  EXPECT_NE(one[0].transitions.actions[5], clean[0].transitions.actions[5]);
}

// A policy that fails in a worker thread: the evaluation throws its exception on the caller's thread.
TEST(RunEpisodes, APolicysFailureIsAnExceptionOfTheCaller) {
  struct NotFinite : Policy {
    void Reset() override {}
    Action Act(const Observation&) override { return Action::Constant(std::nan("")); }
  };
  const PolicyFactory broken = [](const DockingEnv&) { return std::make_unique<NotFinite>(); };
  EXPECT_THROW(RunEpisodes(ShortTask(), broken, 4, 1, 2), std::invalid_argument);
}

TEST(Summarize, CountsOutcomesAndTakesTheDockingStepsOfTheSuccesses) {
  std::vector<EpisodeResult> results(4);
  const Outcome outcomes[4] = {Outcome::kSuccess, Outcome::kSuccess, Outcome::kCrash, Outcome::kTimeout};
  const int docked[4] = {700, 900, 400, -1};
  for (int e = 0; e < 4; ++e) {
    results[e].outcome = outcomes[e];
    results[e].docked_step = docked[e];
    results[e].episode_return = 10.0 * e;
  }
  const EvaluationSummary summary = Summarize(results);
  EXPECT_EQ(summary.successes, 2);
  EXPECT_EQ(summary.crashes, 1);
  EXPECT_EQ(summary.timeouts, 1);
  EXPECT_DOUBLE_EQ(summary.success_rate, 0.5);
  EXPECT_DOUBLE_EQ(summary.docked_step_mean, 800.0);  // the crash's latch does not count
  EXPECT_DOUBLE_EQ(summary.docked_step_p95, 900.0);   // nearest rank: the 2nd of 2
  EXPECT_DOUBLE_EQ(summary.return_mean, 15.0);
}

}  // namespace
}  // namespace iapsim::rl
