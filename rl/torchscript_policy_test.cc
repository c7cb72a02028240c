// TorchScript policies: a saved module acts as its forward says, one of the wrong shape or a file that is no
// module is a clear error naming the file, and an evaluation flies it on any number of threads alike.
#include "rl/torchscript_policy.h"

#include <gtest/gtest.h>
#include <torch/script.h>

#include <cmath>
#include <stdexcept>

#include "rl/docking_expert.h"
#include "rl/evaluation.h"
#include "tests/support/test_folder.h"

namespace iapsim::rl {
namespace {

// A TorchScript module computing tanh(W x + b) for W [actions, observations], saved to `path`.
void SaveLinearPolicy(const std::string& path, const torch::Tensor& weight, const torch::Tensor& bias) {
  torch::jit::Module module("LinearPolicy");
  module.register_parameter("weight", weight, false);
  module.register_parameter("bias", bias, false);
  module.define(R"(
def forward(self, observation):
    return torch.tanh(torch.matmul(observation, self.weight.t()) + self.bias)
)");
  module.save(path);
}

std::string ErrorOf(const std::string& path) {
  try {
    TorchScriptPolicy policy(path);
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "no error";
}

DockingTaskConfig ShortTask() {
  return ReadDockingTask(std::string(IAPSIM_SOURCE_DIR) + "/configs/rl/docking.yaml",
                         {"termination.max_steps=40"});
}

TEST(TorchScriptPolicy, ActsAsItsForwardSays) {
  test_support::TestFolder folder("torchscript_policy");
  torch::manual_seed(3);
  const torch::Tensor weight = 0.1 * torch::randn({kActionSize, kObservationSize});
  const torch::Tensor bias = 0.1 * torch::randn({kActionSize});
  const std::string path = (folder.path() / "linear.pt").string();
  SaveLinearPolicy(path, weight, bias);

  TorchScriptPolicy policy(path);
  Observation observation;
  for (int i = 0; i < kObservationSize; ++i) observation[i] = std::sin(0.3 * i);
  const Action action = policy.Act(observation);
  const auto W = weight.accessor<float, 2>();
  const auto b = bias.accessor<float, 1>();
  for (int r = 0; r < kActionSize; ++r) {
    double sum = b[r];
    for (int c = 0; c < kObservationSize; ++c) sum += W[r][c] * static_cast<float>(observation[c]);
    EXPECT_NEAR(action[r], std::tanh(sum), 1e-5) << r;
  }
}

TEST(TorchScriptPolicy, AWrongShapeOrNoModuleIsAnErrorNamingTheFile) {
  test_support::TestFolder folder("torchscript_policy_bad");
  const std::string seven = (folder.path() / "seven.pt").string();
  SaveLinearPolicy(seven, torch::zeros({7, kObservationSize}), torch::zeros({7}));
  EXPECT_NE(
      ErrorOf(seven).find("seven.pt: forward must map observations [1, 48] to actions [1, 12], got [1, 7]"),
      std::string::npos)
      << ErrorOf(seven);
  const std::string narrow = (folder.path() / "narrow.pt").string();
  SaveLinearPolicy(narrow, torch::zeros({kActionSize, 40}), torch::zeros({kActionSize}));
  EXPECT_NE(ErrorOf(narrow).find("narrow.pt: forward does not take observations of shape [B, 48]"),
            std::string::npos)
      << ErrorOf(narrow);
  EXPECT_NE(ErrorOf(folder.Write("text.pt", "not a module")).find("text.pt: not a TorchScript policy"),
            std::string::npos);
  EXPECT_NE(ErrorOf((folder.path() / "absent.pt").string()).find("absent.pt: not a TorchScript policy"),
            std::string::npos);
}

TEST(MakePolicy, NamesTheExpertOrATorchScriptFile) {
  test_support::TestFolder folder("make_policy");
  const DockingEnv env(ShortTask());
  EXPECT_NE(dynamic_cast<DockingExpert*>(MakePolicy("expert", env).get()), nullptr);
  try {
    MakePolicy("ppo", env);
    FAIL() << "an unknown policy was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("expected expert or a TorchScript file (*.pt)"),
              std::string::npos);
  }
  const std::string zero = (folder.path() / "zero.pt").string();
  SaveLinearPolicy(zero, torch::zeros({kActionSize, kObservationSize}), torch::zeros({kActionSize}));
  EXPECT_NE(dynamic_cast<TorchScriptPolicy*>(MakePolicy(zero, env).get()), nullptr);

  // a zero policy hovers: every episode times out, the same on one and two threads
  const PolicyFactory make = [&](const DockingEnv& episode_env) { return MakePolicy(zero, episode_env); };
  const std::vector<EpisodeResult> one = RunEpisodes(ShortTask(), make, 3, 5, 1);
  const std::vector<EpisodeResult> two = RunEpisodes(ShortTask(), make, 3, 5, 2);
  for (size_t e = 0; e < one.size(); ++e) {
    EXPECT_EQ(one[e].outcome, Outcome::kTimeout);
    EXPECT_EQ(one[e].episode_return, two[e].episode_return);
  }
}

}  // namespace
}  // namespace iapsim::rl
