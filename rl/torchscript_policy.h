#pragma once
// A learned policy as TorchScript: a file that torch.jit.save wrote (from Python, trained on the iapsim_rl
// module or anything else) or `iapsim rl train` exported. Its forward takes a batch of observations,
// float32 [B, 48], and returns the actions, [B, 12], in [−1, 1] (the environment clips them). Whatever it
// does inside (normalisation, an MLP, a tanh) is its own.
//
// libtorch stays behind this header: loading it costs a process about 2 s, so only the programs that fly
// learned policies link it (iapsim::rl_torch; `iapsim rl`, not `iapsim`).

#include <memory>
#include <string>

#include "rl/docking_env.h"
#include "rl/policy.h"

namespace iapsim::rl {

class TorchScriptPolicy : public Policy {
 public:
  /// Loads `path` and checks its shape on a zero observation; throws std::invalid_argument naming the file
  /// when it is no TorchScript module or does not map 48 observations to 12 actions.
  explicit TorchScriptPolicy(const std::string& path);
  ~TorchScriptPolicy() override;

  void Reset() override {}
  Action Act(const Observation& observation) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The policy `name` names for `env`'s task: "expert" (rl/docking_expert.h) or a TorchScript file (*.pt).
/// Throws std::invalid_argument naming the choices, or the file and what is wrong with it.
std::unique_ptr<Policy> MakePolicy(const std::string& name, const DockingEnv& env);

}  // namespace iapsim::rl
