#include "rl/td3bc.h"

#include <ATen/Parallel.h>

#include <stdexcept>

#include "rl/torch_networks.h"

namespace iapsim::rl {

struct Td3Bc::Impl {
  Td3BcConfig config;
  OfflineTensors data;
  Mlp actor{nullptr}, actor_target{nullptr};
  Mlp critic1{nullptr}, critic2{nullptr}, critic1_target{nullptr}, critic2_target{nullptr};
  std::unique_ptr<torch::optim::Adam> actor_optimizer, critic_optimizer;
  at::Generator generator;
  int64_t step = 0;
  double last_actor = 0.0, last_behaviour = 0.0;

  static torch::Tensor Act(Mlp net, const torch::Tensor& s) { return torch::tanh(net->forward(s)); }
  Mlp policy() const { return config.export_average ? actor_target : actor; }
  static torch::Tensor Q(Mlp net, const torch::Tensor& s, const torch::Tensor& a) {
    return net->forward(torch::cat({s, a}, 1));
  }

  // what a checkpoint holds, the step and the random state by way of the tensors given
  Checkpoint Parts(torch::Tensor* step_tensor, torch::Tensor* generator_state) {
    return {
        {{"actor", actor.get()},
         {"actor_target", actor_target.get()},
         {"critic1", critic1.get()},
         {"critic2", critic2.get()},
         {"critic1_target", critic1_target.get()},
         {"critic2_target", critic2_target.get()}},
        {{"actor_optimizer", actor_optimizer.get()}, {"critic_optimizer", critic_optimizer.get()}},
        {{"mean", &data.mean}, {"std", &data.std}, {"step", step_tensor}, {"generator", generator_state}}};
  }

  Td3BcLosses Update(const torch::Tensor& rows) {
    // a TorchScript policy evaluated in between sets one thread (rl/torchscript_policy.h)
    if (at::get_num_threads() != config.threads) at::set_num_threads(config.threads);
    const torch::Tensor s = data.observations.index_select(0, rows), a = data.actions.index_select(0, rows);
    const torch::Tensor r = data.rewards.index_select(0, rows);
    const torch::Tensor s2 = data.next_observations.index_select(0, rows);
    const torch::Tensor not_done_rows = data.not_done.index_select(0, rows);
    torch::Tensor y;
    {
      torch::NoGradGuard no_grad;
      // target policy smoothing: the target actor's action with clipped noise
      const torch::Tensor noise = (torch::randn(a.sizes(), generator, torch::kFloat32) * config.policy_noise)
                                      .clamp(-config.noise_clip, config.noise_clip);
      const torch::Tensor a2 = (Act(actor_target, s2) + noise).clamp(-1.0, 1.0);
      const torch::Tensor q2 = torch::min(Q(critic1_target, s2, a2), Q(critic2_target, s2, a2));
      y = r + not_done_rows * config.discount * q2;
    }
    const torch::Tensor q1 = Q(critic1, s, a);
    const torch::Tensor critic_loss = torch::mse_loss(q1, y) + torch::mse_loss(Q(critic2, s, a), y);
    critic_optimizer->zero_grad();
    critic_loss.backward();
    critic_optimizer->step();
    ++step;

    if (step % config.policy_frequency == 0) {
      const torch::Tensor pi = Act(actor, s);
      const torch::Tensor q = Q(critic1, s, pi);
      const torch::Tensor lambda = config.alpha / q.abs().mean().detach();
      const torch::Tensor behaviour = torch::mse_loss(pi, a);
      const torch::Tensor actor_loss = -lambda * q.mean() + behaviour;
      actor_optimizer->zero_grad();
      actor_loss.backward();
      actor_optimizer->step();
      last_actor = actor_loss.item<double>();
      last_behaviour = behaviour.item<double>();
      SoftUpdate(*critic1, *critic1_target, config.tau);
      SoftUpdate(*critic2, *critic2_target, config.tau);
      SoftUpdate(*actor, *actor_target, config.tau);
    }
    return {step, critic_loss.item<double>(), last_actor, last_behaviour, q1.mean().item<double>()};
  }
};

Td3Bc::Td3Bc(const Dataset& data, const Td3BcConfig& config) : impl_(std::make_unique<Impl>()) {
  if (config.threads < 1) throw std::invalid_argument("TD3-BC: threads must be at least 1");
  if (data.size() < config.batch) {
    throw std::invalid_argument("TD3-BC: the data set has " + std::to_string(data.size()) +
                                " transitions, fewer than a batch (" + std::to_string(config.batch) + ")");
  }
  Impl& impl = *impl_;
  impl.config = config;
  torch::manual_seed(config.seed);  // the networks' initial weights
  impl.generator = at::detail::createCPUGenerator(config.seed);
  impl.data = ToTensors(data);

  const int64_t h = config.hidden;
  impl.actor = Mlp(kObservationSize, h, kActionSize);
  impl.actor_target = Mlp(kObservationSize, h, kActionSize);
  impl.critic1 = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic2 = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic1_target = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic2_target = Mlp(kObservationSize + kActionSize, h, 1);
  SoftUpdate(*impl.actor, *impl.actor_target, 1.0);
  SoftUpdate(*impl.critic1, *impl.critic1_target, 1.0);
  SoftUpdate(*impl.critic2, *impl.critic2_target, 1.0);
  impl.actor_optimizer = std::make_unique<torch::optim::Adam>(
      impl.actor->parameters(), torch::optim::AdamOptions(config.actor_learning_rate));
  std::vector<torch::Tensor> critics = impl.critic1->parameters();
  for (const torch::Tensor& p : impl.critic2->parameters()) critics.push_back(p);
  impl.critic_optimizer =
      std::make_unique<torch::optim::Adam>(critics, torch::optim::AdamOptions(config.critic_learning_rate));
}

Td3Bc::~Td3Bc() = default;

int64_t Td3Bc::step() const { return impl_->step; }

Action Td3Bc::Act(const Observation& observation) const {
  return ActOn(impl_->policy(), impl_->data.mean, impl_->data.std, observation);
}

Td3BcLosses Td3Bc::Update() {
  Impl& impl = *impl_;
  return impl.Update(
      torch::randint(impl.data.observations.size(0), {impl.config.batch}, impl.generator, torch::kLong));
}

Td3BcLosses Td3Bc::UpdateOn(int64_t first) {
  return impl_->Update(torch::arange(first, first + impl_->config.batch, torch::kLong));
}

void Td3Bc::Save(const std::string& path) const {
  torch::Tensor step = torch::tensor(impl_->step, torch::kLong), generator = impl_->generator.get_state();
  impl_->Parts(&step, &generator).Save(path);
}

void Td3Bc::Load(const std::string& path) {
  torch::Tensor step, generator;
  impl_->Parts(&step, &generator).Load(path, "TD3-BC");
  impl_->step = step.item<int64_t>();
  impl_->generator.set_state(generator);
}

void Td3Bc::ExportPolicy(const std::string& path) const {
  ExportActor(path, impl_->policy(), impl_->data.mean, impl_->data.std);
}

}  // namespace iapsim::rl
