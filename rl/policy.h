#pragma once
// What acts in the docking environment: the rule-based expert (rl/docking_expert.h) and the learned
// policies (rl/torchscript_policy.h, which also has MakePolicy). One policy object serves one environment's
// episodes; Reset() comes at every episode's start.

#include "rl/docking_env.h"

namespace iapsim::rl {

class Policy {
 public:
  virtual ~Policy() = default;
  /// Forgets the last episode (a policy with memory: filters, phases).
  virtual void Reset() = 0;
  /// The action for this observation.
  virtual Action Act(const Observation& observation) = 0;
};

}  // namespace iapsim::rl
