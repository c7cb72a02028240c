// PPO: GAE on hand-made rollouts, updates that fit one fixed rollout, a start that is exactly the initial
// policy, checkpoints that resume exactly, and clear errors for a bad initial policy or checkpoint.
#include "rl/ppo.h"

#include <gtest/gtest.h>

#include <cmath>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <thread>
#include <vector>

#include "rl/torch_networks.h"
#include "rl/torchscript_policy.h"
#include "tests/support/test_folder.h"

namespace iapsim::rl {
namespace {

DockingTaskConfig ShortTask() {
  // 50-step episodes: a 64-step rollout ends each by truncation and starts the next
  return ReadDockingTask(std::string(IAPSIM_SOURCE_DIR) + "/configs/rl/docking.yaml",
                         {"termination.max_steps=50"});
}

// A small actor as TD3-BC would export it: random weights, an identity normalisation.
std::string InitialPolicy(const test_support::TestFolder& folder) {
  torch::manual_seed(5);
  const std::string path = (folder.path() / "initial.pt").string();
  ExportActor(path, Mlp(kObservationSize, 32, kActionSize), torch::zeros({1, kObservationSize}),
              torch::ones({1, kObservationSize}));
  return path;
}

PpoConfig Small() {
  PpoConfig config;
  config.envs = 2;
  config.rollout_steps = 64;
  config.minibatch = 64;
  config.epochs = 2;
  config.value_hidden = 32;
  config.value_warmup_iterations = 1;
  return config;
}

// Two environments, three steps, γ = 0.5, λ = 1 (GAE is then the discounted return minus the value):
// environment 0 ends at step 1, so its steps 0 and 1 see nothing of step 2; environment 1 runs on and is
// bootstrapped with its last value.
TEST(Ppo, GeneralizedAdvantagesStopAtEpisodeEndsAndBootstrapTheRest) {
  const std::vector<float> rewards = {1, 2, 3, 4, 5, 6};
  const std::vector<float> values = {0.5, 1, 0, 0, 0.25, 2};
  const std::vector<float> ended = {0, 0, 1, 0, 0, 0};
  const std::vector<float> advantages = GeneralizedAdvantages(rewards, values, ended, {10, 8}, 0.5, 1.0);
  // environment 0: returns 1 + 0.5·3 = 2.5 (step 0), 3 (step 1), 5 + 0.5·10 = 10 (step 2)
  EXPECT_FLOAT_EQ(advantages[0], 2.5 - 0.5);
  EXPECT_FLOAT_EQ(advantages[2], 3.0 - 0.0);
  EXPECT_FLOAT_EQ(advantages[4], 10.0 - 0.25);
  // environment 1: returns 6 + 0.5·8 = 10 (step 2), 4 + 0.5·10 = 9 (step 1), 2 + 0.5·9 = 6.5 (step 0)
  EXPECT_FLOAT_EQ(advantages[5], 10.0 - 2.0);
  EXPECT_FLOAT_EQ(advantages[3], 9.0 - 0.0);
  EXPECT_FLOAT_EQ(advantages[1], 6.5 - 1.0);
  // λ = 0: one-step TD errors
  const std::vector<float> td = GeneralizedAdvantages(rewards, values, ended, {10, 8}, 0.5, 0.0);
  EXPECT_FLOAT_EQ(td[0], 1.0 + 0.5 * 0.0 - 0.5);
  EXPECT_FLOAT_EQ(td[2], 3.0 - 0.0);
  EXPECT_THROW(GeneralizedAdvantages(rewards, values, {0, 0}, {10, 8}, 0.5, 1.0), std::invalid_argument);
}

// Repeated updates on one rollout: the value network fits its returns, and the clipped surrogate falls from
// zero (the ratio is 1 and advantages are normalised at the first) as the policy leans to better actions.
TEST(Ppo, UpdatesLowerTheLossesOnAFixedRollout) {
  test_support::TestFolder folder("ppo_fit");
  PpoConfig config = Small();
  config.value_warmup_iterations = 0;
  config.target_kl = 0.0;
  config.epochs = 1;
  config.minibatch = 128;
  config.actor_learning_rate = 1e-3;
  config.value_learning_rate = 1e-3;
  Ppo learner(ShortTask(), config, InitialPolicy(folder));
  const std::shared_ptr<Ppo::Rollout> rollout = learner.Collect();
  const PpoStats first = learner.Update(*rollout);
  PpoStats last;
  for (int k = 0; k < 40; ++k) last = learner.Update(*rollout);
  std::printf("value loss %.3g -> %.3g, surrogate %.3g -> %.3g, clipped %.2f\n", first.value_loss,
              last.value_loss, first.policy_loss, last.policy_loss, last.clip_fraction);
  EXPECT_EQ(first.episodes, 2);  // each environment's 50-step episode ended in the 64 steps
  EXPECT_NEAR(first.policy_loss, 0.0, 1e-5);
  EXPECT_LT(last.policy_loss, -0.05);
  EXPECT_LT(last.value_loss, 0.2 * first.value_loss);
  EXPECT_GT(last.clip_fraction, 0.0);
  EXPECT_EQ(last.iteration, 41);
}

// The anchor's penalty holds the actor's mean near the initial actor's while the surrogate pulls it away.
TEST(Ppo, TheAnchorHoldsTheActorNearItsStart) {
  test_support::TestFolder folder("ppo_anchor");
  const std::string initial = InitialPolicy(folder);
  double drift[2] = {0.0, 0.0};
  for (const int anchored : {0, 1}) {
    PpoConfig config = Small();
    config.value_warmup_iterations = 0;
    config.target_kl = 0.0;
    config.actor_learning_rate = 1e-3;
    config.anchor_coefficient = anchored ? 4.0 : 0.0;
    config.epochs = 1;
    config.minibatch = 128;  // one minibatch per update
    Ppo learner(ShortTask(), config, initial);
    const std::shared_ptr<Ppo::Rollout> rollout = learner.Collect();
    const PpoStats first = learner.Update(*rollout);
    EXPECT_NEAR(first.anchor_kl, 0.0, 1e-6);  // the first minibatch acts as the initial actor
    PpoStats last;
    for (int k = 0; k < 20; ++k) last = learner.Update(*rollout);
    drift[anchored] = last.anchor_kl;
  }
  std::printf("KL to the initial actor after 21 updates: %.3g plain, %.3g anchored\n", drift[0], drift[1]);
  EXPECT_LT(drift[1], 0.5 * drift[0]);
}

TEST(Ppo, StartsAsTheInitialPolicyAndWarmsUpTheValueFirst) {
  test_support::TestFolder folder("ppo_start");
  const std::string initial = InitialPolicy(folder);
  Ppo learner(ShortTask(), Small(), initial);
  const std::string exported = (folder.path() / "exported.pt").string();
  learner.ExportPolicy(exported);
  TorchScriptPolicy before(initial), after(exported);
  Observation observation = Observation::LinSpaced(-1.0, 1.0);
  EXPECT_EQ(before.Act(observation), after.Act(observation));
  const PpoStats warmup = learner.Iterate();  // value_warmup_iterations = 1: the actor stays
  EXPECT_FALSE(warmup.actor_updated);
  learner.ExportPolicy(exported);
  EXPECT_EQ(TorchScriptPolicy(exported).Act(observation), before.Act(observation));
  const PpoStats tuned = learner.Iterate();
  EXPECT_TRUE(tuned.actor_updated);
  learner.ExportPolicy(exported);
  EXPECT_NE(TorchScriptPolicy(exported).Act(observation), before.Act(observation));
  EXPECT_EQ(tuned.env_steps, 2 * 2 * 64);
  EXPECT_NEAR(tuned.std_mean, Small().initial_std, 0.01);  // σ moved a little from its start
}

// Runs `work(rank)` for two workers at once on threads, each a learner of its own; rethrows what one threw.
template <class Work>
void OnTwoWorkers(const Work& work) {
  std::exception_ptr failed[2];
  std::vector<std::thread> threads;
  for (int rank = 0; rank < 2; ++rank) {
    threads.emplace_back([&, rank] {
      try {
        work(rank);
      } catch (...) {
        failed[rank] = std::current_exception();
      }
    });
  }
  for (auto& thread : threads) thread.join();
  for (const auto& error : failed) {
    if (error) std::rethrow_exception(error);
  }
}

PpoWorkers Worker(int rank, const std::filesystem::path& rendezvous) {
  PpoWorkers workers;
  workers.rank = rank;
  workers.world = 2;
  workers.rendezvous_file = rendezvous.string();
  workers.address = "127.0.0.1";
  workers.timeout_s = 60.0;
  return workers;
}

// Two workers, each updating on its half of one rollout (with half the minibatch), take the steps one
// learner takes on the whole: the same losses and the same policy after two updates, to float rounding
// (the sums run in another order, float32 alone, float64 across workers), and exactly the same policy on both
// workers.
TEST(Ppo, TwoWorkersUpdateAsOneLearnerOnTheSameData) {
  test_support::TestFolder folder("ppo_workers");
  const std::string initial = InitialPolicy(folder);
  PpoConfig config = Small();  // 2 x 64 rows, minibatches of 64
  config.value_warmup_iterations = 0;
  config.target_kl = 0.0;
  config.actor_learning_rate = 1e-3;
  config.value_learning_rate = 1e-3;
  const std::shared_ptr<Ppo::Rollout> rollout = Ppo(ShortTask(), config, initial).Collect();
  Ppo alone(ShortTask(), config, initial);  // a fresh generator: the permutations the workers draw
  PpoStats one[2];
  for (PpoStats& stats : one) stats = alone.Update(*rollout);
  alone.ExportPolicy((folder.path() / "alone.pt").string());

  PpoConfig half = config;
  half.minibatch = 32;
  PpoStats two[2][2];
  OnTwoWorkers([&](int rank) {
    Ppo worker(ShortTask(), half, initial, Worker(rank, folder.path() / "rendezvous"));
    const std::shared_ptr<Ppo::Rollout> share = Ppo::Rows(*rollout, 64 * rank, 64 * (rank + 1));
    for (PpoStats& stats : two[rank]) stats = worker.Update(*share);
    worker.ExportPolicy((folder.path() / ("worker" + std::to_string(rank) + ".pt")).string());
  });
  for (int update = 0; update < 2; ++update) {
    SCOPED_TRACE(update);
    for (const PpoStats& stats : {two[0][update], two[1][update]}) {
      EXPECT_NEAR(stats.policy_loss, one[update].policy_loss, 1e-5);
      EXPECT_NEAR(stats.value_loss, one[update].value_loss, 1e-5 * one[update].value_loss);
      EXPECT_NEAR(stats.approx_kl, one[update].approx_kl, 1e-4 * one[update].approx_kl);
      EXPECT_NEAR(stats.anchor_kl, one[update].anchor_kl, 1e-6);
      EXPECT_EQ(stats.clip_fraction, one[update].clip_fraction);
      // float32 variances alone, float64 sums of the shares
      EXPECT_NEAR(stats.explained_variance, one[update].explained_variance, 1e-4);
      EXPECT_EQ(stats.episodes, one[update].episodes);
      EXPECT_EQ(stats.env_steps, one[update].env_steps);
    }
  }
  EXPECT_LT(one[1].policy_loss, 0.0);  // the actor did move: the comparison is not of two initial actors
  TorchScriptPolicy policy((folder.path() / "alone.pt").string()),
      first((folder.path() / "worker0.pt").string()), second((folder.path() / "worker1.pt").string()),
      start(initial);
  for (const double x : {-1.0, 0.0, 0.5}) {
    const Observation observation = Observation::Constant(x) + Observation::LinSpaced(-0.5, 0.5);
    EXPECT_EQ(first.Act(observation), second.Act(observation));
    EXPECT_TRUE(first.Act(observation).isApprox(policy.Act(observation), 1e-5))
        << first.Act(observation).transpose() << " | " << policy.Act(observation).transpose();
    EXPECT_FALSE(policy.Act(observation).isApprox(start.Act(observation), 1e-3));
  }
}

// Two workers that roll out and update (iterations of their own environments, noise and episodes) give
// the same result for the same seed.
TEST(Ppo, TwoWorkersAreDeterministicForASeed) {
  test_support::TestFolder folder("ppo_workers_seed");
  const std::string initial = InitialPolicy(folder);
  PpoConfig config = Small();
  config.value_warmup_iterations = 0;
  PpoStats runs[2][2];
  for (int run = 0; run < 2; ++run) {
    OnTwoWorkers([&](int rank) {
      Ppo worker(ShortTask(), config, initial, Worker(rank, folder.path() / ("run" + std::to_string(run))));
      worker.Iterate();
      runs[run][rank] = worker.Iterate();
    });
  }
  EXPECT_EQ(runs[0][0].policy_loss, runs[1][0].policy_loss);
  EXPECT_EQ(runs[0][0].value_loss, runs[1][0].value_loss);
  EXPECT_EQ(runs[0][0].return_mean, runs[1][0].return_mean);
  EXPECT_EQ(runs[0][0].policy_loss, runs[0][1].policy_loss);  // and every rank knows the global figures
  EXPECT_EQ(runs[0][0].episodes, 4);                          // 2 workers x 2 environments x one episode
  EXPECT_EQ(runs[0][0].env_steps, 2 * 2 * 2 * 64);
}

TEST(Ppo, ACheckpointResumesTrainingExactly) {
  test_support::TestFolder folder("ppo_checkpoint");
  const std::string initial = InitialPolicy(folder);
  const std::string path = (folder.path() / "checkpoint.pt").string();
  Ppo trained(ShortTask(), Small(), initial);
  trained.Iterate();
  trained.Iterate();
  trained.Save(path);
  Ppo resumed(ShortTask(), Small(), initial);
  resumed.Load(path);
  EXPECT_EQ(resumed.iteration(), 2);
  for (int k = 0; k < 2; ++k) {
    const PpoStats a = trained.Iterate(), b = resumed.Iterate();
    EXPECT_EQ(a.policy_loss, b.policy_loss) << k;
    EXPECT_EQ(a.value_loss, b.value_loss) << k;
    EXPECT_EQ(a.return_mean, b.return_mean) << k;
    EXPECT_EQ(a.env_steps, b.env_steps) << k;
  }
}

// Potential shaping keeps the optimal policy only for the learner's own γ (rl/docking_task.h).
TEST(Ppo, RefusesADiscountOtherThanThePotentialShapings) {
  test_support::TestFolder folder("ppo_discount");
  const std::string initial = InitialPolicy(folder);
  const DockingTaskConfig shaped =
      ReadDockingTask(std::string(IAPSIM_SOURCE_DIR) + "/configs/rl/docking.yaml",
                      {"reward.shaping=potential", "reward.discount=0.99"});
  PpoConfig config = Small();
  config.discount = 0.99;
  EXPECT_NO_THROW(Ppo(shaped, config, initial));
  config.discount = 0.998;
  try {
    Ppo learner(shaped, config, initial);
    FAIL() << "a discount other than the shaping's was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("reward.discount (0.990000)"), std::string::npos)
        << error.what();
  }
  const DockingTaskConfig direct =
      ReadDockingTask(std::string(IAPSIM_SOURCE_DIR) + "/configs/rl/docking.yaml", {"reward.shaping=direct"});
  EXPECT_NO_THROW(Ppo(direct, config, initial));  // direct shaping: any γ
}

TEST(Ppo, ABadInitialPolicyOrCheckpointIsAnErrorNamingTheFile) {
  test_support::TestFolder folder("ppo_bad");
  const std::string initial = InitialPolicy(folder);
  const auto start_error = [&](const std::string& path) -> std::string {
    try {
      Ppo learner(ShortTask(), Small(), path);
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
    return "no error";
  };
  EXPECT_NE(start_error(folder.Write("text.pt", "no module")).find("text.pt: not a TorchScript policy"),
            std::string::npos);
  torch::jit::Module linear("LinearPolicy");  // a policy TorchScriptPolicy flies, but no exported MLP
  linear.register_parameter("weight", torch::zeros({kActionSize, kObservationSize}), false);
  linear.define("def forward(self, observation):\n    return torch.matmul(observation, self.weight.t())\n");
  const std::string linear_path = (folder.path() / "linear.pt").string();
  linear.save(linear_path);
  EXPECT_NE(
      start_error(linear_path).find("linear.pt: not a policy `iapsim rl train` exported (it has no tensor"),
      std::string::npos)
      << start_error(linear_path);
  const std::string narrow = (folder.path() / "narrow.pt").string();
  ExportActor(narrow, Mlp(kObservationSize - 1, 32, kActionSize), torch::zeros({1, kObservationSize}),
              torch::ones({1, kObservationSize}));
  EXPECT_NE(start_error(narrow).find("narrow.pt: 'w0' has shape [32, 47], expected [32, 48]"),
            std::string::npos)
      << start_error(narrow);

  Ppo learner(ShortTask(), Small(), initial);
  const auto load_error = [&](const std::string& path) -> std::string {
    try {
      learner.Load(path);
    } catch (const std::runtime_error& error) {
      return error.what();
    }
    return "no error";
  };
  EXPECT_NE(load_error(folder.Write("damaged.pt", "no archive")).find("damaged.pt: not a PPO checkpoint"),
            std::string::npos);
  PpoConfig wider = Small();
  wider.value_hidden = 16;
  const std::string other = (folder.path() / "other.pt").string();
  Ppo(ShortTask(), wider, initial).Save(other);
  EXPECT_NE(load_error(other).find("other.pt: not a PPO checkpoint of this shape"), std::string::npos)
      << load_error(other);
  PpoConfig no_envs = Small();
  no_envs.envs = 0;
  EXPECT_THROW(Ppo(ShortTask(), no_envs, initial), std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::rl
