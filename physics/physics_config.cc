#include "physics/physics_config.h"

#include <cmath>
#include <stdexcept>

#include "bridge/scenario.h"
#include "model/urdf.h"
#include "model/vehicle.h"

namespace iapsim::physics {
namespace {

using bridge::YamlMap;

constexpr double kDegToRad = M_PI / 180.0;

Material ReadMaterial(YamlMap& map, Material material) {
  map.OptionalInRange("friction", &material.friction, 0.0, 10.0);
  map.OptionalInRange("restitution", &material.restitution, 0.0, 1.0);
  map.OptionalInRange("contact_stiffness_N_per_m", &material.contact_stiffness_N_per_m, 0.0, 1e12);
  map.OptionalInRange("contact_damping_Ns_per_m", &material.contact_damping_Ns_per_m, 0.0, 1e12);
  return material;
}

CollisionFilter ReadFilter(YamlMap& map) {
  CollisionFilter filter;
  map.Optional("group", &filter.group);
  map.Optional("mask", &filter.mask);
  if (filter.group == 0) map.Fail("group", "must have at least one bit set");
  map.Finish();
  return filter;
}

void ReadPose(YamlMap& map, Eigen::Vector3d* p_m, Eigen::Quaterniond* q) {
  model::OptionalVector3(map, "position_m", p_m);
  Eigen::Vector3d rpy = Eigen::Vector3d::Zero();
  model::OptionalVector3(map, "rpy_deg", &rpy, kDegToRad);
  *q = Eigen::Quaterniond(model::RotationFromRpy(rpy));
}

WorldObject ReadObject(YamlMap& map) {
  WorldObject object;
  map.Required("name", &object.name);
  map.OptionalInRange("mass_kg", &object.mass_kg, 0.0, 1e6);
  model::OptionalShapes(map, "shapes", &object.shapes,
                        object.mass_kg > 0.0 ? model::BodyMotion::kMoving : model::BodyMotion::kStatic);
  if (object.shapes.empty()) map.Fail("shapes", "an object needs at least one shape");
  ReadPose(map, &object.p_WO_m, &object.q_WO);
  model::OptionalVector3(map, "inertia_kgm2", &object.inertia_kgm2);
  if (map.Has("material")) {
    YamlMap material = map.Map("material");
    object.material = ReadMaterial(material, object.material);
    material.Finish();
  }
  if (map.Has("collision")) {
    YamlMap filter = map.Map("collision");
    object.filter = ReadFilter(filter);
  }
  map.Finish();
  return object;
}

WorldConfig ReadWorld(YamlMap& map) {
  WorldConfig world;
  map.OptionalInRange("gravity_mps2", &world.gravity_mps2, 0.0, 100.0);
  map.OptionalInRange("solver_iterations", &world.solver_iterations, 1, 10000);
  map.OptionalInRange("solver_tolerance_mps", &world.solver_tolerance_mps, 0.0, 1.0);
  map.Optional("warm_start", &world.warm_start);
  map.OptionalInRange("speculative_contact_speed_mps", &world.speculative_contact_speed_mps, 0.0, 1000.0);
  map.OptionalInRange("contact_breaking_distance_m", &world.contact_breaking_distance_m, 0.0, 1.0);
  map.Optional("factored_contact_rows", &world.factored_contact_rows);
  if (map.Has("ground")) {
    YamlMap ground = map.Map("ground");
    ground.Optional("enabled", &world.ground);
    ground.Optional("z_m", &world.ground_z_m);
    world.ground_material = ReadMaterial(ground, world.ground_material);
    ground.Finish();
  }
  if (map.Has("objects")) {
    const YAML::Node objects = map.Raw("objects");
    if (!objects.IsSequence()) map.Fail("objects", "expected a list of objects");
    YAML::Node resolved;
    for (size_t i = 0; i < objects.size(); ++i) {
      YamlMap object(objects[i], map.file(), map.PathOf("objects") + "[" + std::to_string(i) + "]");
      world.objects.push_back(ReadObject(object));
      for (const auto& other : world.objects) {
        if (&other != &world.objects.back() && other.name == world.objects.back().name) {
          object.Fail("name", "'" + other.name + "' is used twice");
        }
      }
      resolved.push_back(object.Resolved());
    }
    map.SetResolved("objects", resolved);
  }
  map.Finish();
  return world;
}

VehicleSpec ReadVehicle(YamlMap& map, const std::string& scenario_file, std::string* urdf_path) {
  VehicleSpec spec;
  map.Required("name", &spec.name);
  if (spec.name.empty() || spec.name.find_first_of("/ ") != std::string::npos) {
    map.Fail("name", "must be a non-empty topic name part (no '/' or spaces)");
  }
  const std::string file = bridge::ReadFilePath(map, "file", scenario_file);
  spec.vehicle = model::LoadVehicle(file);
  if (map.Has("urdf")) {  // a hand-written URDF instead of the generated one; link names must match
    *urdf_path = bridge::ReadFilePath(map, "urdf", scenario_file);
    try {
      spec.description = model::LoadUrdfFile(*urdf_path);
    } catch (const std::invalid_argument& e) {
      map.Fail("urdf", e.what());
    }
  } else {
    spec.description = model::ParseUrdf(model::GenerateUrdf(spec.vehicle), file + " (generated URDF)");
  }
  model::OptionalVector3(map, "position_m", &spec.p_WP_m);
  double yaw_deg = 0.0, roll_deg = 0.0, pitch_deg = 0.0;
  map.OptionalInRange("yaw_deg", &yaw_deg, -360.0, 360.0);
  // a start moving as one rigid body (an RL episode's, eq. (23)): R_WP = Rz(yaw) Ry(pitch) Rx(roll)
  map.OptionalInRange("roll_deg", &roll_deg, -180.0, 180.0);
  map.OptionalInRange("pitch_deg", &pitch_deg, -90.0, 90.0);
  spec.yaw_rad = yaw_deg * kDegToRad;
  spec.roll_rad = roll_deg * kDegToRad;
  spec.pitch_rad = pitch_deg * kDegToRad;
  model::OptionalVector3(map, "velocity_mps", &spec.v_WP_W_mps);
  Eigen::Vector3d angular_velocity_deg_s = Eigen::Vector3d::Zero();
  model::OptionalVector3(map, "angular_velocity_deg_s", &angular_velocity_deg_s);
  spec.w_WP_W_radps = angular_velocity_deg_s * kDegToRad;
  std::string rotors = "hover";
  map.OptionalChoice("rotors", &rotors, {"hover", "idle"});
  spec.initial_rotors = rotors == "hover" ? InitialRotors::kHover : InitialRotors::kIdle;
  std::string reaction = "air";
  map.OptionalChoice("torque_reaction", &reaction, {"air", "platform"});
  spec.torque_reaction = reaction == "air" ? TorqueReaction::kAir : TorqueReaction::kPlatform;
  if (map.Has("command_link")) {
    YamlMap link = map.Map("command_link");
    link.OptionalInRange("delay_s", &spec.command_link.delay_s, 0.0, 10.0);
    link.OptionalInRange("jitter_s", &spec.command_link.jitter_s, 0.0, 10.0);
    link.Finish();
  }
  map.Finish();
  return spec;
}

// {position_m, axis}, both in the body frame
DockingPort ReadPort(YamlMap& map) {
  DockingPort port;
  for (const std::string key : {"position_m", "axis"}) {
    if (!map.Has(key)) map.Fail(key, "is required (a port is {position_m, axis} in its body's frame)");
  }
  model::OptionalVector3(map, "position_m", &port.p_BQ_m);
  model::OptionalVector3(map, "axis", &port.axis_B);
  if (!(port.axis_B.norm() > 1e-9)) map.Fail("axis", "must be a non-zero vector");
  port.axis_B.normalize();
  map.Finish();
  return port;
}

// The body under `key`: a vehicle's link "<vehicle>/<link>" (returns true) or a world object (false). A
// latch holds bodies with collision shapes only (Bullet solves it between colliders).
bool ReadLatchBody(YamlMap& map, const std::string& key, const SimulationConfig& simulation,
                   std::string* name) {
  map.Required(key, name);
  for (const auto& object : simulation.world.objects) {
    if (object.name == *name) return false;  // an object always has shapes
  }
  for (const auto& vehicle : simulation.vehicles) {
    for (const auto& link : vehicle.description.links) {
      if (vehicle.name + "/" + link.name != *name) continue;
      if (link.collision.empty()) {
        map.Fail(key, "'" + *name + "' has no collision shape for the latch to hold");
      }
      return true;
    }
  }
  map.Fail(key, "'" + *name + "' is not a body of the world (\"<vehicle>/<link>\" or an object's name)");
}

double ReadTolerance(YamlMap& map, const std::string& key) {
  double tolerance_m = 0.0;
  map.Required(key, &tolerance_m);
  if (!(tolerance_m > 0.0 && tolerance_m <= 1.0)) map.Fail(key, "must be in (0, 1] m");
  return tolerance_m;
}

LatchSpec ReadLatch(YamlMap& map, const SimulationConfig& simulation) {
  LatchSpec latch;
  map.Required("name", &latch.name);
  if (latch.name.empty()) map.Fail("name", "must not be empty");
  const bool a_in_vehicle = ReadLatchBody(map, "body_a", simulation, &latch.body_a);
  const bool b_in_vehicle = ReadLatchBody(map, "body_b", simulation, &latch.body_b);
  if (latch.body_a == latch.body_b) map.Fail("body_b", "is body_a: a latch joins two bodies");
  if (!a_in_vehicle && !b_in_vehicle) map.Fail("body_b", "one of the two bodies must be a vehicle's");
  for (const auto& [key, port] : {std::pair{"port_a", &latch.port_a}, {"port_b", &latch.port_b}}) {
    if (!map.Has(key)) map.Fail(key, "is required: {position_m, axis} in the body's frame");
    YamlMap port_map = map.Map(key);
    *port = ReadPort(port_map);
  }
  latch.axial_tolerance_m = ReadTolerance(map, "axial_tolerance_m");
  latch.radial_tolerance_m = ReadTolerance(map, "radial_tolerance_m");
  double angular_tolerance_deg = latch.angular_tolerance_rad / kDegToRad;
  map.OptionalInRange("angular_tolerance_deg", &angular_tolerance_deg, 0.0, 180.0);
  latch.angular_tolerance_rad = angular_tolerance_deg * kDegToRad;
  map.OptionalInRange("max_relative_speed_mps", &latch.max_relative_speed_mps, 0.0, 100.0);
  map.Optional("auto", &latch.auto_close);
  map.Finish();
  return latch;
}

// gusts: [{start_s, rise_s, hold_s, amplitude_W_mps: [n, e, d]}, ...]
std::vector<DiscreteGust> ReadGusts(YamlMap& air) {
  std::vector<DiscreteGust> gusts;
  if (!air.Has("gusts")) return gusts;
  YAML::Node resolved(YAML::NodeType::Sequence);
  const YAML::Node list = air.Raw("gusts");
  if (!list.IsSequence()) air.Fail("gusts", "expected a list of {start_s, rise_s, hold_s, amplitude_W_mps}");
  for (size_t i = 0; i < list.size(); ++i) {
    YamlMap map(list[i], air.file(), air.PathOf("gusts") + "[" + std::to_string(i) + "]");
    DiscreteGust gust;
    map.Required("start_s", &gust.start_s);
    if (!(gust.start_s >= 0.0 && gust.start_s < 1e9)) map.Fail("start_s", "expected a time >= 0 s");
    map.Required("rise_s", &gust.rise_s);
    if (!(gust.rise_s > 0.0 && gust.rise_s < 1e6)) map.Fail("rise_s", "expected a rise time > 0 s");
    map.OptionalInRange("hold_s", &gust.hold_s, 0.0, 1e9);
    if (!map.Has("amplitude_W_mps"))
      map.Fail("amplitude_W_mps", "is required: the gust's peak wind, NED, m/s");
    model::OptionalVector3(map, "amplitude_W_mps", &gust.amplitude_W_mps);
    if (!gust.amplitude_W_mps.allFinite() || gust.amplitude_W_mps.norm() > 100.0) {
      map.Fail("amplitude_W_mps", "expected a gust of at most 100 m/s");
    }
    map.Finish();
    gusts.push_back(gust);
    resolved.push_back(map.Resolved());
  }
  air.SetResolved("gusts", resolved);
  return gusts;
}

}  // namespace

PhysicsConfig ReadPhysicsConfig(YamlMap& params, const std::string& scenario_file, double publish_step_s) {
  PhysicsConfig config;
  params.OptionalInRange("substeps", &config.substeps, 1, 10000);
  params.Optional("publish_contacts", &config.publish_contacts);
  config.simulation.step_s = publish_step_s / config.substeps;
  YamlMap world = params.Map("world");
  config.simulation.world = ReadWorld(world);
  if (params.Has("air")) {
    YamlMap air = params.Map("air");
    AirConfig& out = config.simulation.air;
    air.OptionalInRange("density_kgpm3", &out.density_kgpm3, 0.0, 100.0);
    model::OptionalVector3(air, "wind_W_mps", &out.wind_W_mps);
    if (!out.wind_W_mps.allFinite() || out.wind_W_mps.norm() > 100.0) {
      air.Fail("wind_W_mps", "expected a mean wind of at most 100 m/s");
    }
    if (air.Has("turbulence")) {
      YamlMap turbulence = air.Map("turbulence");
      std::string model = "dryden";
      turbulence.OptionalChoice("model", &model, {"dryden"});
      turbulence.OptionalInRange("w20_mps", &out.w20_mps, 0.0, 50.0);
      turbulence.Finish();
      out.turbulence = true;
    }
    out.gusts = ReadGusts(air);
    air.Optional("body_drag", &out.body_drag);
    air.Optional("rotor_drag", &out.rotor_drag);
    air.Optional("ground_effect", &out.ground_effect);
    air.Optional("downwash", &out.downwash);
    air.Optional("downwash_drag_coefficient", &out.downwash_drag_coefficient);
    if (!(out.downwash_drag_coefficient > 0.0 && out.downwash_drag_coefficient <= 2.0)) {
      air.Fail("downwash_drag_coefficient",
               "expected a drag coefficient in (0, 2] (2: all the blocked momentum turned aside)");
    }
    air.Finish();
    out.enabled = true;
  }

  const YAML::Node vehicles = params.Raw("vehicles");
  if (!vehicles || !vehicles.IsSequence() || vehicles.size() == 0) {
    params.Fail("vehicles", "expected a list of vehicles ({name, file, position_m, ...})");
  }
  YAML::Node resolved;
  for (size_t i = 0; i < vehicles.size(); ++i) {
    YamlMap vehicle(vehicles[i], params.file(), "vehicles[" + std::to_string(i) + "]");
    std::string urdf;
    config.simulation.vehicles.push_back(ReadVehicle(vehicle, scenario_file, &urdf));
    config.urdf.push_back(urdf);
    for (size_t j = 0; j < i; ++j) {
      if (config.simulation.vehicles[j].name == config.simulation.vehicles[i].name) {
        vehicle.Fail("name", "'" + config.simulation.vehicles[i].name + "' is used twice");
      }
    }
    resolved.push_back(vehicle.Resolved());
  }
  params.SetResolved("vehicles", resolved);

  std::string sensing = "truth";
  params.OptionalChoice("flight_controller_sensing", &sensing, {"truth", "gyro", "estimate"});
  config.simulation.flight_controller_sensing = sensing == "gyro"       ? FlightControllerSensing::kGyro
                                                : sensing == "estimate" ? FlightControllerSensing::kEstimate
                                                                        : FlightControllerSensing::kTruth;
  if (params.Has("flight_controller_estimate")) {
    if (sensing != "estimate") {
      params.Fail("flight_controller_estimate", "is read only with flight_controller_sensing: estimate");
    }
    YamlMap estimate = params.Map("flight_controller_estimate");
    FlightControllerEstimate& out = config.simulation.flight_controller_estimate;
    sensors::ComplementaryFilterGains& gains = out.gains;
    for (const auto& [key, value] :
         {std::pair{"accelerometer_weight_per_s", &gains.accelerometer_weight_per_s},
          {"heading_weight_per_s", &gains.heading_weight_per_s},
          {"gyroscope_bias_weight_per_s", &gains.gyroscope_bias_weight_per_s}}) {
      estimate.OptionalInRange(key, value, 0.0, 100.0);
    }
    estimate.Optional("calibrated", &out.calibrated);
    estimate.OptionalInRange("velocity_sigma_mps", &out.velocity_sigma_mps, 0.0, 10.0);
    double heading_sigma_deg = out.heading_sigma_rad * 180.0 / M_PI;
    estimate.OptionalInRange("heading_sigma_deg", &heading_sigma_deg, 0.0, 180.0);
    out.heading_sigma_rad = heading_sigma_deg * M_PI / 180.0;
    for (const auto& [key, value] : {std::pair{"velocity_rate_hz", &out.velocity_rate_hz},
                                     {"heading_rate_hz", &out.heading_rate_hz},
                                     {"imu_integration_rate_hz", &out.imu_integration_rate_hz}}) {
      estimate.Optional(key, value);
      if (!(*value > 0.0 && *value <= 1.0 / config.simulation.step_s)) {
        estimate.Fail(key, "expected a rate in (0, the physics rate] Hz");
      }
    }
    estimate.Finish();
  }

  if (params.Has("actuation")) {
    YamlMap actuation = params.Map("actuation");
    ActuationConfig& out = config.simulation.actuation;
    actuation.Optional("battery_sag", &out.battery_sag);
    actuation.Optional("state_of_charge", &out.state_of_charge);
    if (!(out.state_of_charge >= 0.0 && out.state_of_charge <= 1.0)) {
      actuation.Fail("state_of_charge", "expected the packs' charge at the start, in [0, 1]");
    }
    actuation.Finish();
    out.enabled = true;
    for (const VehicleSpec& vehicle : config.simulation.vehicles) {
      for (const model::SubAircraft& sub : vehicle.vehicle.sub_aircraft) {
        std::string missing;
        if (!(sub.rotors.electric.kv_rpm_per_V > 0.0)) missing = "no rotors.electric";
        if (sub.battery.cells < 1) missing += std::string(missing.empty() ? "" : " and ") + "no battery";
        if (missing.empty()) continue;
        params.Fail("actuation", "needs the motors and the battery of every sub-aircraft, but " + sub.name +
                                     " of vehicle '" + vehicle.name + "' (" + vehicle.vehicle.source_file +
                                     ") has " + missing);
      }
    }
  }

  if (params.Has("uncertainty")) {
    YamlMap uncertainty = params.Map("uncertainty");
    config.uncertainty = ReadUncertainty(uncertainty);
    if (config.uncertainty.wind_W_mps.active() && !config.simulation.air.enabled) {
      params.Fail("uncertainty",
                  "wind_W_mps needs the air modelled: add an `air:` block (with its mean wind)");
    }
  }

  if (params.Has("latches")) {
    const YAML::Node latches = params.Raw("latches");
    if (!latches.IsSequence()) {
      params.Fail("latches", "expected a list of latches ({name, body_a, body_b, ...})");
    }
    YAML::Node resolved_latches;
    for (size_t i = 0; i < latches.size(); ++i) {
      YamlMap latch(latches[i], params.file(), "latches[" + std::to_string(i) + "]");
      config.simulation.latches.push_back(ReadLatch(latch, config.simulation));
      for (size_t j = 0; j < i; ++j) {
        if (config.simulation.latches[j].name == config.simulation.latches[i].name) {
          latch.Fail("name", "'" + config.simulation.latches[i].name + "' is used twice");
        }
      }
      resolved_latches.push_back(latch.Resolved());
    }
    params.SetResolved("latches", resolved_latches);
  }
  return config;
}

PhysicsConfig LoadScenarioPhysics(const std::string& scenario_file,
                                  const std::vector<std::string>& overrides) {
  const bridge::Scenario scenario = bridge::LoadScenario(scenario_file, overrides);
  const bridge::ProcessConfig* clock = scenario.Find(scenario.clock_owner);
  if (!clock || clock->exec != "iapsim_physics") {
    throw bridge::ConfigError(
        scenario_file + ": its clock is not an iapsim_physics process (wanted: the physics of a scenario)");
  }
  bridge::YamlMap params(clock->params, scenario_file, "processes." + clock->name + ".params");
  PhysicsConfig config = ReadPhysicsConfig(params, scenario_file, scenario.clock.step_s);
  config.simulation.seed = scenario.SeedFor(clock->name);
  DrawTrueModel(config.uncertainty, config.simulation.seed, &config.simulation);
  return config;
}

}  // namespace iapsim::physics
