// iapsim_physics: the physics process. Owns the clock: at every step k it advances the world by the clock
// step (in `substeps` physics steps) and publishes the state at t_k; the commands that arrived before the
// tick of step k−1 drive the step from t_{k−1} to t_k.
//
//   subscribes  /<vehicle>/cmd               iapsim_msgs/IapCommand
//               /latch/command               iapsim_msgs/LatchCommand (close or open a docking latch)
//   publishes   /<vehicle>/state             iapsim_msgs/IapState
//               /<vehicle>/odom              nav_msgs/Odometry (W -> platform, twist in the platform frame)
//               /<vehicle>/<sub>/odom        nav_msgs/Odometry per sub-aircraft
//               /<vehicle>/wrench/external   geometry_msgs/WrenchStamped (contacts, about P's origin, in P)
//               /contacts                    iapsim_msgs/ContactArray (publish_contacts)
//               /latch                       iapsim_msgs/LatchEvent, when a docking latch closes or opens

#include <geometry_msgs/WrenchStamped.h>
#include <iapsim_msgs/ContactArray.h>
#include <iapsim_msgs/IapCommand.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/LatchCommand.h>
#include <iapsim_msgs/LatchEvent.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/BatteryState.h>
#include <spdlog/spdlog.h>

#include <chrono>

#include "bridge/eigen_msgs.h"
#include "bridge/process.h"
#include "physics/physics_config.h"
#include "physics/simulation.h"

namespace iapsim::physics {
namespace {

using bridge::FromMsg;
using bridge::ToPointMsg;
using bridge::ToQuaternionMsg;
using bridge::ToVector3Msg;

SubAircraftSetpoint FromCommand(const iapsim_msgs::SubAircraftCommand& command, bool* known_mode) {
  SubAircraftSetpoint setpoint;
  *known_mode = true;
  switch (command.mode) {
    case iapsim_msgs::SubAircraftCommand::MODE_ATTITUDE:
      setpoint.mode = SubAircraftSetpoint::Mode::kAttitude;
      break;
    case iapsim_msgs::SubAircraftCommand::MODE_BODY_RATE:
      setpoint.mode = SubAircraftSetpoint::Mode::kBodyRate;
      break;
    case iapsim_msgs::SubAircraftCommand::MODE_THRUST_TORQUE:
      setpoint.mode = SubAircraftSetpoint::Mode::kThrustTorque;
      break;
    default:
      *known_mode = false;
  }
  setpoint.thrust_N = command.thrust_N;
  setpoint.q_WS = FromMsg(command.attitude_WS);
  setpoint.w_WS_S = FromMsg(command.body_rate_S);
  setpoint.thrust_W_N = FromMsg(command.thrust_W);
  setpoint.torque_S_Nm = FromMsg(command.torque_S);
  setpoint.angular_acceleration_S_radps2 = FromMsg(command.angular_acceleration_S);
  return setpoint;
}

void FillBody(const std::string& name, const BodyState& state, iapsim_msgs::BodyState* out) {
  out->name = name;
  out->pose_W.position = ToPointMsg(state.p_WB_m);
  out->pose_W.orientation = ToQuaternionMsg(state.q_WB);
  out->twist_W.linear = ToVector3Msg(state.v_WB_W);
  out->twist_W.angular = ToVector3Msg(state.w_WB_W);
  const Eigen::Quaterniond q_BW = state.q_WB.conjugate();
  out->twist_B.linear = ToVector3Msg(q_BW * state.v_WB_W);
  out->twist_B.angular = ToVector3Msg(q_BW * state.w_WB_W);
  out->accel_W.linear = ToVector3Msg(state.a_WB_W);
  out->accel_W.angular = ToVector3Msg(state.alpha_WB_W);
}

void FillOdometry(const iapsim_msgs::BodyState& body, const std_msgs::Header& header,
                  nav_msgs::Odometry* odom) {
  odom->header = header;
  odom->child_frame_id = body.name;
  odom->pose.pose = body.pose_W;
  odom->twist.twist = body.twist_B;  // ROS: the twist is in the child frame
}

class PhysicsNode : public bridge::Process {
 public:
  PhysicsNode(const bridge::ProcessContext& context, bridge::YamlMap& params)
      : config_(ReadPhysicsConfig(params, context.scenario.file, context.scenario.clock.step_s)) {
    config_.simulation.seed = context.seed;
    // a gust's start is in the scenario's time, which begins after the lead-in
    for (DiscreteGust& gust : config_.simulation.air.gusts) gust.start_s += context.scenario.lead_in_s;
    true_model_ = DrawTrueModel(config_.uncertainty, context.seed, &config_.simulation);
    try {
      sim_ = std::make_unique<Simulation>(config_.simulation);
    } catch (const std::invalid_argument& e) {
      params.Fail("vehicles", e.what());
    }
    vehicles_.resize(sim_->vehicle_count());
    for (int v = 0; v < sim_->vehicle_count(); ++v) {
      const VehicleSpec& spec = sim_->vehicle(v);
      VehicleBus& bus = vehicles_[v];
      const std::string prefix = "/" + spec.name;
      bus.state_topic = prefix + "/state";
      bus.odom_topic = prefix + "/odom";
      bus.wrench_topic = prefix + "/wrench/external";
      for (const auto& sub : spec.vehicle.sub_aircraft) {
        bus.sub_odom_topics.push_back(prefix + "/" + sub.name + "/odom");
        bus.battery_topics.push_back(prefix + "/" + sub.name + "/battery");
        bus.joint_names.push_back(sub.name + "_joint");
      }
    }
    latches_.resize(sim_->latch_count());
    battery_every_ =
        std::max<uint64_t>(1, std::llround(1.0 / (kBatteryRate_hz * context.scenario.clock.step_s)));
  }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    if (!true_model_.empty()) {  // not in the constructor: --check prints the resolved params on stdout
      spdlog::info("model mismatch: {} parameters drawn (metrics.json: processes.physics.process.true_model)",
                   true_model_.size());
    }
    for (int v = 0; v < sim_->vehicle_count(); ++v) {
      const std::string& name = sim_->vehicle(v).name;
      bus.Subscribe<iapsim_msgs::IapCommand>(
          "/" + name + "/cmd", [this, v](const iapsim_msgs::IapCommand& command, const bridge::MessageInfo&) {
            OnCommand(v, command);
          });
    }
    bus.Subscribe<iapsim_msgs::LatchCommand>(
        "/latch/command", [this](const iapsim_msgs::LatchCommand& command, const bridge::MessageInfo&) {
          OnLatchCommand(command);
        });
  }

  void Step(const bridge::StepInfo& step) override {
    if (step.step > 0) {
      const auto start = std::chrono::steady_clock::now();
      for (int i = 0; i < config_.substeps; ++i) sim_->Step();
      physics_wall_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    std_msgs::Header header;
    header.stamp = bridge::ToRosTime(step.stamp_ns);
    header.frame_id = "W";
    for (int v = 0; v < sim_->vehicle_count(); ++v) Publish(v, step.step, header);
    if (config_.simulation.actuation.enabled && step.step % battery_every_ == 0) {
      for (int v = 0; v < sim_->vehicle_count(); ++v) PublishBatteries(v, header);
    }
    if (config_.publish_contacts) PublishContacts(step.step, header);
    for (int l = 0; l < sim_->latch_count(); ++l) PublishLatchEvents(l, header);
  }

  void Finish(nlohmann::json* report) override {
    (*report)["physics_steps"] = sim_->step_count();
    (*report)["physics_step_s"] = config_.simulation.step_s;
    (*report)["physics_steps_per_s"] = physics_wall_s_ > 0.0 ? sim_->step_count() / physics_wall_s_ : 0.0;
    const SolverStats& solver = sim_->world().solver_stats();
    (*report)["solver"] = {
        {"solves", solver.solves},
        {"mean_iterations", solver.solves > 0 ? static_cast<double>(solver.iterations) / solver.solves : 0.0},
        {"max_iterations", solver.max_iterations},
        {"capped_solves", solver.capped_solves},
        {"max_capped_residual_mps", solver.max_residual_mps},
        {"contact_points_per_solve",
         solver.solves > 0 ? static_cast<double>(solver.contact_points) / solver.solves : 0.0}};
    for (int v = 0; v < sim_->vehicle_count(); ++v) {
      const VehicleOutput& out = sim_->output(v);
      auto& entry = (*report)["vehicles"][sim_->vehicle(v).name];
      entry["commands_received"] = vehicles_[v].commands;
      entry["commands_rejected"] = vehicles_[v].rejected + out.invalid_commands;
      entry["saturated_sub_aircraft_steps"] = out.saturated_steps;
      entry["clamped_thrust_commands"] = out.clamped_thrust_commands;
      entry["mixer_cut_steps"] = {{"roll_pitch", out.mixer_cut_steps.roll_pitch},
                                  {"thrust", out.mixer_cut_steps.thrust},
                                  {"yaw", out.mixer_cut_steps.yaw}};
    }
    for (int l = 0; l < sim_->latch_count(); ++l) {
      const LatchOutput& out = sim_->latch_output(l);
      auto& entry = (*report)["latches"][sim_->latch(l).name];
      entry["closes"] = out.closes;
      entry["opens"] = out.opens;
      entry["latched_at_end"] = out.latched;
      entry["commands_received"] = latches_[l].commands;
      entry["commands_refused"] = latches_[l].refused;
    }
    (*report)["latch_commands_unknown"] = unknown_latch_commands_;
    for (const DrawnParameter& parameter : true_model_) {
      (*report)["true_model"][parameter.name] = {{"nominal", parameter.nominal}, {"drawn", parameter.drawn}};
    }
  }

 private:
  struct VehicleBus {
    uint64_t commands = 0;
    uint64_t rejected = 0;  // wrong size or unknown mode (invalid numbers are counted by the simulation)
    iapsim_msgs::IapState state;
    nav_msgs::Odometry odom;
    geometry_msgs::WrenchStamped wrench;
    // made once: nothing in the step allocates for a name
    std::string state_topic, odom_topic, wrench_topic;
    std::vector<std::string> sub_odom_topics, joint_names, battery_topics;
    sensor_msgs::BatteryState battery;
  };
  // a power module's rate (PX4 publishes battery_status at about 10 Hz)
  static constexpr double kBatteryRate_hz = 10.0;
  uint64_t battery_every_ = 1;
  std::vector<DrawnParameter> true_model_;  // where the flight's vehicles and wind differ from the files'

  void OnCommand(int v, const iapsim_msgs::IapCommand& command) {
    VehicleBus& vehicle = vehicles_[v];
    ++vehicle.commands;
    const size_t n = sim_->vehicle(v).vehicle.sub_aircraft.size();
    if (command.sub_aircraft.size() != n) {
      if (vehicle.rejected++ == 0) {
        spdlog::warn(
            "/{}/cmd: a command for {} sub-aircraft, the vehicle has {}: rejected (the last one holds)",
            sim_->vehicle(v).name, command.sub_aircraft.size(), n);
      }
      return;
    }
    for (size_t s = 0; s < n; ++s) {
      bool known_mode;
      const SubAircraftSetpoint setpoint = FromCommand(command.sub_aircraft[s], &known_mode);
      if (!known_mode) {
        if (vehicle.rejected++ == 0) {
          spdlog::warn("/{}/cmd: sub-aircraft {} has unknown mode {}: rejected", sim_->vehicle(v).name, s,
                       command.sub_aircraft[s].mode);
        }
        continue;
      }
      if (!sim_->SetCommand(v, static_cast<int>(s), setpoint) && sim_->output(v).invalid_commands == 1) {
        spdlog::warn(
            "/{}/cmd: sub-aircraft {} got a NaN, infinite or non-unit setpoint: rejected, the last holds",
            sim_->vehicle(v).name, s);
      }
    }
  }

  void OnLatchCommand(const iapsim_msgs::LatchCommand& command) {
    const int l = sim_->FindLatch(command.name);
    if (l < 0) {
      if (unknown_latch_commands_++ == 0) {
        spdlog::warn("/latch/command: no latch '{}': ignored", command.name);
      }
      return;
    }
    LatchBus& latch = latches_[l];
    ++latch.commands;
    if (command.action == iapsim_msgs::LatchCommand::OPEN) {
      sim_->OpenLatch(l);
      return;
    }
    const LatchOutput& out = sim_->latch_output(l);
    if (command.action != iapsim_msgs::LatchCommand::CLOSE) {
      if (latch.refused++ == 0) spdlog::warn("/latch/command: unknown action {}: ignored", command.action);
    } else if (!sim_->CloseLatch(l) && latch.refused++ == 0) {
      spdlog::warn(
          "/latch/command: latch '{}' cannot close now (axial {:.4f} m, radial {:.4f} m, angle {:.2f} deg, "
          "speed {:.3f} m/s): refused",
          command.name, out.axial_error_m, out.radial_error_m, out.angular_error_rad * 180.0 / M_PI,
          out.relative_speed_mps);
    }
  }

  // One event per change since the last publish step. A latch alternates between closed and open, so
  // replaying the changes from the last published state ends in the current one.
  void PublishLatchEvents(int l, const std_msgs::Header& header) {
    const LatchOutput& out = sim_->latch_output(l);
    LatchBus& latch = latches_[l];
    for (; latch.changes_published < out.closes + out.opens; ++latch.changes_published) {
      latch.latched = !latch.latched;
      latch_event_.header = header;
      latch_event_.name = sim_->latch(l).name;
      latch_event_.body_a = sim_->latch(l).body_a;
      latch_event_.body_b = sim_->latch(l).body_b;
      latch_event_.latched = latch.latched;
      latch_event_.axial_error_m = out.axial_error_m;
      latch_event_.radial_error_m = out.radial_error_m;
      latch_event_.angular_error_rad = out.angular_error_rad;
      bus_->Publish("/latch", latch_event_);
      spdlog::info("latch '{}' {} at t = {:.3f} s", latch_event_.name, latch.latched ? "closed" : "opened",
                   header.stamp.toSec());
    }
  }

  void Publish(int v, uint64_t step, const std_msgs::Header& header) {
    const VehicleSpec& spec = sim_->vehicle(v);
    const VehicleOutput& out = sim_->output(v);
    const MultibodyWorld& world = sim_->world();
    VehicleBus& bus = vehicles_[v];
    iapsim_msgs::IapState& state = bus.state;
    const size_t n = out.sub_aircraft_bodies.size();
    state.header = header;
    state.step = step;
    state.bodies.resize(n + 1);
    state.joints.resize(n);
    state.sub_aircraft.resize(n);
    const BodyState& platform = world.body(out.platform_body);
    FillBody(world.body_name(out.platform_body), platform, &state.bodies[0]);
    for (size_t s = 0; s < n; ++s) {
      const model::SubAircraft& model = spec.vehicle.sub_aircraft[s];
      const BodyState& sub = world.body(out.sub_aircraft_bodies[s]);
      FillBody(world.body_name(out.sub_aircraft_bodies[s]), sub, &state.bodies[s + 1]);
      iapsim_msgs::JointState& joint = state.joints[s];
      joint.name = bus.joint_names[s];
      joint.type = model.joint == model::JointType::kSpherical ? iapsim_msgs::JointState::TYPE_SPHERICAL
                                                               : iapsim_msgs::JointState::TYPE_FIXED;
      joint.orientation_PS = ToQuaternionMsg(platform.q_WB.conjugate() * sub.q_WB);
      joint.angular_velocity_S = ToVector3Msg(sub.q_WB.conjugate() * (sub.w_WB_W - platform.w_WB_W));
      joint.reaction_force_P = ToVector3Msg(out.sub_aircraft[s].joint_force_P_N);
      iapsim_msgs::SubAircraftState& rotors = state.sub_aircraft[s];
      rotors.name = model.name;
      rotors.thrust_W = ToVector3Msg(out.sub_aircraft[s].thrust_W_N);
      rotors.torque_S = ToVector3Msg(out.sub_aircraft[s].torque_S_Nm);
      const RotorVector& speeds = out.sub_aircraft[s].rotor_speeds_rad_s;
      rotors.rotor_speeds_rad_s.assign(speeds.data(), speeds.data() + speeds.size());
      rotors.saturated = out.sub_aircraft[s].saturated;
    }
    state.external_wrench_P.force = ToVector3Msg(out.external_force_P_N);
    state.external_wrench_P.torque = ToVector3Msg(out.external_torque_P_Nm);
    state.external_wrench_W.force = ToVector3Msg(out.external_force_W_N);
    state.external_wrench_W.torque = ToVector3Msg(out.external_torque_W_Nm);
    bus_->Publish(bus.state_topic, state);

    FillOdometry(state.bodies[0], header, &bus.odom);
    bus_->Publish(bus.odom_topic, bus.odom);
    for (size_t s = 0; s < n; ++s) {
      FillOdometry(state.bodies[s + 1], header, &bus.odom);
      bus_->Publish(bus.sub_odom_topics[s], bus.odom);
    }
    bus.wrench.header = header;
    bus.wrench.header.frame_id = state.bodies[0].name;
    bus.wrench.wrench = state.external_wrench_P;
    bus_->Publish(bus.wrench_topic, bus.wrench);
  }

  // each sub-aircraft's pack as a power module reports it (ROS: current negative while discharging)
  void PublishBatteries(int v, const std_msgs::Header& header) {
    const VehicleSpec& spec = sim_->vehicle(v);
    VehicleBus& bus = vehicles_[v];
    sensor_msgs::BatteryState& battery = bus.battery;
    for (size_t s = 0; s < bus.battery_topics.size(); ++s) {
      const model::Battery& pack = spec.vehicle.sub_aircraft[s].battery;
      const SubAircraftOutput& out = sim_->output(v).sub_aircraft[s];
      battery.header = header;
      battery.header.frame_id = spec.vehicle.sub_aircraft[s].name;
      battery.voltage = static_cast<float>(out.battery_voltage_V);
      battery.current = static_cast<float>(-out.battery_current_A);
      battery.charge = static_cast<float>(out.state_of_charge * pack.capacity_Ah);
      battery.capacity = static_cast<float>(pack.capacity_Ah);
      battery.design_capacity = battery.capacity;
      battery.percentage = static_cast<float>(out.state_of_charge);
      battery.power_supply_status = sensor_msgs::BatteryState::POWER_SUPPLY_STATUS_DISCHARGING;
      battery.power_supply_health = sensor_msgs::BatteryState::POWER_SUPPLY_HEALTH_GOOD;
      battery.power_supply_technology = sensor_msgs::BatteryState::POWER_SUPPLY_TECHNOLOGY_LIPO;
      battery.present = true;
      battery.cell_voltage.assign(pack.cells, static_cast<float>(out.battery_voltage_V / pack.cells));
      battery.location = spec.name + "/" + spec.vehicle.sub_aircraft[s].name;
      bus_->Publish(bus.battery_topics[s], battery);
    }
  }

  void PublishContacts(uint64_t step, const std_msgs::Header& header) {
    const MultibodyWorld& world = sim_->world();
    contacts_.header = header;
    contacts_.step = step;
    contacts_.contacts.resize(world.contacts().size());
    for (size_t i = 0; i < world.contacts().size(); ++i) {
      const Contact& c = world.contacts()[i];
      iapsim_msgs::Contact& out = contacts_.contacts[i];
      out.body_a = c.body_a == kGround ? "ground" : world.body_name(c.body_a);
      out.body_b = c.body_b == kGround ? "ground" : world.body_name(c.body_b);
      out.point_W = ToPointMsg(c.point_W_m);
      out.normal_W = ToVector3Msg(c.normal_W);
      out.force_on_a_W = ToVector3Msg(c.force_on_a_W_N);
      out.depth_m = c.depth_m;
    }
    bus_->Publish("/contacts", contacts_);
  }

  struct LatchBus {
    bool latched = false;            // as last published
    uint64_t changes_published = 0;  // closes and opens
    uint64_t commands = 0;
    uint64_t refused = 0;  // CLOSE out of tolerance, or an unknown action
  };

  PhysicsConfig config_;
  std::unique_ptr<Simulation> sim_;
  std::vector<VehicleBus> vehicles_;
  std::vector<LatchBus> latches_;
  uint64_t unknown_latch_commands_ = 0;
  iapsim_msgs::ContactArray contacts_;
  iapsim_msgs::LatchEvent latch_event_;
  bridge::Bus* bus_ = nullptr;
  double physics_wall_s_ = 0.0;
};

}  // namespace
}  // namespace iapsim::physics

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMainFor<iapsim::physics::PhysicsNode>(
      argc, argv,
      "iapsim physics: IAPs as Bullet multibodies with rotors and flight controllers; owns the clock");
}
