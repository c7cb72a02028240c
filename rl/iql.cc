#include "rl/iql.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <stdexcept>

#include "rl/torch_networks.h"

namespace iapsim::rl {

double EpisodeReturnRange(const Dataset& data) {
  double lowest = 0.0, highest = 0.0, episode = 0.0;
  bool first = true;
  for (int64_t i = 0; i < data.size(); ++i) {
    episode += data.rewards[i];
    if (data.terminals[i] || data.timeouts[i] || i + 1 == data.size()) {
      lowest = first ? episode : std::min(lowest, episode);
      highest = first ? episode : std::max(highest, episode);
      first = false;
      episode = 0.0;
    }
  }
  return highest - lowest;
}

struct Iql::Impl {
  IqlConfig config;
  OfflineTensors data;
  double reward_scale = 1.0;
  Mlp actor{nullptr}, actor_average{nullptr}, value{nullptr};
  Mlp critic1{nullptr}, critic2{nullptr}, critic1_target{nullptr}, critic2_target{nullptr};
  std::unique_ptr<torch::optim::Adam> actor_optimizer, critic_optimizer, value_optimizer;
  at::Generator generator;
  int64_t step = 0;

  Mlp policy() const { return config.export_average ? actor_average : actor; }
  static torch::Tensor Q(Mlp net, const torch::Tensor& s, const torch::Tensor& a) {
    return net->forward(torch::cat({s, a}, 1));
  }

  // what a checkpoint holds, the step and the random state by way of the tensors given
  Checkpoint Parts(torch::Tensor* step_tensor, torch::Tensor* generator_state) {
    return {
        {{"actor", actor.get()},
         {"actor_average", actor_average.get()},
         {"value", value.get()},
         {"critic1", critic1.get()},
         {"critic2", critic2.get()},
         {"critic1_target", critic1_target.get()},
         {"critic2_target", critic2_target.get()}},
        {{"actor_optimizer", actor_optimizer.get()},
         {"critic_optimizer", critic_optimizer.get()},
         {"value_optimizer", value_optimizer.get()}},
        {{"mean", &data.mean}, {"std", &data.std}, {"step", step_tensor}, {"generator", generator_state}}};
  }

  // The order of the paper's code: V, then the actor and the critics on the new V, then the targets.
  IqlLosses Update(const torch::Tensor& rows) {
    // a TorchScript policy evaluated in between sets one thread (rl/torchscript_policy.h)
    if (at::get_num_threads() != config.threads) at::set_num_threads(config.threads);
    const torch::Tensor s = data.observations.index_select(0, rows), a = data.actions.index_select(0, rows);
    const torch::Tensor r = data.rewards.index_select(0, rows) * reward_scale;
    const torch::Tensor s2 = data.next_observations.index_select(0, rows);
    const torch::Tensor not_done = data.not_done.index_select(0, rows);
    torch::Tensor q_target;
    {
      torch::NoGradGuard no_grad;
      q_target = torch::min(Q(critic1_target, s, a), Q(critic2_target, s, a));
    }
    IqlLosses losses;
    {  // V: the expectile of Q over the data's actions
      const torch::Tensor u = q_target - value->forward(s);
      const torch::Tensor weight = torch::abs(config.expectile - (u < 0).to(torch::kFloat32));
      const torch::Tensor value_loss = (weight * u * u).mean();
      value_optimizer->zero_grad();
      value_loss.backward();
      value_optimizer->step();
      losses.value = value_loss.item<double>();
    }
    torch::Tensor advantage, y;
    {
      torch::NoGradGuard no_grad;
      advantage = q_target - value->forward(s);
      y = r + not_done * config.discount * value->forward(s2);
    }
    {  // the actor: advantage-weighted cloning
      const torch::Tensor weight = torch::exp(config.beta * advantage).clamp_max(config.max_weight);
      const torch::Tensor squared = (torch::tanh(actor->forward(s)) - a).pow(2);
      const torch::Tensor actor_loss = (weight * squared.sum(1, true)).mean();
      actor_optimizer->zero_grad();
      actor_loss.backward();
      actor_optimizer->step();
      losses.actor = actor_loss.item<double>();
      losses.behaviour = squared.mean().item<double>();
    }
    {  // the critics on r + γ V(s′)
      const torch::Tensor critic_loss =
          torch::mse_loss(Q(critic1, s, a), y) + torch::mse_loss(Q(critic2, s, a), y);
      critic_optimizer->zero_grad();
      critic_loss.backward();
      critic_optimizer->step();
      losses.critic = critic_loss.item<double>();
    }
    SoftUpdate(*critic1, *critic1_target, config.tau);
    SoftUpdate(*critic2, *critic2_target, config.tau);
    SoftUpdate(*actor, *actor_average, config.tau);
    losses.step = ++step;
    losses.q_mean = q_target.mean().item<double>();
    losses.advantage_std = advantage.std().item<double>();
    return losses;
  }
};

Iql::Iql(const Dataset& data, const IqlConfig& config) : impl_(std::make_unique<Impl>()) {
  if (config.threads < 1) throw std::invalid_argument("IQL: threads must be at least 1");
  if (data.size() < config.batch) {
    throw std::invalid_argument("IQL: the data set has " + std::to_string(data.size()) +
                                " transitions, fewer than a batch (" + std::to_string(config.batch) + ")");
  }
  if (!(config.expectile > 0.0 && config.expectile < 1.0)) {
    throw std::invalid_argument("IQL: the expectile must lie in (0, 1), got " +
                                std::to_string(config.expectile));
  }
  Impl& impl = *impl_;
  impl.config = config;
  if (config.normalize_rewards) {
    const double range = EpisodeReturnRange(data);
    if (!(range > 0.0)) {
      throw std::invalid_argument(
          "IQL: every episode of the data set has the same return; its rewards "
          "cannot be normalised by their range");
    }
    impl.reward_scale = 1000.0 / range;
  }
  torch::manual_seed(config.seed);  // the networks' initial weights
  impl.generator = at::detail::createCPUGenerator(config.seed);
  impl.data = ToTensors(data);
  const int64_t h = config.hidden;
  impl.actor = Mlp(kObservationSize, h, kActionSize);
  impl.actor_average = Mlp(kObservationSize, h, kActionSize);
  impl.value = Mlp(kObservationSize, h, 1);
  impl.critic1 = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic2 = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic1_target = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic2_target = Mlp(kObservationSize + kActionSize, h, 1);
  SoftUpdate(*impl.actor, *impl.actor_average, 1.0);
  SoftUpdate(*impl.critic1, *impl.critic1_target, 1.0);
  SoftUpdate(*impl.critic2, *impl.critic2_target, 1.0);
  const torch::optim::AdamOptions adam(config.learning_rate);
  impl.actor_optimizer = std::make_unique<torch::optim::Adam>(impl.actor->parameters(), adam);
  impl.value_optimizer = std::make_unique<torch::optim::Adam>(impl.value->parameters(), adam);
  std::vector<torch::Tensor> critics = impl.critic1->parameters();
  for (const torch::Tensor& p : impl.critic2->parameters()) critics.push_back(p);
  impl.critic_optimizer = std::make_unique<torch::optim::Adam>(critics, adam);
}

Iql::~Iql() = default;

int64_t Iql::step() const { return impl_->step; }

double Iql::reward_scale() const { return impl_->reward_scale; }

double Iql::Value(const Observation& observation) const {
  torch::NoGradGuard no_grad;
  const torch::Tensor in =
      torch::from_blob(const_cast<double*>(observation.data()), {1, kObservationSize}, torch::kFloat64)
          .to(torch::kFloat32);
  return impl_->value->forward(Normalise(in, impl_->data.mean, impl_->data.std)).item<double>();
}

Action Iql::Act(const Observation& observation) const {
  return ActOn(impl_->policy(), impl_->data.mean, impl_->data.std, observation);
}

IqlLosses Iql::Update() {
  Impl& impl = *impl_;
  return impl.Update(
      torch::randint(impl.data.observations.size(0), {impl.config.batch}, impl.generator, torch::kLong));
}

IqlLosses Iql::UpdateOn(int64_t first) {
  return impl_->Update(torch::arange(first, first + impl_->config.batch, torch::kLong));
}

void Iql::Save(const std::string& path) const {
  torch::Tensor step = torch::tensor(impl_->step, torch::kLong), generator = impl_->generator.get_state();
  impl_->Parts(&step, &generator).Save(path);
}

void Iql::Load(const std::string& path) {
  torch::Tensor step, generator;
  impl_->Parts(&step, &generator).Load(path, "IQL");
  impl_->step = step.item<int64_t>();
  impl_->generator.set_state(generator);
}

void Iql::ExportPolicy(const std::string& path) const {
  ExportActor(path, impl_->policy(), impl_->data.mean, impl_->data.std);
}

}  // namespace iapsim::rl
