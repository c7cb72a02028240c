// IQL: on a data set whose answer is known in closed form, V learns the expectile of the returns over the
// data's actions and the actor moves toward the better action by exp(β A); a checkpoint resumes training
// exactly, a damaged one is a clear error, and the exported TorchScript policy acts as the learner.
#include "rl/iql.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "rl/torchscript_policy.h"
#include "tests/support/test_folder.h"

namespace iapsim::rl {
namespace {

// One state, two actions: every row ends its episode, action −0.5 pays 0 and +0.5 pays 1 (all twelve
// components), alternating.
Dataset TwoActions(int rows = 512) {
  Dataset data;
  data.observations = RowMatrixF::Zero(rows, kObservationSize);
  data.next_observations = RowMatrixF::Zero(rows, kObservationSize);
  data.actions = RowMatrixF::Constant(rows, kActionSize, -0.5f);
  data.rewards = Eigen::VectorXf::Zero(rows);
  for (int i = 1; i < rows; i += 2) {
    data.actions.row(i).setConstant(0.5f);
    data.rewards[i] = 1.0f;
  }
  data.terminals.assign(rows, 1);
  data.timeouts.assign(rows, 0);
  data.successes.assign(rows, 0);
  return data;
}

IqlConfig Small() {
  IqlConfig config;
  config.hidden = 64;
  config.batch = 64;
  config.normalize_rewards = false;
  config.export_average = false;
  return config;
}

// Q(s, ±0.5) = 0 and 1 (terminal rows); the 0.7-expectile of two equally likely values 0 and 1 is 0.7
// (τ (1 − v) = (1 − τ) v); the actor's optimum is the mean of the actions weighted by exp(β (Q − V)): with
// β = 3, (e^0.9 · 0.5 − e^−2.1 · 0.5) / (e^0.9 + e^−2.1) = 0.453, with β = 0 plain cloning's 0.
TEST(Iql, ValueIsTheExpectileAndTheActorFavoursTheBetterAction) {
  const Dataset data = TwoActions();
  const Observation state = Observation::Zero();
  for (const double beta : {3.0, 0.0}) {
    IqlConfig config = Small();
    config.beta = beta;
    config.learning_rate = 1e-3;  // converged within 400 updates
    config.tau = 0.05;
    Iql learner(data, config);
    IqlLosses last;
    for (int k = 0; k < 400; ++k) last = learner.UpdateOn((k % 4) * 64);
    const double expected = beta > 0.0 ? 0.453 : 0.0;
    std::printf("beta %.0f: V %.3f (0.7), action %.3f (%.3f), advantage std %.3f\n", beta,
                learner.Value(state), learner.Act(state).mean(), expected, last.advantage_std);
    EXPECT_NEAR(learner.Value(state), 0.7, 0.05);
    EXPECT_NEAR(learner.Act(state).mean(), expected, 0.05);
    EXPECT_NEAR(last.q_mean, 0.5, 0.05);
  }
}

TEST(Iql, RewardsAreScaledByTheRangeOfEpisodeReturns) {
  Dataset data = TwoActions(6);
  EXPECT_DOUBLE_EQ(EpisodeReturnRange(data), 1.0);
  data.terminals = {0, 0, 1, 0, 0, 0};  // episodes of rows 0-2 (return 1) and 3-5, cut by the data's end (2)
  EXPECT_DOUBLE_EQ(EpisodeReturnRange(data), 1.0);
  data.timeouts = {1, 0, 0, 0, 0, 0};  // 0 | 1 | 2
  EXPECT_DOUBLE_EQ(EpisodeReturnRange(data), 2.0);
  IqlConfig config = Small();
  config.batch = 4;
  config.normalize_rewards = true;
  EXPECT_DOUBLE_EQ(Iql(data, config).reward_scale(), 500.0);
  data.rewards.setZero();
  EXPECT_THROW(Iql(data, config), std::invalid_argument);
}

TEST(Iql, ACheckpointResumesTrainingExactly) {
  test_support::TestFolder folder("iql_checkpoint");
  const std::string path = (folder.path() / "checkpoint.pt").string();
  const Dataset data = TwoActions();
  Iql trained(data, Small());
  for (int k = 0; k < 21; ++k) trained.Update();
  trained.Save(path);
  Iql resumed(data, Small());
  resumed.Load(path);
  EXPECT_EQ(resumed.step(), 21);
  for (int k = 0; k < 6; ++k) {
    const IqlLosses a = trained.Update(), b = resumed.Update();
    EXPECT_EQ(a.critic, b.critic) << k;
    EXPECT_EQ(a.value, b.value) << k;
    EXPECT_EQ(a.actor, b.actor) << k;
  }
}

TEST(Iql, ADamagedOrMismatchedCheckpointIsAnErrorNamingTheFile) {
  test_support::TestFolder folder("iql_bad");
  const Dataset data = TwoActions();
  Iql learner(data, Small());
  const auto error_of = [&](const std::string& path) -> std::string {
    try {
      learner.Load(path);
    } catch (const std::runtime_error& error) {
      return error.what();
    }
    return "no error";
  };
  EXPECT_NE(error_of(folder.Write("text.pt", "no archive")).find("text.pt: not a IQL checkpoint"),
            std::string::npos);
  IqlConfig wider = Small();
  wider.hidden = 32;
  const std::string other = (folder.path() / "wider.pt").string();
  Iql(data, wider).Save(other);
  EXPECT_NE(error_of(other).find("wider.pt: not a IQL checkpoint of this shape"), std::string::npos)
      << error_of(other);
  IqlConfig bad = Small();
  bad.expectile = 1.0;
  EXPECT_THROW(Iql(data, bad), std::invalid_argument);
}

TEST(Iql, TheExportedPolicyActsAsTheLearner) {
  test_support::TestFolder folder("iql_export");
  const Dataset data = TwoActions();
  for (const bool average : {true, false}) {
    IqlConfig config = Small();
    config.export_average = average;
    Iql learner(data, config);
    for (int k = 0; k < 10; ++k) learner.Update();
    const std::string path = (folder.path() / "policy.pt").string();
    learner.ExportPolicy(path);
    TorchScriptPolicy policy(path);
    const Observation observation = Observation::Constant(0.1);
    EXPECT_LT((policy.Act(observation) - learner.Act(observation)).cwiseAbs().maxCoeff(), 1e-6) << average;
  }
}

}  // namespace
}  // namespace iapsim::rl
