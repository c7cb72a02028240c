#pragma once
// N docking environments stepped together (Gymnasium's vector API): one row of observations, actions,
// rewards and flags per environment, environments stepped in parallel by OpenMP threads, an environment
// whose episode ended started again at once (auto reset). Environment i draws from its own stream, seeded
// from the vector's seed and i, so the whole vector's trajectories are the same for any thread count.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "rl/docking_env.h"

namespace iapsim::rl {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

class VectorEnv {
 public:
  /// `count` environments of `config`, stepped on `threads` threads (at least 1).
  VectorEnv(const DockingTaskConfig& config, int count, int threads);
  ~VectorEnv();

  int count() const { return static_cast<int>(envs_.size()); }
  int threads() const { return threads_; }
  void set_threads(int threads);

  /// Seeds environment i with physics::StreamSeed(seed, i) and starts every episode; returns the
  /// observations (count × kObservationSize).
  const RowMatrix& Reset(uint64_t seed);
  /// Steps environment i with row i of `actions` (count × kActionSize). Where an episode ended, its row of
  /// observations() is already the next episode's first; final_observation(i) holds the last one.
  void Step(const RowMatrix& actions);

  const RowMatrix& observations() const { return observations_; }
  const Eigen::VectorXd& rewards() const { return rewards_; }
  const std::vector<uint8_t>& terminated() const { return terminated_; }
  const std::vector<uint8_t>& truncated() const { return truncated_; }
  const std::vector<StepInfo>& infos() const { return infos_; }
  /// The observation an episode ended on (meaningful where terminated or truncated).
  const RowMatrix& final_observations() const { return final_observations_; }
  DockingEnv& env(int i) { return *envs_[i]; }

 private:
  std::vector<std::unique_ptr<DockingEnv>> envs_;
  int threads_ = 1;
  RowMatrix observations_;
  RowMatrix final_observations_;
  Eigen::VectorXd rewards_;
  std::vector<uint8_t> terminated_, truncated_;
  std::vector<StepInfo> infos_;
};

}  // namespace iapsim::rl
