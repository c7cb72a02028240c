// TD3-BC: its updates fit a fixed batch, a checkpoint resumes training exactly, a damaged or mismatched
// checkpoint is a clear error, and the exported TorchScript policy acts as the learner's actor.
#include "rl/td3bc.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "rl/docking_expert.h"
#include "rl/torchscript_policy.h"
#include "tests/support/test_folder.h"

namespace iapsim::rl {
namespace {

// Two 300-step expert episodes, through an HDF5 file as `iapsim rl train` reads them.
const Dataset& ExpertData() {
  static const Dataset data = [] {
    test_support::TestFolder folder("td3bc_data");
    const DockingTaskConfig task = ReadDockingTask(
        std::string(IAPSIM_SOURCE_DIR) + "/configs/rl/docking.yaml", {"termination.max_steps=300"});
    const std::string path = (folder.path() / "expert.hdf5").string();
    DatasetWriter writer(path);
    for (const EpisodeResult& episode :
         RunEpisodes(task, [](const DockingEnv& env) { return std::make_unique<DockingExpert>(env); }, 2, 1,
                     2, {0, 0, true})) {
      writer.Append(episode.transitions);
    }
    writer.Close({});
    return ReadDataset(path);
  }();
  return data;
}

Td3BcConfig Small() {
  Td3BcConfig config;
  config.hidden = 64;
  config.batch = 64;
  return config;
}

// The critics fit the batch's returns. The actor's behaviour-cloning term falls where α = 0 (TD3-BC's limit
// of pure behaviour cloning); with the paper's α = 2.5 the normalised Q term outweighs it on one fixed batch.
TEST(Td3Bc, UpdatesLowerTheLossesOnAFixedBatch) {
  for (const double alpha : {2.5, 0.0}) {
    Td3BcConfig config = Small();
    config.alpha = alpha;
    Td3Bc learner(ExpertData(), config);
    const Td3BcLosses first = learner.UpdateOn(100);
    const Td3BcLosses with_actor = learner.UpdateOn(100);
    Td3BcLosses last;
    for (int k = 0; k < 300; ++k) last = learner.UpdateOn(100);
    std::printf("alpha %.1f: critic %.3g -> %.3g, behaviour cloning %.3g -> %.3g\n", alpha, first.critic,
                last.critic, with_actor.behaviour, last.behaviour);
    EXPECT_EQ(last.step, 302);
    EXPECT_LT(last.critic, 0.1 * first.critic);
    if (alpha == 0.0) {
      EXPECT_LT(last.behaviour, 0.1 * with_actor.behaviour);
    }
  }
}

TEST(Td3Bc, ACheckpointResumesTrainingExactly) {
  test_support::TestFolder folder("td3bc_checkpoint");
  const std::string path = (folder.path() / "checkpoint.pt").string();
  Td3Bc trained(ExpertData(), Small());
  for (int k = 0; k < 21; ++k) trained.Update();
  trained.Save(path);
  Td3Bc resumed(ExpertData(), Small());
  resumed.Load(path);
  EXPECT_EQ(resumed.step(), 21);
  for (int k = 0; k < 6; ++k) {
    const Td3BcLosses a = trained.Update(), b = resumed.Update();
    EXPECT_EQ(a.critic, b.critic) << k;
    EXPECT_EQ(a.actor, b.actor) << k;
  }
}

TEST(Td3Bc, ADamagedOrMismatchedCheckpointIsAnErrorNamingTheFile) {
  test_support::TestFolder folder("td3bc_bad");
  Td3Bc learner(ExpertData(), Small());
  const auto error_of = [&](const std::string& path) -> std::string {
    try {
      learner.Load(path);
    } catch (const std::runtime_error& error) {
      return error.what();
    }
    return "no error";
  };
  EXPECT_NE(error_of(folder.Write("text.pt", "no archive")).find("text.pt: not a TD3-BC checkpoint"),
            std::string::npos);
  Td3BcConfig wider = Small();
  wider.hidden = 32;
  const std::string other = (folder.path() / "wider.pt").string();
  Td3Bc(ExpertData(), wider).Save(other);
  EXPECT_NE(error_of(other).find("wider.pt: not a TD3-BC checkpoint of this shape"), std::string::npos)
      << error_of(other);
  EXPECT_THROW(Td3Bc(ExpertData(),
                     [] {
                       Td3BcConfig huge = Small();
                       huge.batch = 100000;
                       return huge;
                     }()),
               std::invalid_argument);
}

TEST(Td3Bc, TheExportedPolicyActsAsTheLearner) {
  test_support::TestFolder folder("td3bc_export");
  Td3Bc learner(ExpertData(), Small());
  for (int k = 0; k < 10; ++k) learner.Update();
  const std::string path = (folder.path() / "policy.pt").string();
  learner.ExportPolicy(path);
  TorchScriptPolicy policy(path);
  for (int row = 0; row < 600; row += 150) {
    const Observation observation = ExpertData().observations.row(row).transpose().cast<double>();
    EXPECT_LT((policy.Act(observation) - learner.Act(observation)).cwiseAbs().maxCoeff(), 1e-6) << row;
  }
}

// The policy is the actor's Polyak average by default: the actor itself where the average follows it at once
// (τ 1) and before any update, and behind it otherwise.
TEST(Td3Bc, ThePolicyIsTheActorsAverageOrItsLastIterate) {
  const auto distance = [](double tau, int updates) {
    Td3BcConfig average = Small(), last = Small();
    average.tau = last.tau = tau;
    last.export_average = false;
    Td3Bc a(ExpertData(), average), b(ExpertData(), last);
    for (int k = 0; k < updates; ++k) a.Update(), b.Update();
    double largest = 0.0;
    for (int row = 0; row < 600; row += 150) {
      const Observation observation = ExpertData().observations.row(row).transpose().cast<double>();
      largest = std::max(largest, (a.Act(observation) - b.Act(observation)).cwiseAbs().maxCoeff());
    }
    return largest;
  };
  EXPECT_LT(distance(0.005, 0), 1e-6);
  EXPECT_LT(distance(1.0, 20), 1e-6);
  EXPECT_GT(distance(0.005, 20), 1e-3);
}

}  // namespace
}  // namespace iapsim::rl
