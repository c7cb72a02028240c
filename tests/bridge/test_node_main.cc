// iapsim_test_node: a small process speaking the real message types, for multi-process tests of the bus,
// the lockstep clock, the launcher and the recorder (physics, control and sensors have their own processes).
//
//   behavior: clock       publishes /<vehicle>/state (IapState) every step; integrates the last command,
//                         checking it is the controller's command of its last step (command_period_steps)
//   behavior: controller  publishes /<vehicle>/cmd (IapCommand) computed from the state of the same step;
//                         with expect_uwb_of_step, fails unless the sensor's ranges of the same step arrived
//                         first (the scenario's `after: [sensor]` orders the two); with
//                         expect_uwb_of_previous_step, unless those of the step before did (`after_previous`)
//   behavior: sensor      publishes /<vehicle>/uwb (UwbRanges) with seeded Gaussian noise
//
// In lockstep and fast mode each checks that it sees exactly the step it expects (none skipped, none
// repeated, the command of the previous step applied) and fails otherwise.
// kill_at_step / hang_at_step make it die by SIGKILL or stop responding, for supervision tests;
// stall_at_step makes one step take stall_s, or with hold_until_file until that file appears in the run
// directory (at most stall_s), so a test decides when the run goes on.

#include <iapsim_msgs/IapCommand.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/UwbRanges.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <random>
#include <thread>

#include "bridge/eigen_msgs.h"
#include "bridge/process.h"

namespace iapsim::bridge {
namespace {

class TestNode : public Process {
 public:
  TestNode(const ProcessContext& context, YamlMap& params)
      : mode_(context.scenario.mode),
        rng_(context.seed),
        step_s_(context.scenario.clock.step_s),
        run_dir_(context.run_dir) {
    params.OptionalChoice("behavior", &behavior_, {"clock", "controller", "sensor"});
    params.Optional("vehicle", &vehicle_);
    params.OptionalInRange("bodies", &bodies_, 1, 64);
    params.OptionalInRange("noise_m", &noise_m_, 0.0, 10.0);
    params.OptionalInRange("command_period_steps", &command_period_steps_, uint64_t{0}, uint64_t{1000000});
    params.Optional("kill_at_step", &kill_at_step_);
    params.Optional("hang_at_step", &hang_at_step_);
    params.Optional("stall_at_step", &stall_at_step_);
    params.OptionalInRange("stall_s", &stall_s_, 0.0, 10.0);
    params.Optional("hold_until_file", &hold_until_file_);
    params.OptionalInRange("setup_delay_s", &setup_delay_s_, 0.0, 10.0);
    double check_delay_s = 0.0;  // a slow --check, to interrupt the launcher while it waits for it
    params.OptionalInRange("check_delay_s", &check_delay_s, 0.0, 10.0);
    if (context.run_dir.empty()) std::this_thread::sleep_for(std::chrono::duration<double>(check_delay_s));
    params.Optional("expect_uwb_of_step", &expect_uwb_of_step_);
    params.Optional("expect_uwb_of_previous_step", &expect_uwb_of_previous_step_);
    params.Optional("unstamped", &unstamped_);
  }

  void Setup(Bus& bus) override {
    // a late starter: the handshake must make start order irrelevant
    std::this_thread::sleep_for(std::chrono::duration<double>(setup_delay_s_));
    bus_ = &bus;
    if (behavior_ == "clock") {
      bus.Subscribe<iapsim_msgs::IapCommand>("/" + vehicle_ + "/cmd",
                                             [this](const iapsim_msgs::IapCommand& c, const MessageInfo&) {
                                               command_ = c;
                                               ++commands_received_;
                                             });
    } else {
      bus.Subscribe<iapsim_msgs::IapState>("/" + vehicle_ + "/state",
                                           [this](const iapsim_msgs::IapState& s, const MessageInfo&) {
                                             if (have_state_ && s.step <= state_.step)
                                               Fail("state step " + std::to_string(s.step) + " repeated");
                                             state_ = s;
                                             have_state_ = true;
                                           });
    }
    if (expect_uwb_of_step_ || expect_uwb_of_previous_step_) {
      bus.Subscribe<iapsim_msgs::UwbRanges>("/" + vehicle_ + "/uwb",
                                            [this](const iapsim_msgs::UwbRanges& r, const MessageInfo&) {
                                              uwb_stamp_ns_ = ToNanoseconds(r.header.stamp);
                                            });
    }
  }

  void Step(const StepInfo& step) override {
    if (static_cast<int64_t>(step.step) == kill_at_step_) {
      // leave the moment of death for the test (CLOCK_MONOTONIC is shared by every process)
      std::ofstream(run_dir_ + "/killed_at_ns")
          << std::chrono::steady_clock::now().time_since_epoch() / std::chrono::nanoseconds(1);
      raise(SIGKILL);
    }
    if (static_cast<int64_t>(step.step) == hang_at_step_) {
      while (true) std::this_thread::sleep_for(std::chrono::seconds(1));
    }
    if (static_cast<int64_t>(step.step) == stall_at_step_) Stall();
    ++steps_;
    if (behavior_ == "clock") return StepClock(step);
    // lockstep: the state of this very step arrived before its tick
    if (Causal() && (!have_state_ || state_.step != step.step)) {
      Fail("at step " + std::to_string(step.step) + " the latest state is step " +
           (have_state_ ? std::to_string(state_.step) : std::string("none")));
    }
    if (behavior_ == "controller") return StepController(step);
    StepSensor(step);
  }

  void Finish(nlohmann::json* report) override {
    (*report)["steps"] = steps_;
    (*report)["commands_received"] = commands_received_;
  }

 private:
  // one slow step
  void Stall() const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(stall_s_);
    if (hold_until_file_.empty()) return std::this_thread::sleep_until(end);
    const std::string path = run_dir_ + "/" + hold_until_file_;
    while (access(path.c_str(), F_OK) != 0 && std::chrono::steady_clock::now() < end) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  // lockstep and fast both wait for participants, so nothing a participant sends arrives late
  bool Causal() const { return mode_ != ClockMode::kRealtime; }

  [[noreturn]] void Fail(const std::string& what) { throw std::runtime_error(behavior_ + ": " + what); }

  void StepClock(const StepInfo& step) {
    // the command of the controller's last step before k must have arrived before step k (lockstep causality)
    if (Causal() && command_period_steps_ > 0 && step.step > 0) {
      const uint64_t expected = (step.step - 1) / command_period_steps_ * command_period_steps_;
      if (commands_received_ == 0 || command_.step != expected) {
        Fail("at step " + std::to_string(step.step) + " the latest command is for step " +
             (commands_received_ ? std::to_string(command_.step) : std::string("none")) + ", expected " +
             std::to_string(expected));
      }
    }
    if (state_.bodies.empty()) {
      state_.bodies.resize(static_cast<size_t>(bodies_));
      for (int i = 0; i < bodies_; ++i) {
        state_.bodies[static_cast<size_t>(i)].name = i == 0 ? "platform" : "sub" + std::to_string(i);
        state_.bodies[static_cast<size_t>(i)].pose_W.orientation.w = 1.0;
      }
    }
    // a toy vertical dynamics driven by the controller's thrust, so the loop really closes
    if (step.step > 0 && !command_.sub_aircraft.empty()) {
      velocity_z_ += (9.81 - command_.sub_aircraft[0].thrust_N) * step_s_;
    }
    for (auto& body : state_.bodies) {
      body.pose_W.position.z += velocity_z_ * step_s_;
      body.twist_W.linear.z = velocity_z_;
    }
    state_.header.stamp = ToRosTime(step.stamp_ns);
    state_.header.frame_id = "W";
    state_.step = step.step;
    bus_->Publish("/" + vehicle_ + "/state", state_);
  }

  void StepController(const StepInfo& step) {
    if (expect_uwb_of_step_ && uwb_stamp_ns_ != step.stamp_ns) {
      Fail("at step " + std::to_string(step.step) + " the latest ranges are stamped " +
           std::to_string(uwb_stamp_ns_) + " ns, not the step's " + std::to_string(step.stamp_ns) + " ns");
    }
    if (expect_uwb_of_previous_step_ && uwb_stamp_ns_ < previous_stamp_ns_) {
      Fail("at step " + std::to_string(step.step) + " the latest ranges are stamped " +
           std::to_string(uwb_stamp_ns_) + " ns, before the previous step's " +
           std::to_string(previous_stamp_ns_) + " ns");
    }
    previous_stamp_ns_ = step.stamp_ns;
    iapsim_msgs::IapCommand command;
    command.header.stamp = ToRosTime(step.stamp_ns);
    command.step = step.step;
    command.sub_aircraft.resize(static_cast<size_t>(std::max(1, bodies_ - 1)));
    const double z = state_.bodies.empty() ? 0.0 : state_.bodies[0].pose_W.position.z;
    const double vz = state_.bodies.empty() ? 0.0 : state_.bodies[0].twist_W.linear.z;
    for (auto& sub : command.sub_aircraft) sub.thrust_N = 9.81 + 4.0 * z + 3.0 * vz;  // PD on height
    bus_->Publish("/" + vehicle_ + "/cmd", command);
  }

  void StepSensor(const StepInfo& step) {
    iapsim_msgs::UwbRanges ranges;
    if (!unstamped_) ranges.header.stamp = ToRosTime(step.stamp_ns);  // else 0: a producer that never stamps
    ranges.tag = "sub1";
    std::normal_distribution<double> noise(0.0, noise_m_);
    for (int anchor = 0; anchor < 4; ++anchor) {
      ranges.peers.push_back("anchor" + std::to_string(anchor));
      const double true_range =
          2.0 + anchor + (state_.bodies.empty() ? 0.0 : state_.bodies[0].pose_W.position.z);
      ranges.ranges_m.push_back(true_range + noise(rng_));
    }
    bus_->Publish("/" + vehicle_ + "/uwb", ranges);
  }

  ClockMode mode_;
  std::mt19937_64 rng_;
  double step_s_;
  std::string run_dir_;
  std::string behavior_ = "controller";
  std::string vehicle_ = "iap";
  int bodies_ = 4;
  double noise_m_ = 0.05;
  uint64_t command_period_steps_ = 1;  // clock: controller period in steps (0: no controller)
  int64_t kill_at_step_ = -1;
  int64_t hang_at_step_ = -1;
  int64_t stall_at_step_ = -1;
  double stall_s_ = 0.0;
  std::string hold_until_file_;  // relative to the run directory
  double setup_delay_s_ = 0.0;
  bool expect_uwb_of_step_ = false;
  bool expect_uwb_of_previous_step_ = false;
  bool unstamped_ = false;
  int64_t previous_stamp_ns_ = -1;
  int64_t uwb_stamp_ns_ = -1;
  Bus* bus_ = nullptr;
  iapsim_msgs::IapState state_;
  bool have_state_ = false;
  iapsim_msgs::IapCommand command_;
  double velocity_z_ = 0.0;
  uint64_t steps_ = 0;
  uint64_t commands_received_ = 0;
};

}  // namespace
}  // namespace iapsim::bridge

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMainFor<iapsim::bridge::TestNode>(
      argc, argv, "iapsim test node (clock, controller or sensor) for multi-process tests");
}
