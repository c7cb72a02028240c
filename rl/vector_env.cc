#include "rl/vector_env.h"

#include <stdexcept>
#include <string>

#include "physics/random.h"

namespace iapsim::rl {

VectorEnv::VectorEnv(const DockingTaskConfig& config, int count, int threads) {
  if (count < 1) throw std::invalid_argument("a vector of environments needs at least one");
  set_threads(threads);
  envs_.reserve(count);
  envs_.push_back(std::make_unique<DockingEnv>(config));
  for (int i = 1; i < count; ++i) envs_.push_back(std::make_unique<DockingEnv>(envs_[0]->config()));
  observations_.resize(count, kObservationSize);
  final_observations_ = RowMatrix::Zero(count, kObservationSize);
  rewards_ = Eigen::VectorXd::Zero(count);
  terminated_.assign(count, 0);
  truncated_.assign(count, 0);
  infos_.resize(count);
}

VectorEnv::~VectorEnv() = default;

void VectorEnv::set_threads(int threads) {
  if (threads < 1) throw std::invalid_argument("threads must be at least 1, got " + std::to_string(threads));
  threads_ = threads;
}

const RowMatrix& VectorEnv::Reset(uint64_t seed) {
  const int n = count();
#pragma omp parallel for num_threads(threads_) schedule(static)
  for (int i = 0; i < n; ++i) {
    observations_.row(i) = envs_[i]->Reset(physics::StreamSeed(seed, i)).transpose();
  }
  std::fill(terminated_.begin(), terminated_.end(), 0);
  std::fill(truncated_.begin(), truncated_.end(), 0);
  rewards_.setZero();
  return observations_;
}

void VectorEnv::Step(const RowMatrix& actions) {
  const int n = count();
  if (actions.rows() != n || actions.cols() != kActionSize) {
    throw std::invalid_argument("VectorEnv::Step: actions must be " + std::to_string(n) + " x " +
                                std::to_string(kActionSize) + ", got " + std::to_string(actions.rows()) +
                                " x " + std::to_string(actions.cols()));
  }
  if (!actions.allFinite()) throw std::invalid_argument("VectorEnv::Step: an action is not finite");
#pragma omp parallel for num_threads(threads_) schedule(static)
  for (int i = 0; i < n; ++i) {
    Observation observation;
    const StepResult result = envs_[i]->Step(actions.row(i).transpose(), &observation);
    rewards_[i] = result.reward;
    terminated_[i] = result.terminated;
    truncated_[i] = result.truncated;
    infos_[i] = result.info;
    if (result.terminated || result.truncated) {
      final_observations_.row(i) = observation.transpose();
      observation = envs_[i]->Reset();
    }
    observations_.row(i) = observation.transpose();
  }
}

}  // namespace iapsim::rl
