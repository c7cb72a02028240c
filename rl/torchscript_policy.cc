#include "rl/torchscript_policy.h"

#include <ATen/Parallel.h>
#include <torch/script.h>

#include <stdexcept>

#include "rl/docking_expert.h"

namespace iapsim::rl {
namespace {

// The reason in a libtorch error: the interpreter's last line (after its TorchScript traceback), or c10's
// first (before its C++ backtrace).
std::string Reason(const std::string& text) {
  if (text.find("Traceback") != std::string::npos) {
    const size_t end = text.find_last_not_of("\n ");
    const size_t start = text.rfind('\n', end);
    return text.substr(start == std::string::npos ? 0 : start + 1,
                       end - (start == std::string::npos ? 0 : start + 1) + 1);
  }
  return text.substr(0, text.find('\n'));
}

std::string ShapeOf(const torch::Tensor& tensor) {
  std::string shape = "[";
  for (int64_t d = 0; d < tensor.dim(); ++d) shape += (d > 0 ? ", " : "") + std::to_string(tensor.size(d));
  return shape + "]";
}

}  // namespace

struct TorchScriptPolicy::Impl {
  torch::jit::Module module;
  torch::Tensor input = torch::zeros({1, kObservationSize}, torch::kFloat32);

  torch::Tensor Forward() {
    torch::NoGradGuard no_grad;
    return module.forward({input}).toTensor();
  }
};

TorchScriptPolicy::TorchScriptPolicy(const std::string& path) : impl_(std::make_unique<Impl>()) {
  // one intra-op thread: environments run in parallel already, one policy per thread
  at::set_num_threads(1);
  try {
    impl_->module = torch::jit::load(path);
  } catch (const std::exception& error) {  // c10::Error, or the interpreter's JITException
    throw std::invalid_argument(path + ": not a TorchScript policy (" + Reason(error.what()) + ")");
  }
  impl_->module.eval();
  c10::IValue out;
  try {
    torch::NoGradGuard no_grad;
    out = impl_->module.forward({impl_->input});
  } catch (const std::exception& error) {
    throw std::invalid_argument(path + ": forward does not take observations of shape [B, " +
                                std::to_string(kObservationSize) + "] (" + Reason(error.what()) + ")");
  }
  if (!out.isTensor()) throw std::invalid_argument(path + ": forward must return a tensor of actions");
  const torch::Tensor action = out.toTensor();
  if (action.dim() != 2 || action.size(0) != 1 || action.size(1) != kActionSize) {
    throw std::invalid_argument(path + ": forward must map observations [1, " +
                                std::to_string(kObservationSize) + "] to actions [1, " +
                                std::to_string(kActionSize) + "], got " + ShapeOf(action));
  }
}

TorchScriptPolicy::~TorchScriptPolicy() = default;

Action TorchScriptPolicy::Act(const Observation& observation) {
  float* in = impl_->input.data_ptr<float>();
  for (int i = 0; i < kObservationSize; ++i) in[i] = static_cast<float>(observation[i]);
  const torch::Tensor out = impl_->Forward().to(torch::kFloat64).contiguous();
  const Action action = Eigen::Map<const Action>(out.data_ptr<double>());
  if (!action.allFinite()) throw std::invalid_argument("the TorchScript policy returned a non-finite action");
  return action;
}

std::unique_ptr<Policy> MakePolicy(const std::string& name, const DockingEnv& env) {
  if (name == "expert") return std::make_unique<DockingExpert>(env);
  if (name.size() > 3 && name.compare(name.size() - 3, 3, ".pt") == 0) {
    return std::make_unique<TorchScriptPolicy>(name);
  }
  throw std::invalid_argument("unknown policy '" + name + "': expected expert or a TorchScript file (*.pt)");
}

}  // namespace iapsim::rl
