// iapsim_control: the control process (a lockstep participant at its own rate). It turns the vehicle's
// state into per-sub-aircraft commands for the simulated flight controllers.
//
//   mode: hover   a constant command source: from the first state, each sub-aircraft's share of the hover
//                 wrench by the allocation (17) at the platform's attitude levelled (its yaw kept), as a
//                 collective thrust and an attitude from (18) with the sub-aircraft's initial yaw.
//
//   subscribes  /<vehicle>/state   iapsim_msgs/IapState
//   publishes   /<vehicle>/cmd     iapsim_msgs/IapCommand (stamped with the state it answers)

#include <iapsim_msgs/IapCommand.h>
#include <iapsim_msgs/IapState.h>

#include <cmath>

#include "bridge/eigen_msgs.h"
#include "bridge/process.h"
#include "control/allocation.h"
#include "model/vehicle.h"

namespace iapsim::control {
namespace {

class ControlNode : public bridge::Process {
 public:
  ControlNode(const bridge::ProcessContext& context, bridge::YamlMap& params) {
    bridge::YamlMap vehicle = params.Map("vehicle");
    vehicle.Required("name", &vehicle_name_);
    vehicle_ = model::LoadVehicle(bridge::ReadFilePath(vehicle, "file", context.scenario.file));
    vehicle.Finish();
    params.OptionalChoice("mode", &mode_, {"hover"});
    params.OptionalInRange("gravity_mps2", &gravity_mps2_, 0.0, 100.0);
  }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    bus.Subscribe<iapsim_msgs::IapState>("/" + vehicle_name_ + "/state",
                                         [this](const iapsim_msgs::IapState& state, const bridge::MessageInfo&) {
                                           state_ = state;
                                           have_state_ = true;
                                         });
  }

  void Step(const bridge::StepInfo&) override {
    if (!have_state_ || state_.bodies.empty()) return;  // realtime: nothing to answer yet
    if (command_.sub_aircraft.empty()) HoldHover();
    command_.header.stamp = state_.header.stamp;
    command_.step = state_.step;
    bus_->Publish("/" + vehicle_name_ + "/cmd", command_);
    ++commands_;
  }

  void Finish(nlohmann::json* report) override { (*report)["commands_sent"] = commands_; }

 private:
  void HoldHover() {
    const Eigen::Quaterniond q_WP = bridge::FromMsg(state_.bodies[0].pose_W.orientation).normalized();
    const Eigen::Vector3d x_W = q_WP * Eigen::Vector3d::UnitX();
    const double yaw_rad = std::atan2(x_W.y(), x_W.x());
    const Eigen::Quaterniond level(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
    const Allocation allocation(vehicle_);
    const Eigen::VectorXd thrusts_P = allocation.Allocate(HoverWrench(vehicle_, level, gravity_mps2_));
    command_.sub_aircraft.resize(vehicle_.sub_aircraft.size());
    for (size_t i = 0; i < vehicle_.sub_aircraft.size(); ++i) {
      const Eigen::Vector3d thrust_W = level * thrusts_P.segment<3>(3 * i);
      const double sub_yaw_rad = yaw_rad + vehicle_.sub_aircraft[i].initial_yaw_rad;
      const Eigen::Vector2d roll_pitch = RollPitchForThrust(thrust_W, sub_yaw_rad);
      auto& sub = command_.sub_aircraft[i];
      sub.mode = iapsim_msgs::SubAircraftCommand::MODE_ATTITUDE;
      sub.thrust_N = thrust_W.norm();
      sub.attitude_WS = bridge::ToQuaternionMsg(AttitudeFromEuler(roll_pitch[0], roll_pitch[1], sub_yaw_rad));
    }
  }

  std::string vehicle_name_;
  model::Vehicle vehicle_;
  std::string mode_ = "hover";
  double gravity_mps2_ = 9.81;
  bridge::Bus* bus_ = nullptr;
  iapsim_msgs::IapState state_;
  bool have_state_ = false;
  iapsim_msgs::IapCommand command_;
  uint64_t commands_ = 0;
};

}  // namespace
}  // namespace iapsim::control

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMain(
      argc, argv, "iapsim control: per-sub-aircraft commands from the vehicle state",
      [](const iapsim::bridge::ProcessContext& context, iapsim::bridge::YamlMap& params) {
        return std::make_unique<iapsim::control::ControlNode>(context, params);
      });
}
