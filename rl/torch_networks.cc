#include "rl/torch_networks.h"

#include <filesystem>
#include <stdexcept>
#include <vector>

#include "rl/docking_env.h"

namespace iapsim::rl {

torch::Tensor FromRows(const RowMatrixF& rows) {
  return torch::from_blob(const_cast<float*>(rows.data()), {rows.rows(), rows.cols()}, torch::kFloat32)
      .clone();
}

constexpr double kObservationClip = 10.0;
torch::Tensor Normalise(const torch::Tensor& observations, const torch::Tensor& mean,
                        const torch::Tensor& std) {
  return ((observations - mean) / std).clamp(-kObservationClip, kObservationClip);
}

void SoftUpdate(const torch::nn::Module& source, torch::nn::Module& target, double tau) {
  torch::NoGradGuard no_grad;
  const auto from = source.parameters();
  auto to = target.parameters();
  for (size_t i = 0; i < from.size(); ++i) to[i].mul_(1.0 - tau).add_(from[i], tau);
}

OfflineTensors ToTensors(const Dataset& data) {
  OfflineTensors t;
  const torch::Tensor observations = FromRows(data.observations);
  t.mean = observations.mean(0, true);
  t.std = observations.std(0, true, true) + 1e-3;
  t.observations = Normalise(observations, t.mean, t.std);
  t.next_observations = Normalise(FromRows(data.next_observations), t.mean, t.std);
  t.actions = FromRows(data.actions);
  t.rewards =
      torch::from_blob(const_cast<float*>(data.rewards.data()), {data.size(), 1}, torch::kFloat32).clone();
  const torch::Tensor terminals =
      torch::from_blob(const_cast<uint8_t*>(data.terminals.data()), {data.size(), 1}, torch::kUInt8);
  t.not_done = 1.0 - terminals.to(torch::kFloat32);
  return t;
}

void WriteModule(torch::serialize::OutputArchive& archive, const char* name,
                 const torch::nn::Module& module) {
  torch::serialize::OutputArchive part;
  module.save(part);
  archive.write(name, part);
}

void ReadModule(torch::serialize::InputArchive& archive, const char* name, torch::nn::Module& module) {
  std::vector<std::vector<int64_t>> shapes;
  for (const torch::Tensor& p : module.parameters()) shapes.push_back(p.sizes().vec());
  torch::serialize::InputArchive part;
  archive.read(name, part);
  module.load(part);
  const std::vector<torch::Tensor> loaded = module.parameters();
  for (size_t i = 0; i < loaded.size(); ++i) {
    if (loaded[i].sizes().vec() != shapes[i]) {
      throw std::runtime_error(std::string(name) + "'s layers are " + std::to_string(loaded[i].size(0)) +
                               " wide where this learner's are " + std::to_string(shapes[i][0]));
    }
  }
}

void SaveArchive(torch::serialize::OutputArchive& archive, const std::string& path) {
  const std::string partial = path + ".partial";
  archive.save_to(partial);
  std::filesystem::rename(partial, path);
}

void Checkpoint::Save(const std::string& path) const {
  torch::serialize::OutputArchive archive;
  for (const auto& [name, module] : modules) WriteModule(archive, name.c_str(), *module);
  for (const auto& [name, optimizer] : optimizers) {
    torch::serialize::OutputArchive part;
    optimizer->save(part);
    archive.write(name, part);
  }
  for (const auto& [name, tensor] : tensors) archive.write(name, *tensor);
  SaveArchive(archive, path);
}

void Checkpoint::Load(const std::string& path, const std::string& learner) const {
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(path);
    for (const auto& [name, module] : modules) ReadModule(archive, name.c_str(), *module);
    for (const auto& [name, optimizer] : optimizers) {
      torch::serialize::InputArchive part;
      archive.read(name, part);
      optimizer->load(part);
    }
    for (const auto& [name, tensor] : tensors) archive.read(name, *tensor);
  } catch (const std::exception& error) {  // c10::Error: no archive, a missing key, a shape that differs
    const std::string what = error.what();
    throw std::runtime_error(path + ": not a " + learner + " checkpoint of this shape (" +
                             what.substr(0, what.find('\n')) + ")");
  }
}

Action ActOn(Mlp actor, const torch::Tensor& mean, const torch::Tensor& std, const Observation& observation) {
  torch::NoGradGuard no_grad;
  const torch::Tensor in =
      torch::from_blob(const_cast<double*>(observation.data()), {1, kObservationSize}, torch::kFloat64)
          .to(torch::kFloat32);
  const torch::Tensor out =
      torch::tanh(actor->forward(Normalise(in, mean, std))).to(torch::kFloat64).contiguous();
  return Eigen::Map<const Action>(out.data_ptr<double>());
}

void ExportActor(const std::string& path, const Mlp& actor, const torch::Tensor& mean,
                 const torch::Tensor& std) {
  torch::jit::Module policy("DockingPolicy");
  const auto copy = [](const torch::Tensor& t) { return t.detach().clone(); };
  policy.register_buffer("mean", copy(mean));
  policy.register_buffer("std", copy(std));
  const torch::nn::Linear layers[3] = {actor->l0, actor->l1, actor->l2};
  for (int i = 0; i < 3; ++i) {
    policy.register_parameter("w" + std::to_string(i), copy(layers[i]->weight), false);
    policy.register_parameter("b" + std::to_string(i), copy(layers[i]->bias), false);
  }
  policy.define(R"(
def forward(self, observation):
    x = torch.clamp((observation - self.mean) / self.std, -10.0, 10.0)
    x = torch.relu(torch.matmul(x, self.w0.t()) + self.b0)
    x = torch.relu(torch.matmul(x, self.w1.t()) + self.b1)
    return torch.tanh(torch.matmul(x, self.w2.t()) + self.b2)
)");
  const std::string partial = path + ".partial";
  policy.save(partial);
  std::filesystem::rename(partial, path);
}

ActorFile ReadActor(const std::string& path) {
  torch::jit::Module module;
  try {
    module = torch::jit::load(path);
  } catch (const std::exception& error) {  // c10::Error: no file, no archive
    const std::string what = error.what();
    throw std::invalid_argument(path + ": not a TorchScript policy (" + what.substr(0, what.find('\n')) +
                                ")");
  }
  const auto tensor = [&](const std::string& name) {
    if (!module.hasattr(name) || !module.attr(name).isTensor()) {
      throw std::invalid_argument(path + ": not a policy `iapsim rl train` exported (it has no tensor '" +
                                  name + "'; PPO starts from TD3-BC's or PPO's policy.pt)");
    }
    return module.attr(name).toTensor().detach().clone().to(torch::kFloat32);
  };
  ActorFile file;
  file.mean = tensor("mean");
  file.std = tensor("std");
  const int64_t hidden = tensor("w0").size(0);
  file.actor = Mlp(kObservationSize, hidden, kActionSize);
  const torch::nn::Linear layers[3] = {file.actor->l0, file.actor->l1, file.actor->l2};
  torch::NoGradGuard no_grad;
  const auto set = [&](const torch::Tensor& into, const std::string& name) {
    const torch::Tensor from = tensor(name);
    if (from.sizes() != into.sizes()) {
      throw std::invalid_argument(path + ": '" + name + "' has shape " + c10::str(from.sizes()) +
                                  ", expected " + c10::str(into.sizes()) + " (" +
                                  std::to_string(kObservationSize) + " observations, " +
                                  std::to_string(kActionSize) + " actions)");
    }
    into.copy_(from);
  };
  for (int i = 0; i < 3; ++i) {
    set(layers[i]->weight, "w" + std::to_string(i));
    set(layers[i]->bias, "b" + std::to_string(i));
  }
  if (file.mean.sizes() != torch::IntArrayRef({1, kObservationSize}) ||
      file.std.sizes() != file.mean.sizes()) {
    throw std::invalid_argument(path + ": 'mean' and 'std' must have shape [1, " +
                                std::to_string(kObservationSize) + "]");
  }
  return file;
}

}  // namespace iapsim::rl
