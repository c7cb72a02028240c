#include "rl/docking_env.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "bridge/config.h"
#include "control/allocation.h"
#include "physics/physics_config.h"
#include "physics/random.h"
#include "sensors/gaussian.h"

namespace iapsim::rl {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
// a port pressed a little past the face (contact penetration, the latch's own axial tolerance) still
// counts as in the guiding region
constexpr double kGuideBehindFace_m = 0.01;

Eigen::Isometry3d Pose(const physics::BodyState& state) {
  return Eigen::Translation3d(state.p_WB_m) * state.q_WB;
}

// angle between the body's z axis and W's
double Tilt_rad(const Eigen::Quaterniond& q_WB) {
  return std::acos(std::clamp((q_WB * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0));
}

// the rotation by the angle |v| about v
Eigen::Matrix3d Rotation(const Eigen::Vector3d& v_rad) {
  const double angle = v_rad.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, v_rad / angle).toRotationMatrix();
}

double Uniform(std::mt19937_64& random, double lo, double hi) {
  return lo + 0.5 * (physics::SymmetricUniform(random) + 1.0) * (hi - lo);
}

}  // namespace

const char* OutcomeName(Outcome outcome) {
  switch (outcome) {
    case Outcome::kRunning:
      return "running";
    case Outcome::kSuccess:
      return "success";
    case Outcome::kCrash:
      return "crash";
    case Outcome::kSeparation:
      return "separation";
    case Outcome::kTimeout:
      return "timeout";
  }
  return "?";
}

DockingEnv::DockingEnv(const DockingTaskConfig& config)
    : config_(config),
      world_(physics::LoadScenarioPhysics(config.scenario, config.scenario_overrides).simulation) {
  const auto fail = [&](const std::string& what) {
    throw bridge::ConfigError(config.file + ": scenario " + config.scenario + ": " + what);
  };
  const std::string names[2] = {config.vehicle_a, config.vehicle_b};
  for (int i = 0; i < 2; ++i) {
    const auto found = std::find_if(world_.vehicles.begin(), world_.vehicles.end(),
                                    [&](const physics::VehicleSpec& spec) { return spec.name == names[i]; });
    if (found == world_.vehicles.end()) fail("has no vehicle '" + names[i] + "' (vehicle_a / vehicle_b)");
    vehicle_[i] = static_cast<int>(found - world_.vehicles.begin());
    if (found->vehicle.sub_aircraft.size() != 1) {
      fail("vehicle '" + names[i] + "' must be one quadrotor (a single sub-aircraft)");
    }
    mass_kg_[i] = found->vehicle.TotalMass_kg();
  }
  const auto latch = std::find_if(world_.latches.begin(), world_.latches.end(),
                                  [&](const physics::LatchSpec& spec) { return spec.name == config.latch; });
  if (latch == world_.latches.end()) fail("has no latch '" + config.latch + "'");
  latch_ = static_cast<int>(latch - world_.latches.begin());

  const double period_s = 1.0 / config.control_rate_hz;
  substeps_ = static_cast<int>(std::lround(period_s / world_.step_s));
  if (substeps_ < 1 || std::abs(substeps_ * world_.step_s - period_s) > 1e-9) {
    throw bridge::ConfigError(config.file + ": control_rate_hz: must divide the physics rate (" +
                              std::to_string(1.0 / world_.step_s) + " Hz), got " +
                              std::to_string(config.control_rate_hz));
  }
  has_ground_ = world_.world.ground;
  ground_z_m_ = world_.world.ground_z_m;

  // The ports and the sub-aircraft in their platform frames, from the scenario's world as built.
  const physics::Simulation built(world_);
  const physics::MultibodyWorld& world = built.world();
  const int latch_bodies[2] = {world.FindBody(latch->body_a), world.FindBody(latch->body_b)};
  const physics::DockingPort ports[2] = {latch->port_a, latch->port_b};
  Eigen::Vector3d p_PQ_m[2], axis_P[2];
  for (int i = 0; i < 2; ++i) {
    const physics::VehicleOutput& out = built.output(vehicle_[i]);
    const std::string& body_name = world.body_name(latch_bodies[i]);
    if (body_name.rfind(names[i] + "/", 0) != 0) {
      fail("latch '" + config.latch + "': body_" + (i == 0 ? "a" : "b") + " must be on vehicle '" + names[i] +
           "', got '" + body_name + "'");
    }
    const Eigen::Isometry3d X_PW = Pose(world.body(out.platform_body)).inverse();
    const Eigen::Isometry3d X_PB = X_PW * Pose(world.body(latch_bodies[i]));
    p_PQ_m[i] = X_PB * ports[i].p_BQ_m;
    axis_P[i] = X_PB.linear() * ports[i].axis_B;
    const Eigen::Quaterniond q_PS(X_PW.linear() *
                                  world.body(out.sub_aircraft_bodies[0]).q_WB.toRotationMatrix());
    if ((q_PS * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ()).norm() > 1e-9) {
      fail("vehicle '" + names[i] + "': its quadrotor must be level in its platform frame");
    }
    sub_yaw_rad_[i] = std::atan2(q_PS.toRotationMatrix()(1, 0), q_PS.toRotationMatrix()(0, 0));
    q_PS_[i] = q_PS;
  }
  if (axis_P[0].dot(axis_P[1]) > -1.0 + 1e-6) {
    fail("latch '" + config.latch + "': the ports must face each other when A and B fly level at one yaw");
  }
  // A's target is its start in the scenario, level; B's is where its port meets A's, at A's attitude.
  const physics::VehicleSpec& a = world_.vehicles[vehicle_[0]];
  target_yaw_rad_ = a.yaw_rad;
  target_q_WP_ = Eigen::AngleAxisd(a.yaw_rad, Eigen::Vector3d::UnitZ());
  target_m_[0] = a.p_WP_m;
  target_m_[1] = a.p_WP_m + target_q_WP_ * (p_PQ_m[0] - p_PQ_m[1]);
}

DockingEnv::~DockingEnv() = default;

bool DockingEnv::InGuidingRegion(const GuidingRegion& guide, double axial_error_m, double radial_error_m) {
  if (axial_error_m < -kGuideBehindFace_m || axial_error_m > guide.length_m) return false;
  return radial_error_m <=
         guide.radius_m + std::max(axial_error_m, 0.0) * std::tan(guide.half_angle_deg * kDegToRad);
}

RewardTerms DockingEnv::Reward(const DockingTaskConfig& config, const Eigen::Vector3d position_error_m[2],
                               const double attitude_error_rad[2], bool in_guiding_region,
                               double axial_error_m, double radial_error_m, double contact_force_y_N) {
  const DockingReward& w = config.reward;
  RewardTerms terms;
  terms.position = -w.position_per_m * (position_error_m[0].norm() + position_error_m[1].norm());
  terms.attitude = -w.attitude_per_rad * (attitude_error_rad[0] + attitude_error_rad[1]);
  if (in_guiding_region) {
    terms.guide = w.guide;
    terms.relative = -w.relative_per_m * (radial_error_m + std::abs(axial_error_m));
  }
  terms.force = -w.force_per_N * std::max(0.0, std::abs(contact_force_y_N) - w.force_free_N);
  return terms;
}

Observation DockingEnv::Reset(uint64_t seed) {
  random_.seed(seed);
  return Reset();
}

Observation DockingEnv::Reset() {
  StartEpisode();
  QuadrotorState states[2];
  CurrentStates(states);
  return Observe(states, contact_wrench_, random_);
}

void DockingEnv::StartEpisode() {
  const DockingReset& reset = config_.reset;
  episode_world_ = world_;
  physics::SimulationConfig& episode = episode_world_;
  episode.seed = random_();  // the physics' own streams (sensor noise, link jitter of a realistic profile)
  Eigen::Vector3d offset_m;
  for (int axis = 0; axis < 3; ++axis) {
    offset_m[axis] = Uniform(random_, reset.b_offset_min_m[axis], reset.b_offset_max_m[axis]);
  }
  for (int i = 0; i < 2; ++i) {
    physics::VehicleSpec& spec = episode.vehicles[vehicle_[i]];
    spec.p_WP_m = i == 0 ? target_m_[0] : Eigen::Vector3d(target_m_[0] + target_q_WP_ * offset_m);
    spec.roll_rad = reset.tilt_max_deg * kDegToRad * physics::SymmetricUniform(random_);
    spec.pitch_rad = reset.tilt_max_deg * kDegToRad * physics::SymmetricUniform(random_);
    spec.yaw_rad = target_yaw_rad_ + reset.yaw_max_deg * kDegToRad * physics::SymmetricUniform(random_);
    for (int axis = 0; axis < 3; ++axis) {
      spec.v_WP_W_mps[axis] = reset.speed_max_mps * physics::SymmetricUniform(random_);
    }
    for (int axis = 0; axis < 3; ++axis) {
      spec.w_WP_W_radps[axis] = reset.rate_max_deg_s * kDegToRad * physics::SymmetricUniform(random_);
    }
    spec.initial_rotors = physics::InitialRotors::kHover;
  }
  simulation_ = std::make_unique<physics::Simulation>(episode);
  progress_ = EpisodeProgress();
  done_ = false;
  contact_wrench_.setZero();
  terms_ = RewardTerms();
  QuadrotorState states[2];
  CurrentStates(states);
  potential_ = StateReward(states, 0.0).potential();
}

void DockingEnv::CurrentStates(QuadrotorState (&states)[2]) const {
  for (int i = 0; i < 2; ++i) {
    const physics::BodyState& body =
        simulation_->world().body(simulation_->output(vehicle_[i]).platform_body);
    states[i] = {body.p_WB_m, body.q_WB, body.v_WB_W, body.w_WB_W, body.a_WB_W};
  }
}

RewardTerms DockingEnv::StateReward(const QuadrotorState (&states)[2], double contact_force_y_N) const {
  const physics::LatchOutput& latch = simulation_->latch_output(latch_);
  Eigen::Vector3d position_error_m[2];
  double attitude_error_rad[2];
  for (int i = 0; i < 2; ++i) {
    position_error_m[i] = states[i].p_WP_m - target_m_[i];
    attitude_error_rad[i] = Eigen::AngleAxisd(target_q_WP_.conjugate() * states[i].q_WP).angle();
  }
  return Reward(config_, position_error_m, attitude_error_rad,
                InGuidingRegion(config_.guide, latch.axial_error_m, latch.radial_error_m),
                latch.axial_error_m, latch.radial_error_m, contact_force_y_N);
}

Observation DockingEnv::Observe(const QuadrotorState (&states)[2], const ContactWrench& contact_wrench,
                                std::mt19937_64& random) const {
  const ObservationNoise& noise = config_.noise;
  Observation observation;
  for (int i = 0; i < 2; ++i) {
    const QuadrotorState& state = states[i];
    auto out = observation.segment<kObservationPerQuadrotor>(i * kObservationPerQuadrotor);
    out.segment<3>(0) = state.p_WP_m - target_m_[i] + noise.position_m * sensors::Gaussian3(random);
    out.segment<3>(3) = state.v_WP_W_mps + noise.velocity_mps * sensors::Gaussian3(random);
    const Eigen::Matrix3d R_WP =
        state.q_WP.toRotationMatrix() * Rotation(noise.attitude_deg * kDegToRad * sensors::Gaussian3(random));
    for (int row = 0; row < 3; ++row) out.segment<3>(6 + 3 * row) = R_WP.row(row).transpose();
    out.segment<3>(15) =
        state.q_WP.conjugate() * state.w_WP_W_radps + noise.rate_radps * sensors::Gaussian3(random);
    out.segment<3>(18) = state.a_WP_W_mps2 + noise.acceleration_mps2 * sensors::Gaussian3(random);
  }
  observation.tail<kContactWrenchSize>() = contact_wrench;
  return observation;
}

Outcome DockingEnv::Judge(const QuadrotorState (&states)[2], bool latched, EpisodeProgress* progress) const {
  const DockingTermination& end = config_.termination;
  ++progress->step;
  progress->just_docked = latched && progress->docked_step < 0;
  if (progress->just_docked) progress->docked_step = progress->step;
  bool crashed = false, separated = false, hovering = true;
  for (int i = 0; i < 2; ++i) {
    const double tilt_rad = Tilt_rad(states[i].q_WP);
    crashed = crashed || tilt_rad > end.crash_tilt_deg * kDegToRad ||
              (has_ground_ && ground_z_m_ - states[i].p_WP_m.z() < end.crash_height_m);
    separated = separated || (states[i].p_WP_m - target_m_[i]).norm() > end.separation_m;
    hovering = hovering && states[i].v_WP_W_mps.norm() <= end.hover_speed_mps &&
               tilt_rad <= end.hover_tilt_deg * kDegToRad;
  }
  progress->hover_steps = latched && hovering ? progress->hover_steps + 1 : 0;
  if (crashed) return Outcome::kCrash;
  if (separated) return Outcome::kSeparation;
  if (progress->hover_steps >= std::max(1L, std::lround(end.hover_s * config_.control_rate_hz))) {
    return Outcome::kSuccess;
  }
  if (progress->step >= end.max_steps) return Outcome::kTimeout;
  return Outcome::kRunning;
}

physics::SubAircraftSetpoint DockingEnv::Setpoint(int quadrotor, const Action& action) const {
  const Action clipped = action.cwiseMax(-1.0).cwiseMin(1.0);
  const Eigen::Vector3d acceleration_W = config_.max_acceleration_mps2 * clipped.segment<3>(6 * quadrotor);
  const Eigen::Vector3d angular_acceleration_P =
      config_.max_angular_acceleration_radps2 * clipped.segment<3>(6 * quadrotor + 3);
  // the thrust that gives this acceleration; eq. (18) tilts the quadrotor along it at the target's yaw
  const Eigen::Vector3d gravity_W(0.0, 0.0, world_.world.gravity_mps2);
  const Eigen::Vector3d thrust_W = mass_kg_[quadrotor] * (acceleration_W - gravity_W);
  const double yaw_rad = target_yaw_rad_ + sub_yaw_rad_[quadrotor];
  const Eigen::Vector2d roll_pitch = control::RollPitchForThrust(thrust_W, yaw_rad);
  physics::SubAircraftSetpoint setpoint;
  setpoint.mode = physics::SubAircraftSetpoint::Mode::kAttitude;
  setpoint.thrust_N = thrust_W.norm();
  setpoint.q_WS = control::AttitudeFromEuler(roll_pitch[0], roll_pitch[1], yaw_rad);
  setpoint.angular_acceleration_S_radps2 = q_PS_[quadrotor].conjugate() * angular_acceleration_P;
  return setpoint;
}

StepResult DockingEnv::Step(const Action& action, Observation* observation) {
  if (done_) throw std::logic_error("DockingEnv::Step after the episode ended: call Reset() first");
  if (!action.allFinite()) throw std::invalid_argument("DockingEnv::Step: the action is not finite");
  for (int i = 0; i < 2; ++i) simulation_->SetCommand(vehicle_[i], 0, Setpoint(i, action));
  contact_wrench_.setZero();
  const physics::VehicleOutput& b = simulation_->output(vehicle_[1]);
  for (int k = 0; k < substeps_; ++k) {
    simulation_->Step();
    contact_wrench_.head<3>() += b.external_force_P_N;
    contact_wrench_.tail<3>() += b.external_torque_P_Nm;
  }
  contact_wrench_ /= substeps_;

  const physics::LatchOutput& latch = simulation_->latch_output(latch_);
  QuadrotorState states[2];
  CurrentStates(states);
  StepResult result;
  StepInfo& info = result.info;
  info.outcome = Judge(states, latch.latched, &progress_);
  info.step = progress_.step;
  info.docked_step = progress_.docked_step;
  info.latched = latch.latched;
  info.axial_error_m = latch.axial_error_m;
  info.radial_error_m = latch.radial_error_m;
  info.contact_force_y_N = contact_wrench_[1];
  info.in_guiding_region = InGuidingRegion(config_.guide, latch.axial_error_m, latch.radial_error_m);

  terms_ = StateReward(states, info.contact_force_y_N);
  if (progress_.just_docked) terms_.bonus += config_.reward.latch_bonus;
  if (info.outcome == Outcome::kSuccess) terms_.bonus += config_.reward.success_bonus;
  if (info.outcome == Outcome::kCrash || info.outcome == Outcome::kSeparation) {
    terms_.bonus -= config_.reward.failure_penalty;
  }
  result.terminated = info.outcome == Outcome::kSuccess || info.outcome == Outcome::kCrash ||
                      info.outcome == Outcome::kSeparation;
  if (config_.reward.shaping == DockingReward::Shaping::kPotential) {
    const double next_potential = result.terminated ? 0.0 : terms_.potential();
    terms_.shaping = config_.reward.discount * next_potential - potential_;
    potential_ = next_potential;
    terms_.position = terms_.attitude = terms_.guide = terms_.relative = 0.0;
  }
  result.reward = terms_.total();
  result.truncated = info.outcome == Outcome::kTimeout;
  done_ = result.terminated || result.truncated;
  CurrentStates(states);
  *observation = Observe(states, contact_wrench_, random_);
  return result;
}

}  // namespace iapsim::rl
