#include "rl/ppo.h"

#include <ATen/Parallel.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "physics/random.h"
#include "rl/torch_networks.h"
#include "rl/vector_env.h"

namespace iapsim::rl {
namespace {

const double kLogSqrt2Pi = 0.5 * std::log(2.0 * M_PI);

// log N(a; μ, σ²) of each row, summed over the action's dimensions
torch::Tensor LogProbability(const torch::Tensor& action, const torch::Tensor& mean,
                             const torch::Tensor& log_std) {
  return (-0.5 * ((action - mean) / log_std.exp()).pow(2) - log_std - kLogSqrt2Pi).sum(-1);
}

torch::Tensor ToTensor(const RowMatrix& rows) {
  return torch::from_blob(const_cast<double*>(rows.data()), {rows.rows(), rows.cols()}, torch::kFloat64)
      .to(torch::kFloat32);
}

void Require(bool ok, const char* field, const std::string& expected) {
  if (!ok) throw std::invalid_argument(std::string("PPO: ") + field + " must be " + expected);
}

}  // namespace

std::vector<float> GeneralizedAdvantages(const std::vector<float>& rewards, const std::vector<float>& values,
                                         const std::vector<float>& ended,
                                         const std::vector<float>& last_values, double discount,
                                         double lambda) {
  const size_t n = last_values.size();
  if (n == 0 || rewards.size() % n != 0 || values.size() != rewards.size() ||
      ended.size() != rewards.size()) {
    throw std::invalid_argument("GeneralizedAdvantages: rewards, values and ended must be steps x envs long");
  }
  std::vector<float> advantages(rewards.size());
  std::vector<double> next_value(last_values.begin(), last_values.end()), next_advantage(n, 0.0);
  for (size_t k = rewards.size(); k-- > 0;) {
    const size_t i = k % n;
    const double going_on = 1.0 - ended[k];
    const double delta = rewards[k] + discount * going_on * next_value[i] - values[k];
    next_advantage[i] = delta + discount * lambda * going_on * next_advantage[i];
    next_value[i] = values[k];
    advantages[k] = static_cast<float>(next_advantage[i]);
  }
  return advantages;
}

struct Ppo::Rollout {
  // row k = t · envs + i: environment i at step t; observations normalised
  torch::Tensor observations, actions, log_probs, values, advantages, returns;
  int episodes = 0, successes = 0;
  double return_sum = 0.0, docked_step_sum = 0.0;
};

struct Ppo::Impl {
  PpoConfig config;
  std::unique_ptr<VectorEnv> envs;
  Mlp actor{nullptr}, value{nullptr};
  Mlp anchor{nullptr};  // the initial actor, frozen
  torch::Tensor log_std, mean, std;
  std::unique_ptr<torch::optim::Adam> actor_optimizer, value_optimizer;
  at::Generator generator;
  int64_t iteration = 0, env_steps = 0;

  void UseThreads() const {
    // a TorchScript policy evaluated in between sets one thread (rl/torchscript_policy.h)
    if (at::get_num_threads() != config.threads) at::set_num_threads(config.threads);
  }
  torch::Tensor Mean(const torch::Tensor& s) { return torch::tanh(actor->forward(s)); }
  torch::Tensor Value(const torch::Tensor& s) { return value->forward(s).squeeze(-1); }
  std::vector<torch::Tensor> ActorParameters() const {
    std::vector<torch::Tensor> parameters = actor->parameters();
    parameters.push_back(log_std);
    return parameters;
  }
};

Ppo::Ppo(const DockingTaskConfig& task, const PpoConfig& config, const std::string& initial_policy)
    : impl_(std::make_unique<Impl>()) {
  Require(config.envs >= 1, "envs", "at least 1");
  Require(config.rollout_steps >= 1, "rollout_steps", "at least 1");
  Require(config.epochs >= 1, "epochs", "at least 1");
  Require(config.minibatch >= 2, "minibatch", "at least 2 (advantages are normalised per minibatch)");
  Require(config.threads >= 1, "threads", "at least 1");
  Require(config.clip > 0.0, "clip", "positive");
  Require(config.initial_std > 0.0, "initial_std", "positive");
  Require(config.reward_scale > 0.0, "reward_scale", "positive");
  Require(config.anchor_coefficient >= 0.0, "anchor_coefficient", "at least 0");
  Require(config.discount > 0.0 && config.discount <= 1.0, "discount", "in (0, 1]");
  Require(config.gae_lambda >= 0.0 && config.gae_lambda <= 1.0, "gae_lambda", "in [0, 1]");
  Require(
      task.reward.shaping != DockingReward::Shaping::kPotential || config.discount == task.reward.discount,
      "discount",
      "the task's reward.discount (" + std::to_string(task.reward.discount) +
          ") under potential shaping, which keeps the optimal policy only for the same γ");
  Impl& impl = *impl_;
  impl.config = config;
  ActorFile start = ReadActor(initial_policy);
  impl.actor = start.actor;
  impl.mean = start.mean;
  impl.std = start.std;
  impl.anchor = ReadActor(initial_policy).actor;
  for (torch::Tensor& p : impl.anchor->parameters()) p.requires_grad_(false);
  torch::manual_seed(config.seed);  // the value network's initial weights
  impl.value = Mlp(kObservationSize, config.value_hidden, 1);
  impl.log_std = torch::full({kActionSize}, std::log(config.initial_std), torch::kFloat32).requires_grad_();
  impl.generator = at::detail::createCPUGenerator(config.seed);
  impl.actor_optimizer = std::make_unique<torch::optim::Adam>(
      impl.ActorParameters(), torch::optim::AdamOptions(config.actor_learning_rate).eps(1e-5));
  impl.value_optimizer = std::make_unique<torch::optim::Adam>(
      impl.value->parameters(), torch::optim::AdamOptions(config.value_learning_rate).eps(1e-5));
  impl.envs = std::make_unique<VectorEnv>(task, config.envs, config.threads);
}

Ppo::~Ppo() = default;

int64_t Ppo::iteration() const { return impl_->iteration; }
const PpoConfig& Ppo::config() const { return impl_->config; }

PpoStats Ppo::Iterate() { return Update(*Collect()); }

std::shared_ptr<Ppo::Rollout> Ppo::Collect() {
  Impl& impl = *impl_;
  const PpoConfig& c = impl.config;
  impl.UseThreads();
  torch::NoGradGuard no_grad;
  const int n = c.envs;
  const int steps = c.rollout_steps;
  VectorEnv& envs = *impl.envs;
  envs.Reset(physics::StreamSeed(c.seed, static_cast<uint64_t>(impl.iteration)));
  auto rollout = std::make_shared<Rollout>();
  std::vector<torch::Tensor> observations, actions, log_probs;
  std::vector<float> rewards(static_cast<size_t>(steps) * n), values(rewards.size()), ended(rewards.size());
  std::vector<double> episode_return(n, 0.0);
  RowMatrix action_rows(n, kActionSize);
  const torch::Tensor sigma = impl.log_std.exp();
  for (int t = 0; t < steps; ++t) {
    const torch::Tensor s = Normalise(ToTensor(envs.observations()), impl.mean, impl.std);
    const torch::Tensor mu = impl.Mean(s);
    const torch::Tensor a =
        (mu + sigma * torch::randn({n, kActionSize}, impl.generator, torch::kFloat32)).contiguous();
    const torch::Tensor v = impl.Value(s).contiguous();
    std::copy(v.data_ptr<float>(), v.data_ptr<float>() + n, values.begin() + static_cast<size_t>(t) * n);
    observations.push_back(s);
    actions.push_back(a);
    log_probs.push_back(LogProbability(a, mu, impl.log_std));
    action_rows = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
                      a.data_ptr<float>(), n, kActionSize)
                      .cast<double>();
    envs.Step(action_rows);  // the environments clip the actions to [−1, 1]; the samples stay as drawn
    for (int i = 0; i < n; ++i) {
      const size_t k = static_cast<size_t>(t) * n + i;
      episode_return[i] += envs.rewards()[i];
      double reward = c.reward_scale * envs.rewards()[i];
      if (envs.terminated()[i] || envs.truncated()[i]) {
        ended[k] = 1.0f;
        const StepInfo& info = envs.infos()[i];
        ++rollout->episodes;
        rollout->return_sum += episode_return[i];
        episode_return[i] = 0.0;
        if (info.outcome == Outcome::kSuccess) {
          ++rollout->successes;
          rollout->docked_step_sum += info.docked_step;
        }
      }
      if (envs.truncated()[i]) {  // out of time, not a terminal state: bootstrap from where it ended
        const RowMatrix final_observation = envs.final_observations().row(i);
        reward += c.discount *
                  impl.Value(Normalise(ToTensor(final_observation), impl.mean, impl.std)).item<double>();
      }
      rewards[k] = static_cast<float>(reward);
    }
  }
  const torch::Tensor last =
      impl.Value(Normalise(ToTensor(envs.observations()), impl.mean, impl.std)).contiguous();
  std::vector<float> advantages = GeneralizedAdvantages(
      rewards, values, ended, std::vector<float>(last.data_ptr<float>(), last.data_ptr<float>() + n),
      c.discount, c.gae_lambda);
  const auto column = [](std::vector<float>& v) {
    return torch::from_blob(v.data(), {static_cast<int64_t>(v.size())}, torch::kFloat32).clone();
  };
  rollout->observations = torch::cat(observations);
  rollout->actions = torch::cat(actions);
  rollout->log_probs = torch::cat(log_probs);
  rollout->values = column(values);
  rollout->advantages = column(advantages);
  rollout->returns = rollout->advantages + rollout->values;
  return rollout;
}

PpoStats Ppo::Update(const Rollout& rollout) {
  Impl& impl = *impl_;
  const PpoConfig& c = impl.config;
  impl.UseThreads();
  PpoStats stats;
  stats.actor_updated = impl.iteration >= c.value_warmup_iterations;
  const int64_t total = rollout.observations.size(0);
  const int64_t minibatch = std::min<int64_t>(c.minibatch, total);
  int value_batches = 0, actor_batches = 0;
  bool stop = false;
  for (int epoch = 0; epoch < c.epochs && !stop; ++epoch) {
    ++stats.epochs;
    const torch::Tensor order = torch::randperm(total, impl.generator, torch::kLong);
    for (int64_t first = 0; first + minibatch <= total; first += minibatch) {
      const torch::Tensor rows = order.slice(0, first, first + minibatch);
      const torch::Tensor s = rollout.observations.index_select(0, rows);
      if (stats.actor_updated) {
        const torch::Tensor a = rollout.actions.index_select(0, rows);
        torch::Tensor advantage = rollout.advantages.index_select(0, rows);
        advantage = (advantage - advantage.mean()) / (advantage.std() + 1e-8);
        const torch::Tensor mean = impl.Mean(s);
        const torch::Tensor log_ratio =
            LogProbability(a, mean, impl.log_std) - rollout.log_probs.index_select(0, rows);
        const torch::Tensor ratio = log_ratio.exp();
        torch::Tensor anchor_mean;
        double kl = 0.0, clipped = 0.0;
        {
          torch::NoGradGuard no_grad;
          kl = ((ratio - 1.0) - log_ratio).mean().item<double>();
          clipped = ((ratio - 1.0).abs() > c.clip).to(torch::kFloat32).mean().item<double>();
          anchor_mean = torch::tanh(impl.anchor->forward(s));
        }
        if (c.target_kl > 0.0 && kl > 1.5 * c.target_kl) {  // the policy moved far enough: stop here
          stop = true;
          break;
        }
        const torch::Tensor surrogate =
            -torch::min(ratio * advantage, ratio.clamp(1.0 - c.clip, 1.0 + c.clip) * advantage).mean();
        const torch::Tensor entropy = (impl.log_std + 0.5 + kLogSqrt2Pi).sum();
        const torch::Tensor anchor_kl =
            ((mean - anchor_mean).pow(2) / (2.0 * (2.0 * impl.log_std.detach()).exp())).sum(-1).mean();
        const torch::Tensor actor_loss =
            surrogate - c.entropy_coefficient * entropy + c.anchor_coefficient * anchor_kl;
        impl.actor_optimizer->zero_grad();
        actor_loss.backward();
        torch::nn::utils::clip_grad_norm_(impl.ActorParameters(), c.max_grad_norm);
        impl.actor_optimizer->step();
        ++actor_batches;
        stats.policy_loss += surrogate.item<double>();
        stats.anchor_kl += anchor_kl.item<double>();
        stats.approx_kl += kl;
        stats.clip_fraction += clipped;
      }
      const torch::Tensor value_loss = torch::mse_loss(impl.Value(s), rollout.returns.index_select(0, rows));
      impl.value_optimizer->zero_grad();
      value_loss.backward();
      torch::nn::utils::clip_grad_norm_(impl.value->parameters(), c.max_grad_norm);
      impl.value_optimizer->step();
      stats.value_loss += value_loss.item<double>();
      ++value_batches;
    }
  }
  if (value_batches > 0) stats.value_loss /= value_batches;
  if (actor_batches > 0) {
    stats.policy_loss /= actor_batches;
    stats.approx_kl /= actor_batches;
    stats.anchor_kl /= actor_batches;
    stats.clip_fraction /= actor_batches;
  }
  {
    torch::NoGradGuard no_grad;
    const double variance = rollout.returns.var().item<double>();
    stats.explained_variance =
        variance > 0.0 ? 1.0 - (rollout.returns - rollout.values).var().item<double>() / variance : 0.0;
    stats.std_mean = impl.log_std.exp().mean().item<double>();
  }
  ++impl.iteration;
  impl.env_steps += total;
  stats.iteration = impl.iteration;
  stats.env_steps = impl.env_steps;
  stats.episodes = rollout.episodes;
  stats.successes = rollout.successes;
  stats.return_mean = rollout.episodes > 0 ? rollout.return_sum / rollout.episodes : 0.0;
  stats.docked_step_mean = rollout.successes > 0 ? rollout.docked_step_sum / rollout.successes : 0.0;
  return stats;
}

void Ppo::Save(const std::string& path) const {
  const Impl& impl = *impl_;
  torch::serialize::OutputArchive archive;
  WriteModule(archive, "actor", *impl.actor);
  WriteModule(archive, "value", *impl.value);
  WriteModule(archive, "anchor", *impl.anchor);
  archive.write("log_std", impl.log_std);
  torch::serialize::OutputArchive actor_optimizer, value_optimizer;
  impl.actor_optimizer->save(actor_optimizer);
  impl.value_optimizer->save(value_optimizer);
  archive.write("actor_optimizer", actor_optimizer);
  archive.write("value_optimizer", value_optimizer);
  archive.write("mean", impl.mean);
  archive.write("std", impl.std);
  archive.write("iteration", torch::tensor(impl.iteration, torch::kLong));
  archive.write("env_steps", torch::tensor(impl.env_steps, torch::kLong));
  archive.write("generator", impl.generator.get_state());
  SaveArchive(archive, path);
}

void Ppo::Load(const std::string& path) {
  Impl& impl = *impl_;
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(path);
    ReadModule(archive, "actor", *impl.actor);
    ReadModule(archive, "value", *impl.value);
    ReadModule(archive, "anchor", *impl.anchor);
    archive.read("log_std", impl.log_std);
    if (impl.log_std.sizes() != torch::IntArrayRef({kActionSize})) {
      throw std::runtime_error("log_std is not one per action");
    }
    torch::serialize::InputArchive actor_optimizer, value_optimizer;
    archive.read("actor_optimizer", actor_optimizer);
    archive.read("value_optimizer", value_optimizer);
    impl.actor_optimizer->load(actor_optimizer);
    impl.value_optimizer->load(value_optimizer);
    archive.read("mean", impl.mean);
    archive.read("std", impl.std);
    torch::Tensor iteration, env_steps, generator;
    archive.read("iteration", iteration);
    archive.read("env_steps", env_steps);
    archive.read("generator", generator);
    impl.iteration = iteration.item<int64_t>();
    impl.env_steps = env_steps.item<int64_t>();
    impl.generator.set_state(generator);
  } catch (const std::exception& error) {  // c10::Error: no archive, a missing key, a shape that differs
    const std::string what = error.what();
    throw std::runtime_error(path + ": not a PPO checkpoint of this shape (" +
                             what.substr(0, what.find('\n')) + ")");
  }
}

void Ppo::ExportPolicy(const std::string& path) const {
  ExportActor(path, impl_->actor, impl_->mean, impl_->std);
}

}  // namespace iapsim::rl
