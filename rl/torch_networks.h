#pragma once
// What the learners (rl/td3bc.cc, rl/iql.cc, rl/ppo.cc) share inside iapsim::rl_torch: the MLP, the
// observation normalisation, checkpoint parts and the actor's TorchScript form. Includes libtorch: for the
// learners' sources and their tests only, never for a header other code includes.
//
// The actor's TorchScript form (DockingPolicy) is what `iapsim rl eval --policy` flies and what PPO starts
// from: buffers mean and std, parameters w0, b0, w1, b1, w2, b2, and
//   forward(o) = tanh(W2 relu(W1 relu(W0 clamp((o − mean) / std, ±10) + b0) + b1) + b2).

#include <torch/script.h>
#include <torch/torch.h>

#include <string>
#include <utility>
#include <vector>

#include "rl/dataset.h"

namespace iapsim::rl {

// The learners' libtorch intra-op threads (their `threads`/`torch_threads`) default to one: their networks
// (256 wide) and batches (256 rows; PPO's 2,000) are too small to share, and on the 2-core development
// machine two threads made 1,000 TD3-BC updates take 53.8 s instead of 16.5 s, IQL's 65.7 s instead of 18.9
// s, and a PPO iteration (16 x 2000 steps, 10 epochs) 27 s instead of 13 s (2026-11-28): the threads'
// synchronisation costs more than the arithmetic they share.

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

/// target ← (1 − τ) target + τ source, parameter by parameter (TD3's and IQL's target networks, τ = 1: a
/// copy).
void SoftUpdate(const torch::nn::Module& source, torch::nn::Module& target, double tau);

/// A data set as the offline learners (TD3-BC, IQL) train on it: float32 tensors, one row per transition,
/// observations normalised by the data set's mean and standard deviation (+ 1e-3, TD3-BC's ε), `not_done`
/// 1 − terminal.
struct OfflineTensors {
  torch::Tensor observations, actions, rewards, next_observations, not_done;
  torch::Tensor mean, std;
};
OfflineTensors ToTensors(const Dataset& data);

/// A learner's checkpoint: its networks, optimisers and tensors (step counters and random state as tensors),
/// each under its name, by pointer into the learner.
struct Checkpoint {
  std::vector<std::pair<std::string, torch::nn::Module*>> modules;
  std::vector<std::pair<std::string, torch::optim::Optimizer*>> optimizers;
  std::vector<std::pair<std::string, torch::Tensor*>> tensors;
  /// Writes every part to PATH.partial and renames it.
  void Save(const std::string& path) const;
  /// Reads every part in place; throws std::runtime_error "PATH: not a <learner> checkpoint of this shape
  /// (why)" for a file that is no archive, lacks a part or has layers of another width.
  void Load(const std::string& path, const std::string& learner) const;
};

/// The actor's action (tanh of its output) for one raw observation, normalised by `mean` and `std`.
Action ActOn(Mlp actor, const torch::Tensor& mean, const torch::Tensor& std, const Observation& observation);

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
