#include "physics/simulation.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "physics/random.h"
#include "sensors/attitude_estimator.h"
#include "sensors/imu.h"

namespace iapsim::physics {
namespace {

// The wakes are a quasi-steady model (physics/rotor.h): their air takes 0.1-0.2 s to travel the 20 rotor
// radii they reach (at the F450's far-wake speed 2 v_h, 12 m/s in hover), so a rotor's push on what lies
// below it changes over tens of milliseconds. Its ray casts are evaluated at 200 Hz and the forces held
// between, which leaves the wake at a twentieth of its travel time behind the rotors and the bodies it hits.
constexpr double kWakeRate_hz = 200.0;

// The turbulence is sampled at 200 Hz and held between samples: each sample is exact at any interval (Van
// Loan's discretisation, physics/wind.h), and at low altitude the spectra's corners V/L lie at a few rad/s
// (L_w is the height), so what lies above 100 Hz is a few millionths of the variance.
constexpr double kTurbulenceRate_hz = 200.0;

// a rate's period in whole physics steps, at least one
int64_t EveryStepsAt(double rate_hz, double step_s) {
  if (!(rate_hz > 0.0))
    throw std::invalid_argument("a rate of the flight controllers' estimates must be positive");
  return std::max<int64_t>(1, std::llround(1.0 / (rate_hz * step_s)));
}

}  // namespace

Simulation::Simulation(const SimulationConfig& config)
    : world_(config.world, config.step_s),
      gravity_W_(0.0, 0.0, config.world.gravity_mps2),
      air_(config.air),
      ground_z_m_(config.world.ground ? config.world.ground_z_m : 0.0),
      estimate_(config.flight_controller_estimate),
      velocity_every_steps_(EveryStepsAt(config.flight_controller_estimate.velocity_rate_hz, config.step_s)),
      heading_every_steps_(EveryStepsAt(config.flight_controller_estimate.heading_rate_hz, config.step_s)),
      imu_integration_steps_(static_cast<int>(
          EveryStepsAt(config.flight_controller_estimate.imu_integration_rate_hz, config.step_s))),
      wake_every_steps_(EveryStepsAt(kWakeRate_hz, config.step_s)),
      turbulence_every_steps_(EveryStepsAt(kTurbulenceRate_hz, config.step_s)) {
  vehicle_of_body_.assign(world_.body_count(), -1);
  for (const auto& spec : config.vehicles) {
    for (const auto& other : vehicles_) {
      if (other->spec.name == spec.name)
        throw std::invalid_argument("vehicle '" + spec.name + "' is used twice");
    }
    auto sim = std::make_unique<VehicleSim>();
    sim->spec = spec;
    const Eigen::Quaterniond q_WP = Eigen::AngleAxisd(spec.yaw_rad, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(spec.pitch_rad, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(spec.roll_rad, Eigen::Vector3d::UnitX());
    VehicleOutput& out = sim->output;
    out.platform_body = world_.AddMultibody(spec.name, spec.description, spec.p_WP_m, q_WP, Material{},
                                            CollisionFilter{}, spec.v_WP_W_mps, spec.w_WP_W_radps);
    vehicle_of_body_.resize(world_.body_count(), static_cast<int>(vehicles_.size()));

    if (config.air.turbulence) {
      sim->turbulence =
          std::make_unique<DrydenTurbulence>(StreamSeed(config.seed, vehicles_.size() * 64 + 63));
    }

    const model::Vehicle& vehicle = spec.vehicle;
    const model::Vehicle& known = spec.flight_controller_model ? *spec.flight_controller_model : vehicle;
    if (known.sub_aircraft.size() != vehicle.sub_aircraft.size()) {
      throw std::invalid_argument("vehicle '" + spec.name +
                                  "': its flight controllers' model has another number of sub-aircraft");
    }
    const Eigen::VectorXd hover_thrusts_N = vehicle.LevelHoverThrusts_N(config.world.gravity_mps2);
    for (size_t i = 0; i < vehicle.sub_aircraft.size(); ++i) {
      const model::SubAircraft& sub = vehicle.sub_aircraft[i];
      const model::SubAircraft& known_sub = known.sub_aircraft[i];
      const int body = world_.FindBody(spec.name + "/" + sub.name);
      if (body < 0) {
        throw std::invalid_argument("vehicle '" + spec.name + "': its description has no link '" + sub.name +
                                    "'");
      }
      out.sub_aircraft_bodies.push_back(body);
      SubAircraftSim s;
      try {
        s.rotors = std::make_unique<Rotors>(sub.rotors, sub.mass.com_B_m);
        if (spec.flight_controller_model) {
          s.known_rotors = std::make_unique<Rotors>(known_sub.rotors, known_sub.mass.com_B_m);
        }
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument("vehicle '" + spec.name + "', " + sub.name + ": " + e.what());
      }
      s.controller = std::make_unique<FlightController>(sub.flight_controller, known_sub.mass.inertia_B_kgm2,
                                                        s.controller_rotors());
      if (config.actuation.enabled) {
        try {
          s.drive = std::make_unique<ElectricDrive>(sub.rotors, sub.battery, config.actuation.state_of_charge,
                                                    config.actuation.battery_sag,
                                                    sub.flight_controller.battery_scale);
          if (spec.flight_controller_model) s.drive->CalibrateOn(known_sub.rotors);
        } catch (const std::invalid_argument& e) {
          throw std::invalid_argument("vehicle '" + spec.name + "', " + sub.name +
                                      ": the actuation model: " + e.what());
        }
      }
      if (config.flight_controller_sensing != FlightControllerSensing::kTruth) {
        const model::FlightControllerImu& noise = sub.flight_controller.imu;
        sensors::ImuConfig imu;
        imu.noise = {noise.gyroscope_noise_density, noise.gyroscope_random_walk,
                     noise.accelerometer_noise_density, noise.accelerometer_random_walk};
        imu.rate_hz = 1.0 / config.step_s;
        imu.gravity_mps2 = config.world.gravity_mps2;
        imu.initial_gyroscope_bias_sigma_radps = noise.gyroscope_bias_sigma_radps;
        imu.initial_accelerometer_bias_sigma_mps2 = noise.accelerometer_bias_sigma_mps2;
        s.imu =
            std::make_unique<sensors::ImuModel>(imu, StreamSeed(config.seed, vehicles_.size() * 64 + i + 33));
        try {
          s.gyro = std::make_unique<GyroFilter>(sub.flight_controller, config.step_s);
          if (config.flight_controller_sensing == FlightControllerSensing::kEstimate) {
            s.attitude = std::make_unique<sensors::ComplementaryAttitudeFilter>(
                config.flight_controller_estimate.gains, config.world.gravity_mps2);
            s.aiding_random.seed(StreamSeed(config.seed, vehicles_.size() * 64 + i + 17));
          }
        } catch (const std::invalid_argument& e) {
          throw std::invalid_argument("vehicle '" + spec.name + "', " + sub.name +
                                      ": the flight controller: " + e.what());
        }
      }
      const int n = s.rotors->count();
      if (spec.initial_rotors == InitialRotors::kHover) {
        RotorVector speeds;
        s.rotors->SpeedsForThrusts(RotorVector::Constant(n, hover_thrusts_N[i] / n), &speeds);
        s.rotors->SetSpeeds(speeds);
        s.setpoint.thrust_N = hover_thrusts_N[i];
      }
      s.setpoint.q_WS = world_.body(body).q_WB;  // hold the initial attitude until commanded
      try {                                      // one jitter stream per link
        s.link = bridge::LinkDelay(spec.command_link.delay_s, spec.command_link.jitter_s, config.step_s,
                                   StreamSeed(config.seed, vehicles_.size() * 64 + i + 1));
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument("vehicle '" + spec.name + "': the command link: " + e.what());
      }
      sim->sub_aircraft.push_back(std::move(s));
      SubAircraftOutput sub_out;
      sub_out.rotor_speeds_rad_s = sim->sub_aircraft.back().rotors->speeds_rad_s();
      sub_out.thrust_ratio = RotorVector::Ones(n);
      sub_out.throttle = RotorVector::Zero(n);
      if (const ElectricDrive* drive = sim->sub_aircraft.back().drive.get()) {  // the pack at rest
        sub_out.battery_voltage_V = drive->voltage_V();
        sub_out.state_of_charge = drive->battery().state_of_charge();
      }
      out.sub_aircraft.push_back(sub_out);
    }
    vehicles_.push_back(std::move(sim));
  }

  for (int body = 0; body < world_.body_count(); ++body) {
    if (world_.movable(body) && world_.bounding_radius_m(body) > 0.0) {
      wake_targets_.push_back({body, Eigen::Vector3d::Zero(), world_.bounding_radius_m(body)});
    }
  }
  wake_candidates_.reserve(wake_targets_.size());

  for (const LatchSpec& spec : config.latches) {
    const std::string what = "latch '" + spec.name + "': ";
    if (FindLatch(spec.name) >= 0) throw std::invalid_argument(what + "the name is used twice");
    LatchSim latch;
    latch.spec = spec;
    for (DockingPort* port : {&latch.spec.port_a, &latch.spec.port_b}) {
      if (!(port->axis_B.norm() > 0.0)) throw std::invalid_argument(what + "a port axis is zero");
      port->axis_B.normalize();
    }
    latch.output.body_a = world_.FindBody(spec.body_a);
    latch.output.body_b = world_.FindBody(spec.body_b);
    for (const auto& [body, name] :
         {std::pair{latch.output.body_a, spec.body_a}, {latch.output.body_b, spec.body_b}}) {
      if (body < 0) throw std::invalid_argument(what + "the world has no body '" + name + "'");
    }
    try {
      latch.world_latch = world_.AddLatch(latch.output.body_a, latch.output.body_b);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(what + e.what());
    }
    latches_.push_back(latch);
    UpdateLatch(latches_.back());
  }
}

Simulation::~Simulation() = default;

bool Simulation::SetCommand(int v, int s, const SubAircraftSetpoint& setpoint) {
  VehicleSim& vehicle = *vehicles_.at(v);
  if (!setpoint.IsValid()) {
    ++vehicle.output.invalid_commands;
    return false;
  }
  SubAircraftSim& sub = vehicle.sub_aircraft.at(s);
  SubAircraftSetpoint limited = setpoint;
  const double max_N = sub.rotors->count() * sub.rotors->max_thrust_N();
  if (setpoint.mode == SubAircraftSetpoint::Mode::kThrustTorque) {
    if (setpoint.thrust_W_N.norm() > max_N) limited.thrust_W_N *= max_N / setpoint.thrust_W_N.norm();
  } else {
    limited.thrust_N = std::clamp(setpoint.thrust_N, 0.0, max_N);
  }
  if (limited.thrust_N != setpoint.thrust_N || limited.thrust_W_N != setpoint.thrust_W_N) {
    ++vehicle.output.clamped_thrust_commands;
  }
  if (sub.link.immediate()) {
    sub.setpoint = limited;
    return true;
  }
  sub.in_flight.emplace_back(sub.link.Arrival(step_count()), limited);
  return true;
}

void Simulation::ApplyAir(VehicleSim& vehicle) {
  if (!air_.enabled) return;
  VehicleOutput& out = vehicle.output;
  const BodyState& platform = world_.body(out.platform_body);
  Eigen::Vector3d wind_W = air_.wind_W_mps;
  if (vehicle.turbulence) {
    // frozen turbulence carried past the vehicle at its airspeed (at least 0.5 m/s: the model needs V > 0,
    // and a hover in still air sees the gusts change no faster than that); u along the mean wind's
    // horizontal direction (north without one), v to its right, w down
    if (due_.turbulence) {
      const Eigen::Vector3d air_W = air_.wind_W_mps - platform.v_WBcom_W;
      const double airspeed_mps = std::max(air_W.norm(), 0.5);
      const double height_m = std::max(ground_z_m_ - platform.p_WBcom_m.z(), 0.0);
      vehicle.gust_mps = vehicle.turbulence->Step(LowAltitudeDryden(height_m, air_.w20_mps), airspeed_mps,
                                                  turbulence_every_steps_ * world_.step_s());
    }
    const Eigen::Vector3d& gust = vehicle.gust_mps;
    Eigen::Vector3d along(air_.wind_W_mps.x(), air_.wind_W_mps.y(), 0.0);
    along = along.norm() > 1e-9 ? along.normalized() : Eigen::Vector3d::UnitX();
    wind_W += gust.x() * along + gust.y() * Eigen::Vector3d::UnitZ().cross(along) +
              gust.z() * Eigen::Vector3d::UnitZ();
  }
  const double t_s = static_cast<double>(step_count()) * world_.step_s();
  for (const DiscreteGust& gust : air_.gusts) wind_W += GustVelocity_W(gust, t_s);
  out.wind_W_mps = wind_W;
  out.air_force_W_N.setZero();
  for (SubAircraftOutput& sub : out.sub_aircraft) sub.air_force_W_N.setZero();
  if (!air_.body_drag) return;
  auto drag = [&](int body, const Eigen::Vector3d& area_B_m2) -> Eigen::Vector3d {
    if (area_B_m2.isZero()) return Eigen::Vector3d::Zero();
    const BodyState& state = world_.body(body);
    const Eigen::Vector3d force_W =
        DragForce_W(area_B_m2, air_.density_kgpm3, state.q_WB, state.v_WBcom_W, wind_W);
    world_.AddForce_W(body, force_W);
    out.air_force_W_N += force_W;
    return force_W;
  };
  drag(out.platform_body, vehicle.spec.vehicle.platform_drag_area_B_m2);
  for (size_t s = 0; s < out.sub_aircraft_bodies.size(); ++s) {
    out.sub_aircraft[s].air_force_W_N =
        drag(out.sub_aircraft_bodies[s], vehicle.spec.vehicle.sub_aircraft[s].drag_area_B_m2);
  }
}

void Simulation::ApplyRotorAir(VehicleSim& vehicle, int s) {
  const SubAircraftSim& sim = vehicle.sub_aircraft[s];
  SubAircraftOutput& out = vehicle.output.sub_aircraft[s];
  const BodyState& state = world_.body(vehicle.output.sub_aircraft_bodies[s]);
  const model::RotorSet& rotors = sim.rotors->set();
  const Eigen::Matrix3d R_WS = state.q_WB.toRotationMatrix();  // once for the hubs and the drag
  if (air_.ground_effect && rotors.radius_m > 0.0) {
    // the wake leaves along +z_S; the image model holds for a surface across it, so the distance is taken
    // along the rotor axis (for a tilted rotor over flat ground, its height / cos(tilt)); beyond 10 radii the
    // ratio is within 0.07 % of 1 and no surface is looked for
    const double reach_m = 10.0 * rotors.radius_m;
    const Eigen::Vector3d axis_W = R_WS.col(2);
    for (int j = 0; j < sim.rotors->count(); ++j) {
      const Eigen::Vector3d hub_W = state.p_WB_m + R_WS * rotors.hub_S_m[j];
      const double distance_m = world_.StaticSurfaceDistance_m(hub_W, axis_W, reach_m);
      out.thrust_ratio[j] =
          distance_m < reach_m ? CheesemanBennettThrustRatio(distance_m / rotors.radius_m) : 1.0;
    }
  }
  if (air_.rotor_drag) {
    Eigen::Vector3d force_S, torque_S;
    sim.rotors->AirWrench_S(R_WS.transpose() * (state.v_WBcom_W - vehicle.output.wind_W_mps),
                            R_WS.transpose() * state.w_WB_W, &force_S, &torque_S);
    const Eigen::Vector3d force_W = R_WS * force_S;
    world_.AddForce_W(vehicle.output.sub_aircraft_bodies[s], force_W);
    world_.AddTorque_W(vehicle.output.sub_aircraft_bodies[s], R_WS * torque_S);
    out.air_force_W_N += force_W;
    vehicle.output.air_force_W_N += force_W;
  }
}

void Simulation::AddAirForce(int body, const Eigen::Vector3d& force_W_N, const Eigen::Vector3d& p_W_m) {
  world_.AddForce_W(body, force_W_N);
  world_.AddTorque_W(body, (p_W_m - world_.body(body).p_WBcom_m).cross(force_W_N));
  if (vehicle_of_body_[body] < 0) return;
  VehicleOutput& out = vehicles_[vehicle_of_body_[body]]->output;
  out.air_force_W_N += force_W_N;
  for (size_t s = 0; s < out.sub_aircraft_bodies.size(); ++s) {
    if (out.sub_aircraft_bodies[s] == body) out.sub_aircraft[s].air_force_W_N += force_W_N;
  }
}

// Each rotor's wake (physics/rotor.h) as kWakeCells rays, one per cell of equal area of its cross-section,
// each carrying that share of the momentum flux, to the first surface it meets within 20 rotor radii (2.5 m
// for the F450; further down the wake has spread to 2.3 R). A movable body there takes C_D / 2 of the share
// at the point hit, along the wake; a static surface (the ground, an object) stops the ray. The wake leaves
// along the rotor axis at its far speed 2 v_h and the air around carries it (the skewed wake of forward
// flight, as in Glauert's model of it). Bounding spheres first: a body whose sphere cannot reach the wake's
// cone is not ray-tested, so a vehicle whose wakes pass clear of everything pays a few products per rotor.
// Evaluated at kWakeRate_hz (EvaluateWakes), each force held on the point it hit, on the body that moves.
void Simulation::ApplyDownwash(VehicleSim& vehicle, int s) {
  SubAircraftSim& sim = vehicle.sub_aircraft[s];
  if (due_.wakes) EvaluateWakes(vehicle, s);
  for (const SubAircraftSim::WakeForce& wake : sim.wake_forces) {
    const BodyState& hit = world_.body(wake.body);
    AddAirForce(wake.body, wake.force_W_N, hit.p_WBcom_m + hit.q_WB * wake.p_CH_B_m);
  }
}

void Simulation::EvaluateWakes(VehicleSim& vehicle, int s) {
  SubAircraftSim& sim = vehicle.sub_aircraft[s];
  sim.wake_forces.clear();
  const model::RotorSet& rotors = sim.rotors->set();
  const double radius_m = rotors.radius_m;
  if (!(radius_m > 0.0 && air_.density_kgpm3 > 0.0)) return;
  const int own_body = vehicle.output.sub_aircraft_bodies[s];
  const BodyState& state = world_.body(own_body);
  const double reach_m = 20.0 * radius_m;
  const double far_radius_m = WakeRadius_m(reach_m, radius_m);
  const Eigen::Matrix3d R_WB = state.q_WB.toRotationMatrix();  // once for the four hubs
  const Eigen::Vector3d axis_W = R_WB.col(2);
  const Eigen::Vector3d air_W = vehicle.output.wind_W_mps - state.v_WBcom_W;
  const double share = 0.5 * air_.downwash_drag_coefficient / kWakeCells;
  const double per_disk_load = 1.0 / (2.0 * air_.density_kgpm3 * M_PI * radius_m * radius_m);  // v_h² / T
  for (int j = 0; j < sim.rotors->count(); ++j) {
    const double speed = sim.rotors->speeds_rad_s()[j];
    const double thrust_N =
        rotors.thrust_coefficient * speed * speed * vehicle.output.sub_aircraft[s].thrust_ratio[j];
    if (!(thrust_N > 0.0)) continue;
    const double far_speed_mps = 2.0 * std::sqrt(thrust_N * per_disk_load);
    const Eigen::Vector3d along_W = (far_speed_mps * axis_W + air_W).normalized();
    const Eigen::Vector3d hub_W = state.p_WB_m + R_WB * rotors.hub_S_m[j];
    wake_candidates_.clear();
    for (const WakeTarget& target : wake_targets_) {
      if (target.body == own_body) continue;
      const Eigen::Vector3d p_HC_W = target.p_WC_m - hub_W;
      const double r = target.radius_m;
      const double t = p_HC_W.dot(along_W);
      if (t < -r || t > reach_m + r) continue;
      // the cone's radius where the sphere can reach furthest down it (the cone widens slowly)
      const double wake_m = WakeRadius_m(std::clamp(t + r, 0.0, reach_m), radius_m);
      if ((p_HC_W - t * along_W).squaredNorm() <= (wake_m + r) * (wake_m + r)) {
        wake_candidates_.push_back(target.body);
      }
    }
    if (wake_candidates_.empty()) continue;
    // the cells' axes: the sub-aircraft's x axis, across the wake
    Eigen::Vector3d e1_W = R_WB.col(0);
    e1_W = (e1_W - e1_W.dot(along_W) * along_W).normalized();
    const Eigen::Vector3d e2_W = along_W.cross(e1_W);
    for (const Eigen::Vector2d& cell : WakeCells()) {
      const Eigen::Vector3d offset_W = cell.x() * e1_W + cell.y() * e2_W;
      const Eigen::Vector3d from_W = hub_W + WakeRadius_m(0.0, radius_m) * offset_W;
      const Eigen::Vector3d to_W = hub_W + reach_m * along_W + far_radius_m * offset_W;
      const double length_m = (to_W - from_W).norm();
      double fraction =
          world_.StaticSurfaceDistance_m(from_W, (to_W - from_W) / length_m, length_m) / length_m;
      int hit = -1;
      for (const int body : wake_candidates_) {
        const double f = world_.BodyRayFraction(body, from_W, to_W);
        if (f < fraction) {
          fraction = f;
          hit = body;
        }
      }
      if (hit < 0) continue;
      const double distance_m = fraction * reach_m;  // along the wake
      const BodyState& target = world_.body(hit);
      sim.wake_forces.push_back(
          {hit, share * WakeMomentumFlux_N(thrust_N, distance_m, radius_m) * along_W,
           target.q_WB.conjugate() * (from_W + fraction * (to_W - from_W) - target.p_WBcom_m)});
    }
  }
}

void Simulation::ApplySubAircraft(VehicleSim& vehicle, int s) {
  SubAircraftSim& sim = vehicle.sub_aircraft[s];
  SubAircraftOutput& out = vehicle.output.sub_aircraft[s];
  const int body = vehicle.output.sub_aircraft_bodies[s];
  const BodyState& state = world_.body(body);
  const double dt = world_.step_s();

  Eigen::Vector3d force_S, torque_S;
  if (sim.setpoint.mode == SubAircraftSetpoint::Mode::kThrustTorque) {
    out.thrust_W_N = sim.setpoint.thrust_W_N;
    out.torque_S_Nm = sim.setpoint.torque_S_Nm;
    out.saturated = false;
  } else {
    if (air_.enabled) ApplyRotorAir(vehicle, s);
    // the rotors act with the speeds they have now; the controller then moves them for the next step
    sim.rotors->Wrench_S(out.thrust_ratio, &force_S, &torque_S);
    if (air_.enabled && air_.downwash) ApplyDownwash(vehicle, s);
    out.thrust_W_N = state.q_WB * force_S;
    out.torque_S_Nm = torque_S;
    RotorVector thrusts, speeds;
    Eigen::Quaterniond q_WS;
    Eigen::Vector3d w_WS_S, alpha_WS_S;
    SenseRotation(sim, state, &q_WS, &w_WS_S, &alpha_WS_S);
    out.q_WS_flight_controller = q_WS;
    const MixerCut cut = sim.controller->Update(sim.setpoint, q_WS, w_WS_S, alpha_WS_S, dt, &thrusts);
    out.saturated = cut.any();
    if (sim.drive) {
      sim.drive->Step(thrusts, dt, sim.rotors.get());
      out.throttle = sim.drive->throttle();
      out.battery_voltage_V = sim.drive->voltage_V();
      out.battery_current_A = sim.drive->current_A();
      out.state_of_charge = sim.drive->battery().state_of_charge();
    } else {
      sim.controller_rotors().SpeedsForThrusts(thrusts, &speeds);
      sim.rotors->Step(speeds, dt);
    }
    out.rotor_speeds_rad_s = sim.rotors->speeds_rad_s();
    if (out.saturated) ++vehicle.output.saturated_steps;
    vehicle.output.mixer_cut_steps.roll_pitch += cut.roll_pitch ? 1 : 0;
    vehicle.output.mixer_cut_steps.thrust += cut.thrust ? 1 : 0;
    vehicle.output.mixer_cut_steps.yaw += cut.yaw ? 1 : 0;
  }
  world_.AddForce_W(body, out.thrust_W_N);
  const Eigen::Vector3d torque_W = state.q_WB * out.torque_S_Nm;
  if (vehicle.spec.torque_reaction == TorqueReaction::kPlatform) {
    world_.AddJointTorque_W(body, torque_W);
  } else {
    world_.AddTorque_W(body, torque_W);
  }
}

void Simulation::SenseRotation(SubAircraftSim& sim, const BodyState& state, Eigen::Quaterniond* q_WS,
                               Eigen::Vector3d* w_WS_S_radps, Eigen::Vector3d* alpha_WS_S_radps2) {
  const double dt = world_.step_s();
  const Eigen::Quaterniond q_SW = state.q_WB.conjugate();
  *q_WS = state.q_WB;
  *w_WS_S_radps = q_SW * state.w_WB_W;
  alpha_WS_S_radps2->setZero();  // no D term on the truth
  if (!sim.imu) return;
  // the IMU mounted level at the sub-aircraft's origin: I = S
  Eigen::Vector3d w_I_radps = sim.attitude ? sim.imu->SampleGyroscopeInInterval(*w_WS_S_radps, dt)
                                           : sim.imu->SampleGyroscope(*w_WS_S_radps, dt);
  if (sim.attitude) {
    const FlightControllerEstimate& estimate = estimate_;
    const int64_t k = step_count();
    // a heading, or the mean of a second of them
    const auto yaw_rad = [&](double count) {
      return sensors::RollPitchYaw_rad(state.q_WB).z() +
             estimate.heading_sigma_rad / std::sqrt(count) * sensors::StandardNormal(sim.aiding_random);
    };
    if (!sim.attitude->initialized()) {  // aligned on the ground (FlightControllerEstimate)
      Eigen::Vector3d gyroscope_bias_S_radps = Eigen::Vector3d::Zero();
      if (estimate.calibrated) {
        gyroscope_bias_S_radps = sim.imu->gyroscope_bias_radps();
        sim.accelerometer_offset_S_mps2 = sim.imu->accelerometer_bias_mps2();
      }
      const Eigen::Vector3d f_at_rest_S_mps2 = q_SW * Eigen::Vector3d(0.0, 0.0, -gravity_W_.z()) +
                                               sim.imu->accelerometer_bias_mps2() -
                                               sim.accelerometer_offset_S_mps2;
      sim.attitude->Initialize(
          sensors::LevelFromSpecificForce(f_at_rest_S_mps2, yaw_rad(estimate.heading_rate_hz)),
          gyroscope_bias_S_radps);
    }
    if (due_.velocity) {
      sim.attitude->UpdateVelocity(
          state.v_WB_W + estimate.velocity_sigma_mps * sensors::Gaussian3(sim.aiding_random), k * dt);
    }
    if (due_.heading) sim.attitude->UpdateHeading(yaw_rad(1.0), heading_every_steps_ * dt);
    // the filter on the IMU's means over PX4's integration interval (f = R_WSᵀ (a − g) at the origin)
    sim.w_sum_S_radps += w_I_radps;
    sim.f_sum_S_mps2 += q_SW * (state.a_WB_W - gravity_W_);
    if (++sim.integrated_steps == imu_integration_steps_) {
      const double interval_s = imu_integration_steps_ * dt;
      const Eigen::Vector3d f_S_mps2 =
          sim.imu->EndInterval(sim.f_sum_S_mps2 / imu_integration_steps_, interval_s);
      sim.attitude->Update(sim.w_sum_S_radps / imu_integration_steps_,
                           f_S_mps2 - sim.accelerometer_offset_S_mps2, interval_s);
      sim.w_sum_S_radps.setZero();
      sim.f_sum_S_mps2.setZero();
      sim.integrated_steps = 0;
    } else {
      sim.attitude->Propagate(w_I_radps, dt);
    }
    *q_WS = sim.attitude->q_WB();
    w_I_radps -= sim.attitude->gyroscope_bias_B_radps();
  }
  sim.gyro->Update(w_I_radps);
  *w_WS_S_radps = sim.gyro->rate_S_radps();
  *alpha_WS_S_radps2 = sim.gyro->acceleration_S_radps2();
}

void Simulation::Step() {
  const int64_t k = step_count();
  due_ = {k % turbulence_every_steps_ == 0, k % wake_every_steps_ == 0, k % velocity_every_steps_ == 0,
          k % heading_every_steps_ == 0};
  for (auto& vehicle : vehicles_) ApplyAir(*vehicle);  // before any wake reaches another vehicle
  if (air_.enabled && air_.downwash && due_.wakes) {
    for (WakeTarget& target : wake_targets_) target.p_WC_m = world_.body(target.body).p_WBcom_m;
  }
  for (auto& vehicle : vehicles_) {
    for (SubAircraftSim& sub : vehicle->sub_aircraft) {
      while (!sub.in_flight.empty() && sub.in_flight.front().first <= step_count()) {
        sub.setpoint = sub.in_flight.front().second;
        sub.in_flight.pop_front();
      }
    }
    for (int s = 0; s < static_cast<int>(vehicle->sub_aircraft.size()); ++s) ApplySubAircraft(*vehicle, s);
  }
  world_.Step();
  for (int v = 0; v < vehicle_count(); ++v) ComputeOutputs(v);
  for (LatchSim& latch : latches_) UpdateLatch(latch);
}

int Simulation::FindLatch(const std::string& name) const {
  for (size_t l = 0; l < latches_.size(); ++l) {
    if (latches_[l].spec.name == name) return static_cast<int>(l);
  }
  return -1;
}

bool Simulation::CloseLatch(int l) { return Close(latches_.at(l)); }

bool Simulation::Close(LatchSim& latch) {
  LatchOutput& out = latch.output;
  if (!out.latched && out.can_close) {
    world_.CloseLatch(latch.world_latch);
    out.latched = true;
    ++out.closes;
  }
  return out.latched;
}

void Simulation::OpenLatch(int l) {
  LatchSim& latch = latches_.at(l);
  LatchOutput& out = latch.output;
  if (!out.latched) return;
  world_.OpenLatch(latch.world_latch);
  out.latched = false;
  out.armed = false;
  ++out.opens;
}

void Simulation::UpdateLatch(LatchSim& latch) {
  const LatchSpec& spec = latch.spec;
  LatchOutput& out = latch.output;
  const BodyState& a = world_.body(out.body_a);
  const BodyState& b = world_.body(out.body_b);
  const Eigen::Vector3d p_WQa = a.p_WB_m + a.q_WB * spec.port_a.p_BQ_m;
  const Eigen::Vector3d p_WQb = b.p_WB_m + b.q_WB * spec.port_b.p_BQ_m;
  const Eigen::Vector3d axis_a_W = a.q_WB * spec.port_a.axis_B;
  const Eigen::Vector3d axis_b_W = b.q_WB * spec.port_b.axis_B;
  const Eigen::Vector3d p_QaQb_W = p_WQb - p_WQa;
  out.axial_error_m = p_QaQb_W.dot(axis_a_W);
  out.radial_error_m = (p_QaQb_W - out.axial_error_m * axis_a_W).norm();
  out.angular_error_rad = std::atan2(axis_a_W.cross(axis_b_W).norm(), -axis_a_W.dot(axis_b_W));
  const Eigen::Vector3d v_WQa = a.v_WB_W + a.w_WB_W.cross(p_WQa - a.p_WB_m);
  const Eigen::Vector3d v_WQb = b.v_WB_W + b.w_WB_W.cross(p_WQb - b.p_WB_m);
  out.relative_speed_mps = (v_WQb - v_WQa).norm();

  const bool within_tolerance = std::abs(out.axial_error_m) <= spec.axial_tolerance_m &&
                                out.radial_error_m <= spec.radial_tolerance_m &&
                                out.angular_error_rad <= spec.angular_tolerance_rad;
  out.can_close = within_tolerance && out.relative_speed_mps <= spec.max_relative_speed_mps;
  if (!within_tolerance) out.armed = true;
  if (spec.auto_close && out.armed) Close(latch);
}

void Simulation::ComputeOutputs(int v) {
  VehicleOutput& out = vehicles_[v]->output;
  const BodyState& platform = world_.body(out.platform_body);
  const Eigen::Matrix3d R_PW = platform.q_WB.conjugate().toRotationMatrix();
  const std::vector<int>& subs = out.sub_aircraft_bodies;
  const auto in_vehicle = [&](int body) { return body >= 0 && vehicle_of_body_[body] == v; };

  out.external_force_W_N.setZero();
  out.external_torque_W_Nm.setZero();
  for (auto& sub : out.sub_aircraft) sub.contact_force_W_N.setZero();
  for (const Contact& contact : world_.contacts()) {
    const bool a_in = in_vehicle(contact.body_a);
    if (a_in == in_vehicle(contact.body_b)) continue;  // not touching the vehicle, or touching itself
    const Eigen::Vector3d force_W = a_in ? contact.force_on_a_W_N : Eigen::Vector3d(-contact.force_on_a_W_N);
    const int body = a_in ? contact.body_a : contact.body_b;
    out.external_force_W_N += force_W;
    out.external_torque_W_Nm += (contact.point_W_m - platform.p_WB_m).cross(force_W);
    for (size_t s = 0; s < subs.size(); ++s) {
      if (subs[s] == body) out.sub_aircraft[s].contact_force_W_N += force_W;
    }
  }
  out.external_force_P_N = R_PW * out.external_force_W_N;
  out.external_torque_P_Nm = R_PW * out.external_torque_W_Nm;

  // Newton's law on each sub-aircraft: what the joint pushed on it is what it did not get from elsewhere
  for (size_t s = 0; s < subs.size(); ++s) {
    SubAircraftOutput& sub = out.sub_aircraft[s];
    const double m = world_.mass_kg(subs[s]);
    const Eigen::Vector3d joint_on_sub_W = m * world_.body(subs[s]).a_WBcom_W - sub.thrust_W_N -
                                           m * gravity_W_ - sub.contact_force_W_N - sub.air_force_W_N;
    sub.joint_force_P_N = R_PW * (-joint_on_sub_W);
  }
}

}  // namespace iapsim::physics
