#include "rl/policy.h"

#include <stdexcept>

#include "rl/docking_expert.h"

namespace iapsim::rl {

std::unique_ptr<Policy> MakePolicy(const std::string& name, const DockingEnv& env) {
  if (name == "expert") return std::make_unique<DockingExpert>(env);
  throw std::invalid_argument("unknown policy '" + name + "': expected expert");
}

}  // namespace iapsim::rl
