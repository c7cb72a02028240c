#pragma once
// PPO (Schulman et al., "Proximal Policy Optimization Algorithms", 2017) fine-tuning a docking policy
// online, as the seed does after TD3-BC (§IV-E, Fig. 7): the actor starts as the TD3-BC actor (its
// TorchScript file, rl/torch_networks.h) and keeps its normalisation; actions are drawn from a Gaussian
// around the actor's tanh output with a learned, state-independent log σ; a separate value network gives
// GAE advantages (Schulman et al. 2016); the clipped surrogate objective updates the actor.
//
// An iteration rolls out `envs` environments of a VectorEnv for `rollout_steps` steps each, from fresh
// episodes seeded by (seed, iteration): so an iteration depends on the networks, the optimisers and the
// random state only, and a checkpoint resumes training exactly. An episode that the iteration's end cuts
// off is bootstrapped with the value of its last observation, as is one truncated by the task's time limit
// (its final observation).
//
// Defaults follow Stable-Baselines3's PPO (γ 0.99, λ 0.95, clip 0.2, 10 epochs, gradients clipped at 0.5,
// advantages normalised per minibatch; its early stop of the epochs past 1.5 × target_kl, given 0.02), with
// what fine-tuning a pretrained actor needs: a small actor learning rate, little exploration (σ 0.05: the
// docking's 1 cm alignment fails under more), value-only warm-up iterations so that the first actor updates
// see advantages of a fitted value network rather than of a random one, and the anchor to the initial
// actor. These defaults (with the task's potential-shaped reward) are the setting that raised a cloned
// actor's success in the README's measurements; without the anchor, or with σ 0.2, the actor stopped
// docking within ten iterations.
//
// Data-parallel workers (PpoWorkers): W processes, each with its own environments, train one policy as
// synchronous PPO does with several actors (Schulman et al. 2017, §5; DD-PPO, Wijmans et al. 2020, in its
// synchronous form). Rank r's samples are rows [r N, (r + 1) N) of one global rollout of W N rows; every
// epoch draws one permutation of those rows, the same on every rank (the learners' generators stay equal),
// so every minibatch is a global one of W × minibatch rows; each rank's loss is the sum over its rows of the
// minibatch divided by the global size, the advantages are normalised with the minibatch's global mean and
// σ, and the gradients, the KL of the early stop and the figures are summed across ranks by c10d's Gloo
// all-reduce (libtorch's own). Every rank so takes the same optimiser step from the same gradients and the
// networks stay equal: W workers of E environments update as one learner of W E environments with a W times
// larger minibatch would, to float rounding. Rank r's episodes and exploration noise come from the streams
// (seed, iteration, r).
//
// libtorch stays behind this header (PIMPL).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rl/docking_task.h"

namespace iapsim::rl {

struct PpoConfig {
  int envs = 16;
  int rollout_steps = 2000;  // per environment and iteration: the task's whole episode
  int epochs = 10;
  int minibatch = 2000;
  double actor_learning_rate = 2e-5;
  double value_learning_rate = 3e-4;
  double discount = 0.99;
  double gae_lambda = 0.95;
  double clip = 0.2;
  // rewards are multiplied by this before GAE, so that values are O(1): the docking task's returns reach
  // ±150 with its bonuses, which a value network's output layer would take thousands of updates to reach
  // (Engstrom et al. 2020, "Implementation Matters in Deep RL", reward scaling). Advantages are normalised
  // per minibatch, so the actor's update does not depend on it.
  double reward_scale = 0.01;
  double entropy_coefficient = 0.0;
  // β of a penalty β KL(π ‖ π₀) = β Σ (μ − μ₀)² / 2σ² (σ held) that anchors the actor's mean μ to the
  // initial actor's μ₀ on the rollout's states (the policy-space form of DAPG's and Jump-Start RL's
  // staying near the demonstrator): where the reward's gradient is weaker than the advantages' noise (the
  // docking's 1 cm alignment), the actor would otherwise random-walk away from what the expert's data taught
  // it. 0: plain PPO.
  double anchor_coefficient = 1.0;
  double max_grad_norm = 0.5;
  double target_kl = 0.02;    // ≤ 0: every epoch runs
  double initial_std = 0.05;  // σ of every action at the start, in actions of [−1, 1]
  int value_warmup_iterations = 5;
  int value_hidden = 256;
  uint64_t seed = 1;
  int threads = 1;        // environment threads
  int torch_threads = 1;  // libtorch's intra-op threads for the policy and the updates (rl/torch_networks.h)
};

/// Who this learner is among several that train one policy together; world 1: alone.
struct PpoWorkers {
  int rank = 0;
  int world = 1;
  // world > 1: the rendezvous, a file every rank can reach (c10d's FileStore), new for each training
  std::string rendezvous_file;
  // what this rank's Gloo connections bind, which the others reach: the address of `interface` (a network
  // interface, e.g. eth0), else `address`, else the one this host's name resolves to
  std::string interface;
  std::string address;
  double timeout_s = 300.0;  // for the other ranks to join, and for any collective step
};

/// One iteration's figures: its rollout's episodes and its update's losses.
struct PpoStats {
  int64_t iteration = 0;  // iterations done, this one included
  int64_t env_steps = 0;  // control steps rolled out, over all iterations
  // episodes that ended within the rollout (stochastic actions)
  int episodes = 0;
  int successes = 0;
  double return_mean = 0.0;
  double docked_step_mean = 0.0;  // over its successes
  // the update, means over the minibatches it ran
  double policy_loss = 0.0;  // clipped surrogate, negated
  double value_loss = 0.0;
  double approx_kl = 0.0;           // E[(r − 1) − log r], r the probability ratio
  double anchor_kl = 0.0;           // KL(π ‖ π₀) to the initial actor, per sample
  double clip_fraction = 0.0;       // share of samples with |r − 1| > clip
  double explained_variance = 0.0;  // of the returns by the rollout's values
  double std_mean = 0.0;            // mean σ of the actions after the update
  int epochs = 0;                   // epochs run (early stop on target_kl)
  bool actor_updated = false;       // false during value warm-up
};

/// GAE(γ, λ) advantages of a rollout of `envs` environments, row k = t · envs + i: rewards r_k (a truncated
/// episode's last one already holding γ V of where it ended), values V_k of the observations acted on,
/// ended_k whether the episode ended at that step (nothing flows back across it), and last_values the values
/// of the observations after the last step, for the episodes still running.
std::vector<float> GeneralizedAdvantages(const std::vector<float>& rewards, const std::vector<float>& values,
                                         const std::vector<float>& ended,
                                         const std::vector<float>& last_values, double discount,
                                         double lambda);

class Ppo {
 public:
  struct Rollout;  // one iteration's samples, advantages and returns (rl/ppo.cc)

  /// A learner on `task` whose actor is `initial_policy`'s (a policy.pt that TD3-BC or PPO exported).
  /// Throws std::invalid_argument naming the file, or the config field that is out of range. With several
  /// `workers`, returns once every rank has joined (std::runtime_error after workers.timeout_s).
  Ppo(const DockingTaskConfig& task, const PpoConfig& config, const std::string& initial_policy,
      const PpoWorkers& workers = {});
  ~Ppo();

  /// Rolls out and updates: Update(*Collect()).
  PpoStats Iterate();
  /// The next iteration's rollout with the current policy (stochastic actions).
  std::shared_ptr<Rollout> Collect();
  /// The update on `rollout`, counted as an iteration (tests update on one rollout repeatedly). With
  /// several workers, every rank calls it at once, each with its own rollout of the same size.
  PpoStats Update(const Rollout& rollout);
  /// Rows [begin, end) of `rollout`: the share of one rank, for comparing workers with one learner on the
  /// same data.
  static std::shared_ptr<Rollout> Rows(const Rollout& rollout, int64_t begin, int64_t end);

  int64_t iteration() const;
  const PpoConfig& config() const;

  /// Writes the networks, log σ, the optimisers, the normalisation, the counters and the random state
  /// (PATH.partial, renamed); Load continues exactly where this left off.
  void Save(const std::string& path) const;
  /// Throws std::runtime_error naming the file for one that is no checkpoint of this learner's shape.
  void Load(const std::string& path);
  /// The deterministic actor (tanh of the mean, no noise) as a TorchScript policy.
  void ExportPolicy(const std::string& path) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iapsim::rl
