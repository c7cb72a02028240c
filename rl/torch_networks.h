#pragma once
// What the learners (rl/td3bc.cc, rl/ppo.cc) share inside iapsim::rl_torch: the MLP, the observation
// normalisation, checkpoint parts and the actor's TorchScript form. Includes libtorch: for the learners'
// sources and their tests only, never for a header other code includes.
//
// The actor's TorchScript form (DockingPolicy) is what `iapsim rl eval --policy` flies and what PPO starts
// from: buffers mean and std, parameters w0, b0, w1, b1, w2, b2, and
//   forward(o) = tanh(W2 relu(W1 relu(W0 clamp((o − mean) / std, ±10) + b0) + b1) + b2).

#include <torch/script.h>
#include <torch/torch.h>

#include <string>

#include "rl/dataset.h"

namespace iapsim::rl {

// Three linear layers with ReLUs between them: every actor, critic and value network.
struct MlpImpl : torch::nn::Module {
  MlpImpl(int64_t in, int64_t hidden, int64_t out)
      : l0(register_module("l0", torch::nn::Linear(in, hidden))),
        l1(register_module("l1", torch::nn::Linear(hidden, hidden))),
        l2(register_module("l2", torch::nn::Linear(hidden, out))) {}
  torch::Tensor forward(const torch::Tensor& x) { return l2(torch::relu(l1(torch::relu(l0(x))))); }
  torch::nn::Linear l0, l1, l2;
};
TORCH_MODULE(Mlp);

/// Rows of a data set as a float32 tensor (a copy).
torch::Tensor FromRows(const RowMatrixF& rows);

/// (o − mean) / std, clipped at ±10 deviations (as Stable-Baselines3's VecNormalize): the contact wrench is
/// nearly always zero, and a rare contact spike would otherwise reach the networks as thousands of
/// deviations.
torch::Tensor Normalise(const torch::Tensor& observations, const torch::Tensor& mean,
                        const torch::Tensor& std);

/// Writes `module` under `name` into `archive`.
void WriteModule(torch::serialize::OutputArchive& archive, const char* name, const torch::nn::Module& module);
/// Reads `module` from `archive`'s `name`; throws std::runtime_error when a parameter's shape differs from
/// the module's (libtorch's load adopts whatever shape it reads).
void ReadModule(torch::serialize::InputArchive& archive, const char* name, torch::nn::Module& module);
/// Saves `archive` to PATH.partial and renames it: a killed run never leaves half a checkpoint.
void SaveArchive(torch::serialize::OutputArchive& archive, const std::string& path);

/// Writes `actor` with the normalisation in front as a DockingPolicy TorchScript file (PATH.partial,
/// renamed).
void ExportActor(const std::string& path, const Mlp& actor, const torch::Tensor& mean,
                 const torch::Tensor& std);

/// A DockingPolicy file's actor and normalisation (a copy of its tensors).
struct ActorFile {
  Mlp actor{nullptr};
  torch::Tensor mean, std;
};
/// Reads a file ExportActor wrote; throws std::invalid_argument naming the file and what is missing or of
/// the wrong shape.
ActorFile ReadActor(const std::string& path);

}  // namespace iapsim::rl
