// iapsim_rl: the docking environments as a Python module (pybind11), for researchers who train in Python
// (numpy, Debian's python3-torch). The same C++ objects as `iapsim rl`, with Gymnasium's conventions:
//
//   env = iapsim_rl.DockingEnv("configs/rl/docking.yaml")
//   obs, info = env.reset(seed=1)
//   obs, reward, terminated, truncated, info = env.step(action)       # action: 12 floats in [-1, 1]
//   envs = iapsim_rl.VectorEnv("configs/rl/docking.yaml", num_envs=8, threads=2)
//   obs, info = envs.reset(seed=1)                                     # obs: (8, 48)
//   obs, rewards, terminated, truncated, info = envs.step(actions)     # auto-reset;
//   info["final_observation"]
//
// Steps release the GIL, so other Python threads run while the physics does.

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>

#include "bridge/config.h"
#include "physics/random.h"
#include "rl/docking_expert.h"
#include "rl/vector_env.h"

namespace py = pybind11;

namespace iapsim::rl {
namespace {

py::dict InfoDict(const StepInfo& info) {
  py::dict out;
  out["outcome"] = OutcomeName(info.outcome);
  out["latched"] = info.latched;
  out["step"] = info.step;
  out["docked_step"] = info.docked_step;
  out["axial_error_m"] = info.axial_error_m;
  out["radial_error_m"] = info.radial_error_m;
  out["contact_force_y_N"] = info.contact_force_y_N;
  out["in_guiding_region"] = info.in_guiding_region;
  return out;
}

Action ToAction(const Eigen::VectorXd& values) {
  if (values.size() != kActionSize) {
    throw std::invalid_argument("an action has " + std::to_string(kActionSize) + " values, got " +
                                std::to_string(values.size()));
  }
  return values;
}

// A task file with overrides, as `iapsim rl` reads it.
DockingTaskConfig Task(const std::string& task, const std::vector<std::string>& overrides) {
  return ReadDockingTask(task, overrides);
}

}  // namespace

PYBIND11_MODULE(iapsim_rl, m) {
  m.doc() = "iapsim's air-docking RL environments (seed section IV-E, VI-H), Gymnasium-style";
  // a bad task file or key: iapsim_rl.ConfigError, a ValueError naming the file and the key
  py::register_exception<bridge::ConfigError>(m, "ConfigError", PyExc_ValueError);
  m.attr("observation_size") = kObservationSize;
  m.attr("action_size") = kActionSize;
  m.def("stream_seed", &physics::StreamSeed, py::arg("seed"), py::arg("index"),
        "the seed of environment / episode `index` of a vector or evaluation seeded with `seed`");

  py::class_<DockingEnv>(m, "DockingEnv")
      .def(py::init([](const std::string& task, const std::vector<std::string>& overrides) {
             return std::make_unique<DockingEnv>(Task(task, overrides));
           }),
           py::arg("task"), py::arg("overrides") = std::vector<std::string>())
      .def(
          "reset",
          [](DockingEnv& env, std::optional<uint64_t> seed) {
            const Observation observation = seed ? env.Reset(*seed) : env.Reset();
            return py::make_tuple(Eigen::VectorXd(observation), py::dict());
          },
          py::arg("seed") = py::none(), "starts an episode (seeding the stream first if seed is given)")
      .def(
          "step",
          [](DockingEnv& env, const Eigen::VectorXd& action) {
            const Action checked = ToAction(action);
            Observation observation;
            StepResult result;
            {
              py::gil_scoped_release release;
              result = env.Step(checked, &observation);
            }
            return py::make_tuple(Eigen::VectorXd(observation), result.reward, result.terminated,
                                  result.truncated, InfoDict(result.info));
          },
          py::arg("action"))
      .def_property_readonly("control_rate_hz",
                             [](const DockingEnv& env) { return env.config().control_rate_hz; })
      .def_property_readonly("physics_substeps", &DockingEnv::physics_substeps)
      .def_property_readonly("target_a_m",
                             [](const DockingEnv& env) { return Eigen::Vector3d(env.target_a_m()); })
      .def_property_readonly("target_b_m",
                             [](const DockingEnv& env) { return Eigen::Vector3d(env.target_b_m()); });

  py::class_<VectorEnv>(m, "VectorEnv")
      .def(py::init([](const std::string& task, int num_envs, int threads,
                       const std::vector<std::string>& overrides) {
             return std::make_unique<VectorEnv>(Task(task, overrides), num_envs, threads);
           }),
           py::arg("task"), py::arg("num_envs"), py::arg("threads") = 1,
           py::arg("overrides") = std::vector<std::string>())
      .def_property_readonly("num_envs", &VectorEnv::count)
      .def(
          "reset",
          [](VectorEnv& envs, uint64_t seed) {
            RowMatrix observations;
            {
              py::gil_scoped_release release;
              observations = envs.Reset(seed);
            }
            return py::make_tuple(observations, py::dict());
          },
          py::arg("seed"), "seeds environment i with stream_seed(seed, i) and starts every episode")
      .def(
          "step",
          [](VectorEnv& envs, const RowMatrix& actions) {
            {
              py::gil_scoped_release release;
              envs.Step(actions);
            }
            py::dict info;
            info["final_observation"] = envs.final_observations();
            py::list outcomes;
            std::vector<int> docked;
            for (const StepInfo& step : envs.infos()) {
              outcomes.append(OutcomeName(step.outcome));
              docked.push_back(step.docked_step);
            }
            info["outcome"] = outcomes;
            info["docked_step"] = py::array(py::cast(docked));
            const auto flags = [](const std::vector<uint8_t>& values) {
              py::array_t<bool> out(values.size());
              for (size_t i = 0; i < values.size(); ++i) out.mutable_at(i) = values[i] != 0;
              return out;
            };
            return py::make_tuple(envs.observations(), envs.rewards(), flags(envs.terminated()),
                                  flags(envs.truncated()), info);
          },
          py::arg("actions"), "steps environment i with row i of actions (num_envs x 12)")
      .def("env", &VectorEnv::env, py::arg("index"), py::return_value_policy::reference_internal);

  py::class_<DockingExpert>(m, "Expert")
      .def(py::init<const DockingEnv&>(), py::arg("env"), py::keep_alive<1, 2>())
      .def("reset", &DockingExpert::Reset, "forget the last episode (at every reset)")
      .def(
          "act",
          [](DockingExpert& expert, const Eigen::VectorXd& observation) {
            if (observation.size() != kObservationSize) {
              throw std::invalid_argument("an observation has " + std::to_string(kObservationSize) +
                                          " values, got " + std::to_string(observation.size()));
            }
            return Eigen::VectorXd(expert.Act(observation));
          },
          py::arg("observation"));
}

}  // namespace iapsim::rl
