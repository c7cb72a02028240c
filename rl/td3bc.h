#pragma once
// TD3-BC (Fujimoto & Gu, "A Minimalist Approach to Offline Reinforcement Learning", NeurIPS 2021): TD3's
// twin critics, target policy smoothing and delayed actor updates, with the actor's objective
//   maximise  λ Q(s, π(s)) − (π(s) − a)²,   λ = α / mean |Q(s, π(s))|
// on a fixed data set, observations normalised by the data set's mean and standard deviation. The seed
// pretrains its docking policy this way from the expert's episodes (§IV-E, Fig. 7) before PPO.
//
// Defaults are the paper's (its Table 3 and its released code): 256-256 ReLU networks, Adam at 3e-4,
// batch 256, γ 0.99, τ 0.005, policy noise 0.2 clipped at 0.5, actor every second update, α 2.5.
//
// libtorch stays behind this header (PIMPL).

#include <cstdint>
#include <memory>
#include <string>

#include "rl/dataset.h"

namespace iapsim::rl {

struct Td3BcConfig {
  int hidden = 256;
  double actor_learning_rate = 3e-4;
  double critic_learning_rate = 3e-4;
  int batch = 256;
  double discount = 0.99;
  double tau = 0.005;
  double policy_noise = 0.2;
  double noise_clip = 0.5;
  int policy_frequency = 2;
  double alpha = 2.5;
  uint64_t seed = 1;
  int threads = 1;  // libtorch's intra-op threads for the updates
  // The policy (Act, ExportPolicy): the actor's Polyak average (its TD3 target network, τ), or its last
  // iterate. The average of a cloning actor is far steadier: on the paper-like noisy data its last iterate
  // docked 2-74 % from one evaluation to the next, its average 94-98 % (README, Learning).
  bool export_average = true;
};

struct Td3BcLosses {
  int64_t step = 0;        // updates done, this one included
  double critic = 0.0;     // (Q1 − y)² + (Q2 − y)², batch mean
  double actor = 0.0;      // −λ Q + BC, at the last actor update
  double behaviour = 0.0;  // its (π(s) − a)² part
  double q_mean = 0.0;     // mean Q1 of the batch
};

class Td3Bc {
 public:
  /// A learner on `data` (kept by reference: it must outlive the learner).
  Td3Bc(const Dataset& data, const Td3BcConfig& config);
  ~Td3Bc();

  /// One update on a batch drawn uniformly from the data set.
  Td3BcLosses Update();
  /// One update on the rows `first` .. first + batch − 1 (tests: a fixed batch).
  Td3BcLosses UpdateOn(int64_t first);
  int64_t step() const;
  /// The policy's action (Td3BcConfig::export_average) for a raw (unnormalised) observation.
  Action Act(const Observation& observation) const;

  /// Writes every network, target, optimiser state, the normalisation, the step and the random state, so
  /// that Load continues exactly where this left off. Written to PATH.partial and renamed.
  void Save(const std::string& path) const;
  /// Throws std::runtime_error naming the file for one that is no checkpoint of this learner's shape.
  void Load(const std::string& path);
  /// The policy (Td3BcConfig::export_average) with the normalisation in front, as a TorchScript policy
  /// (rl/torchscript_policy.h).
  void ExportPolicy(const std::string& path) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iapsim::rl
