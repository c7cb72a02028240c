#include "rl/ppo.h"

#include <ATen/Parallel.h>

#include <chrono>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <torch/csrc/distributed/c10d/FileStore.hpp>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
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
  at::Generator generator;  // the update's permutations (equal on every rank), and alone the rollout's noise
  int64_t iteration = 0, env_steps = 0;
  PpoWorkers workers;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> group;  // several workers: the others

  // `values` summed over the ranks, in place (alone: as they are)
  void SumAcrossRanks(torch::Tensor& values) {
    if (!group) return;
    std::vector<torch::Tensor> buffers{values};
    group->allreduce(buffers)->wait();
  }
  // The gradients of `parameters` summed over the ranks, in one all-reduce with `figures` (returned summed)
  std::vector<double> SumGradients(const std::vector<torch::Tensor>& parameters,
                                   std::vector<double> figures) {
    if (!group) return figures;
    std::vector<torch::Tensor> parts;
    for (const torch::Tensor& p : parameters) {
      parts.push_back(p.grad().defined() ? p.grad().reshape(-1) : torch::zeros({p.numel()}));
    }
    parts.push_back(torch::tensor(std::vector<float>(figures.begin(), figures.end())));
    torch::Tensor flat = torch::cat(parts);
    SumAcrossRanks(flat);
    int64_t at = 0;
    for (const torch::Tensor& p : parameters) {
      if (p.grad().defined()) p.mutable_grad().copy_(flat.slice(0, at, at + p.numel()).view_as(p));
      at += p.numel();
    }
    for (double& figure : figures) figure = flat[at++].item<double>();
    return figures;
  }

  void UseThreads() const {
    // a TorchScript policy evaluated in between sets one thread (rl/torchscript_policy.h)
    if (at::get_num_threads() != config.torch_threads) at::set_num_threads(config.torch_threads);
  }
  torch::Tensor Mean(const torch::Tensor& s) { return torch::tanh(actor->forward(s)); }
  torch::Tensor Value(const torch::Tensor& s) { return value->forward(s).squeeze(-1); }
  std::vector<torch::Tensor> ActorParameters() const {
    std::vector<torch::Tensor> parameters = actor->parameters();
    parameters.push_back(log_std);
    return parameters;
  }
};

Ppo::Ppo(const DockingTaskConfig& task, const PpoConfig& config, const std::string& initial_policy,
         const PpoWorkers& workers)
    : impl_(std::make_unique<Impl>()) {
  Require(workers.world >= 1, "workers", "at least 1");
  Require(workers.rank >= 0 && workers.rank < workers.world, "rank", "in [0, workers)");
  Require(workers.world == 1 || !workers.rendezvous_file.empty(), "rendezvous_file",
          "given for several workers");
  Require(config.envs >= 1, "envs", "at least 1");
  Require(config.rollout_steps >= 1, "rollout_steps", "at least 1");
  Require(config.epochs >= 1, "epochs", "at least 1");
  Require(config.minibatch >= 2, "minibatch", "at least 2 (advantages are normalised per minibatch)");
  Require(config.threads >= 1, "threads", "at least 1");
  Require(config.torch_threads >= 1, "torch_threads", "at least 1");
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
  {
    // The value network's initial weights come from torch's process-wide generator, which building any
    // network draws from (ReadActor's too, before it loads the weights): learners made at once on several
    // threads (a test's workers) take turns for all of it, or one's draws would shift the other's seeded ones
    static std::mutex seeding;
    const std::lock_guard<std::mutex> lock(seeding);
    ActorFile start = ReadActor(initial_policy);
    impl.actor = start.actor;
    impl.mean = start.mean;
    impl.std = start.std;
    impl.anchor = ReadActor(initial_policy).actor;
    torch::manual_seed(config.seed);
    impl.value = Mlp(kObservationSize, config.value_hidden, 1);
  }
  for (torch::Tensor& p : impl.anchor->parameters()) p.requires_grad_(false);
  impl.log_std = torch::full({kActionSize}, std::log(config.initial_std), torch::kFloat32).requires_grad_();
  impl.generator = at::detail::createCPUGenerator(config.seed);
  impl.actor_optimizer = std::make_unique<torch::optim::Adam>(
      impl.ActorParameters(), torch::optim::AdamOptions(config.actor_learning_rate).eps(1e-5));
  impl.value_optimizer = std::make_unique<torch::optim::Adam>(
      impl.value->parameters(), torch::optim::AdamOptions(config.value_learning_rate).eps(1e-5));
  impl.envs = std::make_unique<VectorEnv>(task, config.envs, config.threads);
  impl.workers = workers;
  if (workers.world > 1) {
    const auto timeout = std::chrono::milliseconds(static_cast<int64_t>(workers.timeout_s * 1000.0));
    try {
      auto store = c10::make_intrusive<c10d::FileStore>(workers.rendezvous_file, workers.world);
      store->setTimeout(timeout);
      auto options = c10d::ProcessGroupGloo::Options::create();
      options->timeout = timeout;
      options->devices.push_back(
          !workers.interface.empty() ? c10d::ProcessGroupGloo::createDeviceForInterface(workers.interface)
          : !workers.address.empty() ? c10d::ProcessGroupGloo::createDeviceForHostname(workers.address)
                                     : c10d::ProcessGroupGloo::createDefaultDevice());
      impl.group = c10::make_intrusive<c10d::ProcessGroupGloo>(store, workers.rank, workers.world, options);
    } catch (const std::exception& error) {  // c10::Error: a rank that never came, an address not here
      const std::string what = error.what();
      throw std::runtime_error("PPO worker " + std::to_string(workers.rank) + " of " +
                               std::to_string(workers.world) + ": no rendezvous through " +
                               workers.rendezvous_file + " (" + what.substr(0, what.find('\n')) + ")");
    }
  }
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
  // alone: the episodes of the stream (seed, iteration), the noise from the learner's generator; rank r of W:
  // the stream (seed, iteration, r) and the noise of (seed, iteration, W + r), the generator kept for the
  // update's permutations, which must be equal on every rank
  uint64_t stream = physics::StreamSeed(c.seed, static_cast<uint64_t>(impl.iteration));
  at::Generator noise = impl.generator;
  if (impl.group) {
    const auto world = static_cast<uint64_t>(impl.workers.world),
               rank = static_cast<uint64_t>(impl.workers.rank);
    noise = at::detail::createCPUGenerator(physics::StreamSeed(stream, world + rank));
    stream = physics::StreamSeed(stream, rank);
  }
  envs.Reset(stream);
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
        (mu + sigma * torch::randn({n, kActionSize}, noise, torch::kFloat32)).contiguous();
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
  const int world = impl.workers.world;
  const int64_t local = rollout.observations.size(0);
  const int64_t total = local * world;  // rank r's rows are [r local, (r + 1) local) of the global rollout
  if (world > 1) {
    // float64: exact for any rollout (torch::tensor of doubles would be float32, which n² may not fit)
    torch::Tensor sizes =
        torch::tensor({static_cast<double>(local), static_cast<double>(local * local)}, torch::kFloat64);
    impl.SumAcrossRanks(sizes);  // Σn = W n and Σn² = W n² only if every rank has n rows
    if (sizes[0].item<double>() != static_cast<double>(total) ||
        sizes[1].item<double>() != static_cast<double>(total * local)) {
      throw std::runtime_error("PPO worker " + std::to_string(impl.workers.rank) +
                               ": the ranks' rollouts differ in size (envs and rollout_steps must be equal)");
    }
  }
  const int64_t minibatch = std::min<int64_t>(static_cast<int64_t>(c.minibatch) * world, total);
  // a minibatch's mean: alone, of its rows; rank r, its rows' share of the global minibatch's
  const auto average = [&](const torch::Tensor& per_row) {
    return world == 1 ? per_row.mean() : per_row.sum() / static_cast<double>(minibatch);
  };
  int value_batches = 0, actor_batches = 0;
  bool stop = false;
  for (int epoch = 0; epoch < c.epochs && !stop; ++epoch) {
    ++stats.epochs;
    const torch::Tensor order = torch::randperm(total, impl.generator, torch::kLong);
    for (int64_t first = 0; first + minibatch <= total; first += minibatch) {
      torch::Tensor rows = order.slice(0, first, first + minibatch);
      if (world > 1) {
        const torch::Tensor shifted = rows - impl.workers.rank * local;
        rows = shifted.masked_select(shifted.ge(0).logical_and(shifted.lt(local)));
      }
      const torch::Tensor s = rollout.observations.index_select(0, rows);
      if (stats.actor_updated) {
        const torch::Tensor a = rollout.actions.index_select(0, rows);
        torch::Tensor advantage = rollout.advantages.index_select(0, rows);
        const torch::Tensor mean = impl.Mean(s);
        const torch::Tensor log_ratio =
            LogProbability(a, mean, impl.log_std) - rollout.log_probs.index_select(0, rows);
        const torch::Tensor ratio = log_ratio.exp();
        torch::Tensor anchor_mean;
        double kl = 0.0, clipped = 0.0;
        {
          torch::NoGradGuard no_grad;
          const torch::Tensor kl_rows = (ratio - 1.0) - log_ratio;
          const torch::Tensor clipped_rows = ((ratio - 1.0).abs() > c.clip).to(torch::kFloat32);
          if (world == 1) {
            advantage = (advantage - advantage.mean()) / (advantage.std() + 1e-8);
            kl = kl_rows.mean().item<double>();
            clipped = clipped_rows.mean().item<double>();
          } else {  // the global minibatch's: mean and σ of the advantages (unbiased, as std()), KL, clipping
            torch::Tensor sums =
                torch::stack({advantage.sum(), advantage.pow(2).sum(), kl_rows.sum(), clipped_rows.sum()})
                    .to(torch::kFloat64);
            impl.SumAcrossRanks(sums);
            const double m = static_cast<double>(minibatch), advantage_mean = sums[0].item<double>() / m;
            const double variance =
                (sums[1].item<double>() - m * advantage_mean * advantage_mean) / (m - 1.0);
            advantage = (advantage - advantage_mean) / (std::sqrt(std::max(0.0, variance)) + 1e-8);
            kl = sums[2].item<double>() / m;
            clipped = sums[3].item<double>() / m;
          }
          anchor_mean = torch::tanh(impl.anchor->forward(s));
        }
        if (c.target_kl > 0.0 && kl > 1.5 * c.target_kl) {  // the policy moved far enough: stop here
          stop = true;
          break;
        }
        const torch::Tensor surrogate =
            -average(torch::min(ratio * advantage, ratio.clamp(1.0 - c.clip, 1.0 + c.clip) * advantage));
        // not a mean over rows: each rank adds its share
        const torch::Tensor entropy = (impl.log_std + 0.5 + kLogSqrt2Pi).sum() / world;
        const torch::Tensor anchor_kl =
            average(((mean - anchor_mean).pow(2) / (2.0 * (2.0 * impl.log_std.detach()).exp())).sum(-1));
        const torch::Tensor actor_loss =
            surrogate - c.entropy_coefficient * entropy + c.anchor_coefficient * anchor_kl;
        impl.actor_optimizer->zero_grad();
        actor_loss.backward();
        const std::vector<double> figures =
            impl.SumGradients(impl.ActorParameters(), {surrogate.item<double>(), anchor_kl.item<double>()});
        torch::nn::utils::clip_grad_norm_(impl.ActorParameters(), c.max_grad_norm);
        impl.actor_optimizer->step();
        ++actor_batches;
        stats.policy_loss += figures[0];
        stats.anchor_kl += figures[1];
        stats.approx_kl += kl;
        stats.clip_fraction += clipped;
      }
      const torch::Tensor returns = rollout.returns.index_select(0, rows);
      const torch::Tensor value_loss =
          world == 1 ? torch::mse_loss(impl.Value(s), returns) : average((impl.Value(s) - returns).pow(2));
      impl.value_optimizer->zero_grad();
      value_loss.backward();
      const std::vector<double> figures =
          impl.SumGradients(impl.value->parameters(), {value_loss.item<double>()});
      torch::nn::utils::clip_grad_norm_(impl.value->parameters(), c.max_grad_norm);
      impl.value_optimizer->step();
      stats.value_loss += figures[0];
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
  // the rollout's figures: the global rollout's with several workers
  torch::Tensor sums;
  {
    torch::NoGradGuard no_grad;
    const torch::Tensor residual = rollout.returns - rollout.values;
    sums = torch::stack(
               {rollout.returns.sum(), rollout.returns.pow(2).sum(), residual.sum(), residual.pow(2).sum()})
               .to(torch::kFloat64);
    sums = torch::cat(
        {sums, torch::tensor({static_cast<double>(rollout.episodes), static_cast<double>(rollout.successes),
                              rollout.return_sum, rollout.docked_step_sum},
                             torch::kFloat64)});
    impl.SumAcrossRanks(sums);
    stats.std_mean = impl.log_std.exp().mean().item<double>();
  }
  const double n = static_cast<double>(total);
  const auto unbiased_variance = [&](int at) {
    const double sum = sums[at].item<double>(), squares = sums[at + 1].item<double>();
    return (squares - sum * sum / n) / (n - 1.0);
  };
  const double variance = world == 1 ? rollout.returns.var().item<double>() : unbiased_variance(0);
  const double residual_variance =
      world == 1 ? (rollout.returns - rollout.values).var().item<double>() : unbiased_variance(2);
  stats.explained_variance = variance > 0.0 ? 1.0 - residual_variance / variance : 0.0;
  ++impl.iteration;
  impl.env_steps += total;
  stats.iteration = impl.iteration;
  stats.env_steps = impl.env_steps;
  stats.episodes = static_cast<int>(sums[4].item<double>());
  stats.successes = static_cast<int>(sums[5].item<double>());
  stats.return_mean = stats.episodes > 0 ? sums[6].item<double>() / stats.episodes : 0.0;
  stats.docked_step_mean = stats.successes > 0 ? sums[7].item<double>() / stats.successes : 0.0;
  return stats;
}

std::shared_ptr<Ppo::Rollout> Ppo::Rows(const Rollout& rollout, int64_t begin, int64_t end) {
  auto rows = std::make_shared<Rollout>();
  for (auto [to, from] :
       {std::pair{&rows->observations, &rollout.observations}, std::pair{&rows->actions, &rollout.actions},
        std::pair{&rows->log_probs, &rollout.log_probs}, std::pair{&rows->values, &rollout.values},
        std::pair{&rows->advantages, &rollout.advantages}, std::pair{&rows->returns, &rollout.returns}}) {
    *to = from->slice(0, begin, end).clone();
  }
  if (begin == 0) {  // the episodes go with the first share
    rows->episodes = rollout.episodes;
    rows->successes = rollout.successes;
    rows->return_sum = rollout.return_sum;
    rows->docked_step_sum = rollout.docked_step_sum;
  }
  return rows;
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
