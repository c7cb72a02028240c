#pragma once
// IQL, implicit Q-learning (Kostrikov, Nair & Levine, "Offline Reinforcement Learning with Implicit
// Q-Learning", ICLR 2022): an offline learner that never evaluates its critics at actions the data set does
// not hold. A value network V(s) fits an upper expectile τ of the target critics' Q(s, a) over the data's
// actions (the loss |τ − 1(u < 0)| u², u = Q − V), the twin critics fit r + γ V(s′), and the actor is
// advantage-weighted behaviour cloning:
//   minimise  mean_batch( min(exp(β (Q(s, a) − V(s))), 100) · ‖π(s) − a‖² )
// (the weighted log-likelihood of a Gaussian of fixed σ around the tanh actor: the deterministic form of
// IQL's actor, as CORL's implementation offers it). TD3-BC (rl/td3bc.h) moves its actor along ∂Q/∂a, off
// the data, where the docking task's critics diverge (README, Learning); IQL only reweights the data's
// own actions.
//
// Defaults are the paper's for its D4RL locomotion tasks (its Appendix and released code): 256-256 ReLU
// networks, Adam at 3e-4, batch 256, γ 0.99, τ_target 0.005, expectile 0.7, β 3, weights clipped at 100,
// rewards scaled by 1000 / (largest − smallest episode return of the data set). The actor's learning-rate
// cosine decay of the paper is not used.
//
// libtorch stays behind this header (PIMPL).

#include <cstdint>
#include <memory>
#include <string>

#include "rl/dataset.h"

namespace iapsim::rl {

struct IqlConfig {
  int hidden = 256;
  double learning_rate = 3e-4;  // actor, critics and value network
  int batch = 256;
  double discount = 0.99;
  double tau = 0.005;  // the target critics' (and the averaged actor's) Polyak rate
  double expectile = 0.7;
  double beta = 3.0;  // the advantage's inverse temperature
  double max_weight = 100.0;
  bool normalize_rewards = true;  // × 1000 / (max − min episode return), as the paper's locomotion runs
  uint64_t seed = 1;
  int threads = 1;  // libtorch's intra-op threads for the updates
  // The policy (Act, ExportPolicy): the actor's Polyak average (τ), or its last iterate, as TD3-BC's
  // Td3BcConfig::export_average (its reason there).
  bool export_average = true;
};

struct IqlLosses {
  int64_t step = 0;
  double critic = 0.0;         // (Q1 − y)² + (Q2 − y)², batch mean, in scaled rewards
  double value = 0.0;          // the expectile loss
  double actor = 0.0;          // the weighted cloning loss
  double behaviour = 0.0;      // (π(s) − a)², batch and action mean (TD3-BC's BC term)
  double q_mean = 0.0;         // mean target Q of the batch, in scaled rewards
  double advantage_std = 0.0;  // of Q − V over the batch: how far apart the weights are
};

class Iql {
 public:
  /// A learner on `data` (kept by reference: it must outlive the learner).
  Iql(const Dataset& data, const IqlConfig& config);
  ~Iql();

  /// One update on a batch drawn uniformly from the data set.
  IqlLosses Update();
  /// One update on the rows `first` .. first + batch − 1 (tests: a fixed batch).
  IqlLosses UpdateOn(int64_t first);
  int64_t step() const;
  /// The factor the rewards are trained in (1 without normalize_rewards).
  double reward_scale() const;
  /// The value network's V(s) for a raw observation, in scaled rewards (tests).
  double Value(const Observation& observation) const;
  /// The policy's action (IqlConfig::export_average) for a raw (unnormalised) observation.
  Action Act(const Observation& observation) const;

  /// Writes every network, target, optimiser state, the normalisation, the step and the random state;
  /// Load continues exactly where this left off. Written to PATH.partial and renamed.
  void Save(const std::string& path) const;
  /// Throws std::runtime_error naming the file for one that is no checkpoint of this learner's shape.
  void Load(const std::string& path);
  /// The policy with the normalisation in front, as a TorchScript policy (rl/torchscript_policy.h).
  void ExportPolicy(const std::string& path) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The data set's largest minus smallest episode return (episodes end at a terminal or a time-out, and at
/// the last row); IQL scales its rewards by 1000 over it.
double EpisodeReturnRange(const Dataset& data);

}  // namespace iapsim::rl
