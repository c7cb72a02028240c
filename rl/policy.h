#pragma once
// What acts in the docking environment: the rule-based expert, and (next) the learned policies. One
// policy object serves one environment's episodes; Reset() comes at every episode's start.

#include <memory>
#include <string>

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

/// The policy called `name` for `env`'s task: "expert" (rl/docking_expert.h). Throws std::invalid_argument
/// naming the choices for anything else.
std::unique_ptr<Policy> MakePolicy(const std::string& name, const DockingEnv& env);

}  // namespace iapsim::rl
