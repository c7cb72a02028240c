#include "rl/td3bc.h"

#include <ATen/Parallel.h>

#include <stdexcept>

#include "rl/torch_networks.h"

namespace iapsim::rl {
namespace {

torch::Tensor FromFlags(const std::vector<uint8_t>& flags) {
  return torch::from_blob(const_cast<uint8_t*>(flags.data()), {static_cast<int64_t>(flags.size()), 1},
                          torch::kUInt8)
      .to(torch::kFloat32);
}

void SoftUpdate(const torch::nn::Module& source, torch::nn::Module& target, double tau) {
  torch::NoGradGuard no_grad;
  const auto from = source.parameters();
  auto to = target.parameters();
  for (size_t i = 0; i < from.size(); ++i) to[i].mul_(1.0 - tau).add_(from[i], tau);
}

void CopyParameters(const torch::nn::Module& source, torch::nn::Module& target) {
  SoftUpdate(source, target, 1.0);
}

}  // namespace

struct Td3Bc::Impl {
  Td3BcConfig config;
  // the data set as tensors, observations normalised
  torch::Tensor observations, actions, rewards, next_observations, not_done;
  torch::Tensor mean, std;
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

  Td3BcLosses Update(const torch::Tensor& rows) {
    // a TorchScript policy evaluated in between sets one thread (rl/torchscript_policy.h)
    if (at::get_num_threads() != config.threads) at::set_num_threads(config.threads);
    const torch::Tensor s = observations.index_select(0, rows), a = actions.index_select(0, rows);
    const torch::Tensor r = rewards.index_select(0, rows), s2 = next_observations.index_select(0, rows);
    const torch::Tensor not_done_rows = not_done.index_select(0, rows);
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
  const torch::Tensor observations = FromRows(data.observations);
  impl.mean = observations.mean(0, true);
  impl.std = observations.std(0, true, true) + 1e-3;  // TD3-BC's normalisation, its ε
  impl.observations = Normalise(observations, impl.mean, impl.std);
  impl.next_observations = Normalise(FromRows(data.next_observations), impl.mean, impl.std);
  impl.actions = FromRows(data.actions);
  impl.rewards =
      torch::from_blob(const_cast<float*>(data.rewards.data()), {data.size(), 1}, torch::kFloat32).clone();
  impl.not_done = 1.0 - FromFlags(data.terminals);

  const int64_t h = config.hidden;
  impl.actor = Mlp(kObservationSize, h, kActionSize);
  impl.actor_target = Mlp(kObservationSize, h, kActionSize);
  impl.critic1 = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic2 = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic1_target = Mlp(kObservationSize + kActionSize, h, 1);
  impl.critic2_target = Mlp(kObservationSize + kActionSize, h, 1);
  CopyParameters(*impl.actor, *impl.actor_target);
  CopyParameters(*impl.critic1, *impl.critic1_target);
  CopyParameters(*impl.critic2, *impl.critic2_target);
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
  torch::NoGradGuard no_grad;
  const torch::Tensor in =
      torch::from_blob(const_cast<double*>(observation.data()), {1, kObservationSize}, torch::kFloat64)
          .to(torch::kFloat32);
  const torch::Tensor out =
      impl_->Act(impl_->policy(), Normalise(in, impl_->mean, impl_->std)).to(torch::kFloat64).contiguous();
  return Eigen::Map<const Action>(out.data_ptr<double>());
}

Td3BcLosses Td3Bc::Update() {
  Impl& impl = *impl_;
  return impl.Update(
      torch::randint(impl.observations.size(0), {impl.config.batch}, impl.generator, torch::kLong));
}

Td3BcLosses Td3Bc::UpdateOn(int64_t first) {
  return impl_->Update(torch::arange(first, first + impl_->config.batch, torch::kLong));
}

void Td3Bc::Save(const std::string& path) const {
  const Impl& impl = *impl_;
  torch::serialize::OutputArchive archive;
  WriteModule(archive, "actor", *impl.actor);
  WriteModule(archive, "actor_target", *impl.actor_target);
  WriteModule(archive, "critic1", *impl.critic1);
  WriteModule(archive, "critic2", *impl.critic2);
  WriteModule(archive, "critic1_target", *impl.critic1_target);
  WriteModule(archive, "critic2_target", *impl.critic2_target);
  torch::serialize::OutputArchive actor_optimizer, critic_optimizer;
  impl.actor_optimizer->save(actor_optimizer);
  impl.critic_optimizer->save(critic_optimizer);
  archive.write("actor_optimizer", actor_optimizer);
  archive.write("critic_optimizer", critic_optimizer);
  archive.write("mean", impl.mean);
  archive.write("std", impl.std);
  archive.write("step", torch::tensor(impl.step, torch::kLong));
  archive.write("generator", impl.generator.get_state());
  SaveArchive(archive, path);
}

void Td3Bc::Load(const std::string& path) {
  Impl& impl = *impl_;
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(path);
    ReadModule(archive, "actor", *impl.actor);
    ReadModule(archive, "actor_target", *impl.actor_target);
    ReadModule(archive, "critic1", *impl.critic1);
    ReadModule(archive, "critic2", *impl.critic2);
    ReadModule(archive, "critic1_target", *impl.critic1_target);
    ReadModule(archive, "critic2_target", *impl.critic2_target);
    torch::serialize::InputArchive actor_optimizer, critic_optimizer;
    archive.read("actor_optimizer", actor_optimizer);
    archive.read("critic_optimizer", critic_optimizer);
    impl.actor_optimizer->load(actor_optimizer);
    impl.critic_optimizer->load(critic_optimizer);
    archive.read("mean", impl.mean);
    archive.read("std", impl.std);
    torch::Tensor step, generator;
    archive.read("step", step);
    archive.read("generator", generator);
    impl.step = step.item<int64_t>();
    impl.generator.set_state(generator);
  } catch (const std::exception& error) {  // c10::Error: no archive, a missing key, a shape that differs
    const std::string what = error.what();
    throw std::runtime_error(path + ": not a TD3-BC checkpoint of this shape (" +
                             what.substr(0, what.find('\n')) + ")");
  }
}

void Td3Bc::ExportPolicy(const std::string& path) const {
  ExportActor(path, impl_->policy(), impl_->mean, impl_->std);
}

}  // namespace iapsim::rl
