// iapsim_policy: flies the air-docking task's policy in the multi-process graph (seed §VI-H), so that a
// policy trained in the in-process environment (rl/docking_env.h) is checked against the physics process
// it never saw: over the bus, in lockstep or realtime, with the recorder. A participant due at every clock
// step (rate_hz 0), because it averages the contact wrench over every physics step of a control period as
// the environment does; it acts once per control period of the task (steps k with t_k a multiple of it).
//
//   params  task: FILE        the task (configs/rl/docking.yaml): vehicles A and B, latch, action limits,
//                             observation noise, termination, and the targets (A's start in the task's
//                             scenario, B's where it docks); the run's physics flies, from wherever the
//                             run starts A and B
//           task_set: [KEY=VALUE, ...]  overrides of the task's keys (as `iapsim rl eval --set`)
//           policy: NAME      expert, or a TorchScript policy file (*.pt, relative to the scenario)
//   subscribes  /<a>/state, /<b>/state   iapsim_msgs/IapState (the platform, and B's contact wrench)
//               /latch                   iapsim_msgs/LatchEvent (the task's latch closing or opening)
//   publishes   /<a>/cmd, /<b>/cmd       iapsim_msgs/IapCommand: the flight-controller setpoint of each
//                                        quadrotor's half of the action, as the environment applies it
//   reports     outcome (success, crash, separation, timeout; running if the run ended first), the step
//               and time it came at, docked_step and docked_at_s where the latch closed
//
// The observation is the environment's (DockingEnv::Observe) from the true states with the task's noise
// drawn here, and the contact wrench on B averaged over the states of the control period; the outcome is
// judged as the environment judges it (DockingEnv::Judge). After the outcome the policy keeps flying.

#include <iapsim_msgs/IapCommand.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/LatchEvent.h>

#include <cmath>
#include <optional>
#include <random>

#include "bridge/eigen_msgs.h"
#include "bridge/process.h"
#include "rl/docking_env.h"
#include "rl/torchscript_policy.h"

namespace iapsim::rl {
namespace {

class PolicyNode : public bridge::Process {
 public:
  PolicyNode(const bridge::ProcessContext& context, bridge::YamlMap& params) : random_(context.seed) {
    const std::string task_file = bridge::ReadFilePath(params, "task", context.scenario.file);
    params.Required("policy", &policy_name_);
    if (policy_name_ != "expert")
      policy_name_ = bridge::ReadFilePath(params, "policy", context.scenario.file);
    const DockingTaskConfig task = ReadDockingTask(task_file, ReadOverrides(params, "task_set"));
    if (context.self.rate_hz != 0.0) {
      params.Fail("rate_hz",
                  "must be 0 (every clock step): the process averages the contact wrench over each "
                  "control period and acts at the task's control_rate_hz (" +
                      std::to_string(task.control_rate_hz) + " Hz) itself");
    }
    steps_per_action_ = bridge::StepsPerPeriod(task.control_rate_hz, context.scenario.clock.step_s);
    if (steps_per_action_ == 0) {
      throw bridge::ConfigError(task_file + ": control_rate_hz: " + std::to_string(task.control_rate_hz) +
                                " Hz does not divide the clock's rate of this run (" + context.scenario.file +
                                ")");
    }
    // the targets are the task's (A's start in the task's scenario), wherever this run starts A and B
    env_ = std::make_unique<DockingEnv>(task);
    try {
      policy_ = MakePolicy(policy_name_, *env_);
    } catch (const std::invalid_argument& error) {
      params.Fail("policy", error.what());
    }
  }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    const DockingTaskConfig& task = env_->config();
    const std::string names[2] = {task.vehicle_a, task.vehicle_b};
    for (int i = 0; i < 2; ++i) {
      cmd_topic_[i] = "/" + names[i] + "/cmd";
      bus.Subscribe<iapsim_msgs::IapState>(
          "/" + names[i] + "/state",
          [this, i](const iapsim_msgs::IapState& state, const bridge::MessageInfo&) { OnState(i, state); });
    }
    bus.Subscribe<iapsim_msgs::LatchEvent>(
        "/latch", [this](const iapsim_msgs::LatchEvent& event, const bridge::MessageInfo&) {
          if (event.name == env_->config().latch) latched_ = event.latched;
        });
  }

  void Step(const bridge::StepInfo& step) override {
    if (step.step % steps_per_action_ != 0) return;  // between two actions: the states' wrenches add up
    if (!states_[0] || !states_[1]) return;          // realtime: nothing to act on yet
    const QuadrotorState states[2] = {*states_[0], *states_[1]};
    if (acted_) {  // a control period has passed since the last action: judge where it led
      const Outcome outcome = env_->Judge(states, latched_, &progress_);
      if (progress_.just_docked) docked_at_s_ = static_cast<double>(step.stamp_ns) * 1e-9;
      if (outcome != Outcome::kRunning && outcome_ == Outcome::kRunning) {
        outcome_ = outcome;
        outcome_step_ = progress_.step;
        outcome_at_s_ = static_cast<double>(step.stamp_ns) * 1e-9;
      }
    }
    const ContactWrench wrench =
        wrench_samples_ > 0 ? ContactWrench(wrench_sum_ / wrench_samples_) : ContactWrench::Zero();
    wrench_sum_.setZero();
    wrench_samples_ = 0;
    const Action action = policy_->Act(env_->Observe(states, wrench, random_));
    for (int i = 0; i < 2; ++i) {
      const physics::SubAircraftSetpoint setpoint = env_->Setpoint(i, action);
      iapsim_msgs::IapCommand command;
      command.header.stamp = bridge::ToRosTime(step.stamp_ns);
      command.step = step.step;
      command.sub_aircraft.resize(1);
      iapsim_msgs::SubAircraftCommand& sub = command.sub_aircraft[0];
      sub.mode = iapsim_msgs::SubAircraftCommand::MODE_ATTITUDE;
      sub.thrust_N = setpoint.thrust_N;
      sub.attitude_WS = bridge::ToQuaternionMsg(setpoint.q_WS);
      sub.angular_acceleration_S = bridge::ToVector3Msg(setpoint.angular_acceleration_S_radps2);
      bus_->Publish(cmd_topic_[i], command);
    }
    acted_ = true;
  }

  void Finish(nlohmann::json* report) override {
    nlohmann::json& out = *report;
    out["policy"] = policy_name_;
    out["outcome"] = OutcomeName(outcome_);
    out["success"] = outcome_ == Outcome::kSuccess;
    out["control_steps"] = progress_.step;
    if (outcome_ != Outcome::kRunning) {
      out["outcome_step"] = outcome_step_;
      out["outcome_at_s"] = outcome_at_s_;
    }
    if (progress_.docked_step >= 0) {
      out["docked_step"] = progress_.docked_step;
      out["docked_at_s"] = docked_at_s_;
    }
  }

 private:
  void OnState(int i, const iapsim_msgs::IapState& message) {
    if (message.bodies.empty()) return;
    const iapsim_msgs::BodyState& platform = message.bodies[0];
    QuadrotorState state;
    state.p_WP_m = bridge::FromMsg(platform.pose_W.position);
    state.q_WP = bridge::FromMsg(platform.pose_W.orientation).normalized();
    state.v_WP_W_mps = bridge::FromMsg(platform.twist_W.linear);
    state.w_WP_W_radps = bridge::FromMsg(platform.twist_W.angular);
    state.a_WP_W_mps2 = bridge::FromMsg(platform.accel_W.linear);
    states_[i] = state;
    if (i == 1) {  // the contact wrench on B, averaged over the physics steps between two actions
      wrench_sum_.head<3>() += bridge::FromMsg(message.external_wrench_P.force);
      wrench_sum_.tail<3>() += bridge::FromMsg(message.external_wrench_P.torque);
      ++wrench_samples_;
    }
  }

  std::string policy_name_;
  std::unique_ptr<DockingEnv> env_;  // the task: targets, observation, setpoints, judgement; never stepped
  std::unique_ptr<Policy> policy_;
  std::mt19937_64 random_;  // the observation noise
  bridge::Bus* bus_ = nullptr;
  uint64_t steps_per_action_ = 1;
  std::string cmd_topic_[2];
  std::optional<QuadrotorState> states_[2];
  bool latched_ = false;
  ContactWrench wrench_sum_ = ContactWrench::Zero();
  int wrench_samples_ = 0;
  bool acted_ = false;
  EpisodeProgress progress_;
  Outcome outcome_ = Outcome::kRunning;
  int outcome_step_ = 0;
  double outcome_at_s_ = 0.0;
  double docked_at_s_ = 0.0;
};

}  // namespace
}  // namespace iapsim::rl

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMainFor<iapsim::rl::PolicyNode>(
      argc, argv, "iapsim policy: flies the air-docking policy (expert or TorchScript) over the bus");
}
