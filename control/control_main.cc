// iapsim_control: the IAP computer (a lockstep participant at its own rate, 200 Hz in the paper). It turns
// the vehicle's state into per-sub-aircraft commands for the simulated flight controllers.
//
//   mode: track   the tracker (10) or (16), picked by the rank test (8), follows `trajectory` (time 0 = the
//                 scenario's, after its lead_in_s, or the first state if later) or the pose commands arriving
//                 on `reference.topic` (a replayed command log: `iapsim replay`), through `reference.shaping`
//                 (control/commanded_reference.h); allocation (17) within the thrust limits; (18) per
//                 sub-aircraft. interaction: admittance  (19)-(20) (Table IV) revise the reference from the
//                 contact wrench, which (10) also feeds forward (§VI-E); direct_wrench: (21) (Table V) takes
//                 over from (10) once contact holds and drives the contact wrench to a command (§VI-F). The
//                 wrench comes from wrench_topic (the sensors' low-passed wrench; give this process
//                 `after: [sensors]` in lockstep so it reads the wrench of its own step).
//   odometry_topic  the platform's pose and twist come from this nav_msgs/Odometry (the sensors process's
//                 odometry, or an estimator's: pose in W, twist in P; a relative name is the vehicle's)
//                 instead of the true state, which this process then does not read (issue 19's
//                 estimation in the loop). In lockstep give the process `after: [sensors]` and the
//                 odometry the controller's rate.
//   sensor_link: {delay_s, jitter_s}  what this computer reads of the vehicle (state and wrench) reaches it
//                 that long after it was measured (control/sensor_link.h); it controls with the newest that
//                 has arrived and sends nothing before the first (the flight controllers hold their initial
//                 setpoints)
//   mode: hover   a constant, open-loop command source: from the first state, each sub-aircraft's share of
//                 the hover wrench by (17) at the platform's attitude levelled (its yaw kept), as a
//                 collective thrust and an attitude from (18) with the sub-aircraft's initial yaw.
//
//   subscribes  /<vehicle>/state      iapsim_msgs/IapState (or odometry_topic: nav_msgs/Odometry)
//               reference.topic       PoseStamped or iapsim_msgs/Setpoint (track with a reference)
//               wrench_topic          geometry_msgs/WrenchStamped, in P about its origin (interaction)
//   publishes   /<vehicle>/cmd        iapsim_msgs/IapCommand (stamped with the newest state's time, its
//                                     step that of the state it was computed from)
//               /<vehicle>/setpoint   iapsim_msgs/Setpoint   (track: the reference of that command)
//               /<vehicle>/wrench/command  geometry_msgs/WrenchStamped (track: U, in P about its origin)
//               /<vehicle>/wrench/target   geometry_msgs/WrenchStamped (direct_wrench, while engaged: the
//                                          wrench command of that step, in P about its origin; none while
//                                          released after a lost contact)

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/WrenchStamped.h>
#include <iapsim_msgs/IapCommand.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/Setpoint.h>
#include <nav_msgs/Odometry.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <optional>
#include <vector>

#include "bridge/eigen_msgs.h"
#include "bridge/process.h"
#include "control/admittance.h"
#include "control/allocation.h"
#include "control/commanded_reference.h"
#include "control/control_config.h"
#include "control/flight_envelope.h"
#include "control/iap_controller.h"
#include "control/sensor_link.h"
#include "control/trajectory.h"
#include "control/wrench_control.h"
#include "model/vehicle.h"

namespace iapsim::control {
namespace {

// What the computer knows of the platform at one instant: the true state or an odometry's estimate of it.
struct Measured {
  int64_t stamp_ns = 0;
  uint64_t step = 0;  // the physics step it was measured in
  PlatformState platform;
};

PlatformState PlatformStateOf(const geometry_msgs::Pose& pose_W, const geometry_msgs::Twist& twist_P) {
  PlatformState state;
  state.p_WP_m = bridge::FromMsg(pose_W.position);
  state.q_WP = bridge::FromMsg(pose_W.orientation).normalized();
  state.v_WP_P_mps = bridge::FromMsg(twist_P.linear);
  state.w_WP_P_radps = bridge::FromMsg(twist_P.angular);
  return state;
}

class ControlNode : public bridge::Process {
 public:
  ControlNode(const bridge::ProcessContext& context, bridge::YamlMap& params) {
    bridge::YamlMap vehicle = params.Map("vehicle");
    vehicle.Required("name", &vehicle_name_);
    vehicle_ = model::LoadVehicle(bridge::ReadFilePath(vehicle, "file", context.scenario.file));
    vehicle.Finish();
    if (!params.Has("mode")) params.Fail("mode", "is required: track or hover");
    params.OptionalChoice("mode", &mode_, {"track", "hover"});
    config_ = ReadControllerConfig(params);
    // rate_hz 0 runs every clock step
    period_s_ = context.self.rate_hz > 0 ? 1.0 / context.self.rate_hz : context.scenario.clock.step_s;
    double delay_s = 0.0, jitter_s = 0.0;
    if (params.Has("sensor_link")) {
      bridge::YamlMap link = params.Map("sensor_link");
      link.OptionalInRange("delay_s", &delay_s, 0.0, 10.0);
      link.OptionalInRange("jitter_s", &jitter_s, 0.0, 10.0);
      link.Finish();
    }
    params.Optional("odometry_topic", &odometry_topic_);
    // a relative name is the vehicle's, as in ROS: odometry is /<vehicle>/odometry
    if (!odometry_topic_.empty() && odometry_topic_[0] != '/') {
      odometry_topic_ = "/" + vehicle_name_ + "/" + odometry_topic_;
    }
    const double step_s = context.scenario.clock.step_s;
    step_ns_ = static_cast<int64_t>(std::llround(step_s * 1e9));
    lead_in_ns_ = context.scenario.lead_in_ns();
    try {  // one jitter stream per input
      states_.emplace(bridge::LinkDelay(delay_s, jitter_s, step_s, context.seed), step_ns_);
      wrenches_.emplace(bridge::LinkDelay(delay_s, jitter_s, step_s, context.seed + 0x9E3779B97F4A7C15ULL),
                        step_ns_);
    } catch (const std::invalid_argument& e) {
      params.Fail("sensor_link", e.what());
    }
    params.OptionalChoice("interaction", &interaction_, {"none", "admittance", "direct_wrench"});
    if (interaction_ != "none") {
      if (mode_ != "track") params.Fail("interaction", "needs mode: track");
      wrench_topic_ = "/" + vehicle_name_ + "/wrench/filtered";
      params.Optional("wrench_topic", &wrench_topic_);
      if (interaction_ == "admittance") {
        admittance_.emplace(ReadAdmittanceConfig(params), period_s_);
      } else {
        wrench_controller_.emplace(vehicle_, config_, ReadDirectWrenchConfig(params), period_s_);
      }
    }
    FlightEnvelopeConfig envelope;
    if (params.Has("envelope")) {
      bridge::YamlMap section = params.Map("envelope");
      envelope = ReadFlightEnvelope(section);
      section.Finish();
    }
    envelope_.emplace(envelope);
    if (mode_ == "track") {
      if (params.Has("trajectory") == params.Has("reference")) {
        params.Fail("trajectory",
                    "mode track needs exactly one of trajectory (a known path) or reference "
                    "(pose commands from a topic)");
      }
      if (params.Has("trajectory")) {
        bridge::YamlMap trajectory = params.Map("trajectory");
        trajectory_ = ReadTrajectory(trajectory, context.scenario.file);
        trajectory.Finish();
        const std::string outside = envelope_->Check(*trajectory_, context.scenario.duration_s, period_s_);
        if (!outside.empty()) params.Fail("trajectory", outside + " (the control params' envelope)");
      } else {
        bridge::YamlMap reference = params.Map("reference");
        reference.Required("topic", &reference_topic_);
        reference.OptionalChoice("type", &reference_type_, {"pose_stamped", "setpoint"});
        shaping_ = ReadReferenceShaping(reference);
        reference.Finish();
        try {
          commanded_.emplace(shaping_);
        } catch (const std::invalid_argument& e) {
          params.Fail("reference", e.what());
        }
      }
      if (!wrench_controller_) controller_.emplace(vehicle_, config_);
    }
  }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    const auto measured = [this](const std_msgs::Header& header, const geometry_msgs::Pose& pose_W,
                                 const geometry_msgs::Twist& twist_P, uint64_t step) {
      newest_state_ns_ = bridge::ToNanoseconds(header.stamp);
      states_->Push(Measured{*newest_state_ns_, step, PlatformStateOf(pose_W, twist_P)}, *newest_state_ns_);
    };
    if (odometry_topic_.empty()) {
      bus.Subscribe<iapsim_msgs::IapState>(
          "/" + vehicle_name_ + "/state",
          [measured](const iapsim_msgs::IapState& state, const bridge::MessageInfo&) {
            if (!state.bodies.empty()) {
              measured(state.header, state.bodies[0].pose_W, state.bodies[0].twist_B, state.step);
            }
          });
    } else {
      bus.Subscribe<nav_msgs::Odometry>(
          odometry_topic_, [this, measured](const nav_msgs::Odometry& odometry, const bridge::MessageInfo&) {
            const auto step = static_cast<uint64_t>(bridge::ToNanoseconds(odometry.header.stamp) / step_ns_);
            measured(odometry.header, odometry.pose.pose, odometry.twist.twist, step);
          });
    }
    if (!wrench_topic_.empty()) {
      bus.Subscribe<geometry_msgs::WrenchStamped>(
          wrench_topic_, [this](const geometry_msgs::WrenchStamped& m, const bridge::MessageInfo&) {
            wrenches_->Push(m, bridge::ToNanoseconds(m.header.stamp));
          });
    }
    if (reference_topic_.empty()) return;
    const auto command = [this](const ros::Time& stamp, const geometry_msgs::Pose& pose, bool five_dof) {
      FlightEnvelope::PoseCommand pose_W{bridge::FromMsg(pose.position), bridge::FromMsg(pose.orientation)};
      // what is not even a pose is left to Add to reject; a pose goes through the envelope first
      if (pose_W.p_WP_m.allFinite() && pose_W.q_WP.coeffs().allFinite() &&
          std::abs(pose_W.q_WP.norm() - 1.0) <= 1e-3) {
        const EnvelopeCounts before = envelope_->counts();
        const auto admitted = envelope_->Admit(stamp.toSec(), pose_W, five_dof);
        const EnvelopeCounts& after = envelope_->counts();
        if ((after.clamped > before.clamped && after.clamped == 1) ||
            (after.rejected > before.rejected && after.rejected == 1)) {
          spdlog::warn(
              "{}: a pose command at t = {:.3f} s outside the flight envelope ({}{}{}) was {} (the first "
              "such; all are counted in the report)",
              reference_topic_, stamp.toSec(),
              after.outside_geofence > before.outside_geofence ? " geofence" : "",
              after.too_fast > before.too_fast ? " speed" : "",
              after.too_tilted > before.too_tilted ? " tilt" : "", admitted ? "clamped" : "rejected");
        }
        if (!admitted) return;
        pose_W = *admitted;
      }
      if (!commanded_->Add(stamp.toSec(), pose_W.p_WP_m, pose_W.q_WP, five_dof)) ++rejected_references_;
    };
    if (reference_type_ == "pose_stamped") {
      bus.Subscribe<geometry_msgs::PoseStamped>(
          reference_topic_, [command](const geometry_msgs::PoseStamped& m, const bridge::MessageInfo&) {
            command(m.header.stamp, m.pose, false);
          });
    } else {
      bus.Subscribe<iapsim_msgs::Setpoint>(
          reference_topic_, [command](const iapsim_msgs::Setpoint& m, const bridge::MessageInfo&) {
            command(m.header.stamp, m.pose_W, m.dof == iapsim_msgs::Setpoint::DOF_5);
          });
    }
  }

  void Step(const bridge::StepInfo&) override {
    // realtime: nothing to answer yet; with a sensor link, nothing has arrived yet. The time is that of the
    // newest state received: what every output is stamped with (in lockstep, this step's).
    if (!newest_state_ns_ || !states_->Advance(*newest_state_ns_)) return;
    now_ = bridge::ToRosTime(*newest_state_ns_);
    if (wrenches_->Advance(*newest_state_ns_)) {
      const geometry_msgs::WrenchStamped& wrench = wrenches_->current();
      wrench_P_ << bridge::FromMsg(wrench.wrench.force), bridge::FromMsg(wrench.wrench.torque);
      wrench_stamp_ns_ = bridge::ToNanoseconds(wrench.header.stamp);
    }
    if (controller_ || wrench_controller_) {
      Track();
    } else if (command_.sub_aircraft.empty()) {
      HoldHover();
    }
    command_.header.stamp = now_;
    command_.step = measured().step;
    bus_->Publish("/" + vehicle_name_ + "/cmd", command_);
    ++commands_;
  }

  void Finish(nlohmann::json* report) override {
    (*report)["commands_sent"] = commands_;
    const EnvelopeCounts& envelope = envelope_->counts();
    (*report)["envelope"] = {{"commands", envelope.commands}, {"clamped", envelope.clamped},
                             {"rejected", envelope.rejected}, {"outside_geofence", envelope.outside_geofence},
                             {"too_fast", envelope.too_fast}, {"too_tilted", envelope.too_tilted}};
    (*report)["fully_actuated"] = Allocation(vehicle_).fully_actuated();
    if (const IapController* controller = active_controller()) {
      (*report)["rejected_updates"] = controller->rejected_updates();
      (*report)["saturated_updates"] = controller->saturated_updates();
      // per part of the wrench, the updates that gave some of it up (control/allocation.h's order)
      const auto& cuts = controller->part_cut_updates();
      (*report)["allocation_cut_updates"] = {
          {"vertical", cuts[0]}, {"roll_pitch", cuts[1]}, {"horizontal", cuts[2]}, {"yaw", cuts[3]}};
    }
    if (interaction_ != "none") {
      (*report)["interaction"] = interaction_;
      // the wrench of another step than the state's (no `after` in lockstep, or a slower sensors process)
      (*report)["stale_wrench_updates"] = stale_wrench_updates_;
    }
    if (admittance_) {
      (*report)["admittance_saturated_updates"] = admittance_->saturated_updates();
      (*report)["admittance_rejected_updates"] = admittance_->rejected_updates();
    }
    if (wrench_controller_) {
      (*report)["engaged"] = wrench_controller_->engaged();
      if (engaged_at_s_) (*report)["engaged_at_s"] = *engaged_at_s_;
      (*report)["released_at_s"] = released_at_s_;  // each time the contact was lost and (21) let go
    }
    if (commanded_) {
      (*report)["rejected_references"] = rejected_references_;
      nlohmann::json& shaping = (*report)["reference_shaping"];
      if (shaping_.type == ReferenceShaping::Type::kNone) {
        shaping["type"] = "none";
        shaping["velocity_time_constant_s"] = shaping_.velocity_time_constant_s;
      } else {
        const ReferenceShaperConfig& config = shaping_.second_order;
        const auto list = [](const Eigen::Vector3d& v, double scale) {
          return std::vector<double>{v.x() * scale, v.y() * scale, v.z() * scale};
        };
        shaping["type"] = "second_order";
        shaping["bandwidth_hz"] = config.bandwidth_hz;
        shaping["max_velocity_mps"] = list(config.max_velocity_mps, 1.0);
        shaping["max_acceleration_mps2"] = list(config.max_acceleration_mps2, 1.0);
        shaping["max_rate_dps"] = list(config.max_rate_radps, 180.0 / M_PI);
        shaping["max_angular_acceleration_dps2"] = list(config.max_angular_acceleration_radps2, 180.0 / M_PI);
      }
      // how far the flown reference was from the raw commands (the price of shaping)
      const ReferenceLag lag = commanded_->lag();
      shaping["lag_max_m"] = lag.max_m;
      shaping["lag_rms_m"] = lag.rms_m;
      shaping["lag_max_deg"] = lag.max_deg;
      shaping["lag_rms_deg"] = lag.rms_deg;
    }
  }

 private:
  void Track() {
    // the trajectory's time 0 is the scenario's (after its lead-in, which holds the start), or the first
    // state's if that arrived later
    if (!start_ns_) start_ns_ = std::max(measured().stamp_ns, lead_in_ns_);
    const double t_s = static_cast<double>(bridge::ToNanoseconds(now_) - *start_ns_) * 1e-9;
    if (!hold_) {  // before the first pose command: stay where the flight starts
      hold_.emplace();
      hold_->p_WP_m = measured().platform.p_WP_m;
      hold_->q_WP = measured().platform.q_WP;
    }
    const PoseReference nominal = trajectory_           ? trajectory_->Sample(t_s)
                                  : commanded_->empty() ? *hold_
                                                        : commanded_->Update(*hold_, period_s_);
    const PlatformState& state = measured().platform;
    if (interaction_ != "none" && wrench_stamp_ns_ != measured().stamp_ns) ++stale_wrench_updates_;
    PoseReference reference = nominal;
    if (admittance_) {
      reference = admittance_->Update(nominal, WrenchInW(state.q_WP, wrench_P_));
      controller_->Update(reference, state, wrench_P_, period_s_);
    } else if (wrench_controller_) {
      const uint64_t releases = wrench_controller_->releases();
      wrench_controller_->Update(reference, state, wrench_P_);
      if (wrench_controller_->engaged()) {
        if (!engaged_at_s_) engaged_at_s_ = t_s;
        PublishWrench("/wrench/target", wrench_controller_->command_wrench_P());
      } else if (wrench_controller_->releases() != releases) {
        released_at_s_.push_back(t_s);
        spdlog::info(
            "contact lost at {:.3f} s: the direct wrench controller hands back to the pose "
            "controller until the contact is re-established",
            t_s);
      }
    } else {
      controller_->Update(reference, state, Vector6d::Zero(), period_s_);
    }

    const ControlOutput& out = active_controller()->output();
    command_.sub_aircraft.resize(out.sub_aircraft.size());
    for (size_t i = 0; i < out.sub_aircraft.size(); ++i) {
      auto& sub = command_.sub_aircraft[i];
      sub.mode = iapsim_msgs::SubAircraftCommand::MODE_ATTITUDE;
      sub.thrust_N = out.sub_aircraft[i].thrust_N;
      sub.attitude_WS = bridge::ToQuaternionMsg(out.sub_aircraft[i].q_WS);
    }
    PublishReference(reference);
    PublishWrench("/wrench/command", out.wrench_P);
  }

  const Measured& measured() const { return states_->current(); }

  const IapController* active_controller() const {
    if (wrench_controller_) return &wrench_controller_->active_controller();
    return controller_ ? &*controller_ : nullptr;
  }

  void PublishWrench(const std::string& suffix, const Vector6d& wrench_P) {
    geometry_msgs::WrenchStamped wrench;
    wrench.header.stamp = now_;
    wrench.header.frame_id = "P";
    wrench.wrench.force = bridge::ToVector3Msg(wrench_P.head<3>());
    wrench.wrench.torque = bridge::ToVector3Msg(wrench_P.tail<3>());
    bus_->Publish("/" + vehicle_name_ + suffix, wrench);
  }

  void PublishReference(const PoseReference& reference) {
    iapsim_msgs::Setpoint setpoint;
    setpoint.header.stamp = now_;
    setpoint.header.frame_id = "W";
    setpoint.dof = reference.five_dof ? iapsim_msgs::Setpoint::DOF_5 : iapsim_msgs::Setpoint::DOF_6;
    setpoint.pose_W.position = bridge::ToPointMsg(reference.p_WP_m);
    setpoint.pose_W.orientation = bridge::ToQuaternionMsg(reference.q_WP);
    setpoint.twist_W.linear = bridge::ToVector3Msg(reference.v_WP_W_mps);
    setpoint.twist_W.angular = bridge::ToVector3Msg(reference.q_WP * reference.w_WP_P_radps);
    setpoint.accel_W.linear = bridge::ToVector3Msg(reference.a_WP_W_mps2);
    setpoint.accel_W.angular = bridge::ToVector3Msg(reference.q_WP * reference.dw_WP_P_radps2);
    bus_->Publish("/" + vehicle_name_ + "/setpoint", setpoint);
  }

  void HoldHover() {
    const Eigen::Quaterniond& q_WP = measured().platform.q_WP;
    const double yaw_rad = YawOf(q_WP.toRotationMatrix());
    const Eigen::Quaterniond level(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
    const Allocation allocation(vehicle_);
    const Eigen::VectorXd thrusts_P = allocation.Allocate(HoverWrench(vehicle_, level, config_.gravity_mps2));
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
  std::string mode_;
  IapControllerConfig config_;
  std::unique_ptr<Trajectory> trajectory_;
  std::optional<FlightEnvelope> envelope_;
  std::string reference_topic_;
  std::string reference_type_ = "pose_stamped";
  ReferenceShaping shaping_;
  std::optional<CommandedPoseReference> commanded_;
  std::optional<PoseReference> hold_;
  uint64_t rejected_references_ = 0;
  std::optional<IapController> controller_;
  std::string interaction_ = "none";
  std::string wrench_topic_;  // empty: no interaction
  std::optional<Admittance> admittance_;
  std::optional<DirectWrenchController> wrench_controller_;
  Vector6d wrench_P_ = Vector6d::Zero();  // the latest contact wrench, in P about its origin
  int64_t wrench_stamp_ns_ = -1;
  uint64_t stale_wrench_updates_ = 0;
  std::optional<double> engaged_at_s_;
  std::vector<double> released_at_s_;
  double period_s_ = 0.005;
  bridge::Bus* bus_ = nullptr;
  // what has arrived over the sensor link
  std::string odometry_topic_;  // empty: the true state
  int64_t step_ns_ = 1;
  int64_t lead_in_ns_ = 0;
  std::optional<SensorLink<Measured>> states_;
  std::optional<SensorLink<geometry_msgs::WrenchStamped>> wrenches_;
  std::optional<int64_t> newest_state_ns_;  // received, arrived or not
  ros::Time now_;                           // the step being answered: the newest state's stamp
  std::optional<int64_t> start_ns_;
  iapsim_msgs::IapCommand command_;
  uint64_t commands_ = 0;
};

}  // namespace
}  // namespace iapsim::control

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMainFor<iapsim::control::ControlNode>(
      argc, argv, "iapsim control: per-sub-aircraft commands from the vehicle state");
}
