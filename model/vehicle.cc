#include "model/vehicle.h"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <cmath>
#include <filesystem>

#include "bridge/config.h"
#include "model/mesh.h"

namespace iapsim::model {

using bridge::YamlMap;

namespace {

constexpr double kDegToRad = M_PI / 180.0;

// [xx, yy, zz] or [xx, yy, zz, xy, xz, yz]; must be a physical inertia (positive definite, triangle rule)
void OptionalInertia(YamlMap& map, const std::string& key, Eigen::Matrix3d* inertia) {
  if (!map.Has(key)) return;
  const auto v = bridge::ReadNumberList(map, key, {3, 6});
  Eigen::Matrix3d I = Eigen::Vector3d(v[0], v[1], v[2]).asDiagonal();
  if (v.size() == 6) {
    I(0, 1) = I(1, 0) = v[3];
    I(0, 2) = I(2, 0) = v[4];
    I(1, 2) = I(2, 1) = v[5];
  }
  const Eigen::Vector3d principal = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues();
  if (principal.minCoeff() <= 0.0) map.Fail(key, "is not positive definite");
  // any rigid body: each principal moment is at most the sum of the other two
  const double slack = 1e-9 * principal.sum();
  if (principal(0) + principal(1) < principal(2) - slack) {
    map.Fail(key, "violates the triangle inequality of principal moments (no rigid body has it)");
  }
  *inertia = I;
}

void ReadMass(YamlMap& map, MassProperties* mass) {
  map.OptionalInRange("mass_kg", &mass->mass_kg, 0.0, 1e4);
  OptionalInertia(map, "inertia_kgm2", &mass->inertia_B_kgm2);
  OptionalVector3(map, "com_m", &mass->com_B_m);
}

void CheckMass(YamlMap& map, const MassProperties& mass, const std::string& what) {
  if (mass.mass_kg <= 0.0) map.Fail("mass_kg", what + " needs a positive mass");
  if (mass.inertia_B_kgm2.isZero()) map.Fail("inertia_kgm2", what + " needs an inertia");
}

Shape ReadShape(YamlMap& map, BodyMotion motion) {
  Shape shape;
  int kinds = 0;
  if (map.Has("box")) {
    const auto v = bridge::ReadNumberList(map, "box", {3});
    shape.kind = Shape::Kind::kBox;
    shape.box_size_m = Eigen::Vector3d(v[0], v[1], v[2]);
    if (shape.box_size_m.minCoeff() <= 0.0) map.Fail("box", "sizes must be positive");
    ++kinds;
  }
  // cylinders and cones: {radius_m, length_m}
  using Kind = Shape::Kind;
  for (const auto& [key, kind] : {std::pair{"cylinder", Kind::kCylinder}, {"cone", Kind::kCone}}) {
    if (!map.Has(key)) continue;
    YamlMap solid = map.Map(key);
    shape.kind = kind;
    solid.Required("radius_m", &shape.radius_m);
    solid.Required("length_m", &shape.length_m);
    if (shape.radius_m <= 0.0 || shape.length_m <= 0.0) {
      map.Fail(key, "radius_m and length_m must be positive");
    }
    solid.Finish();
    ++kinds;
  }
  if (map.Has("sphere")) {
    YamlMap sphere = map.Map("sphere");
    shape.kind = Shape::Kind::kSphere;
    sphere.Required("radius_m", &shape.radius_m);
    if (shape.radius_m <= 0.0) map.Fail("sphere", "radius_m must be positive");
    sphere.Finish();
    ++kinds;
  }
  if (map.Has("mesh")) {
    YamlMap mesh = map.Map("mesh");
    shape.kind = Shape::Kind::kMesh;
    shape.mesh_file = bridge::ReadFilePath(mesh, "file", map.file());
    if (mesh.Has("scale") && mesh.Raw("scale").IsScalar()) {
      double uniform = 1.0;
      mesh.Optional("scale", &uniform);
      shape.mesh_scale.setConstant(uniform);
    } else {
      OptionalVector3(mesh, "scale", &shape.mesh_scale);
    }
    if (!(shape.mesh_scale.minCoeff() > 0.0)) mesh.Fail("scale", "must be positive (a number or [x, y, z])");
    mesh.Optional("convex", &shape.mesh_convex);
    if (!shape.mesh_convex && motion == BodyMotion::kMoving) {
      mesh.Fail("convex",
                "false (collide with the triangles) needs a static body; a moving one collides as "
                "one convex hull per part of the file: split the mesh into convex parts (OBJ objects)");
    }
    try {  // read now, so a bad mesh is reported with this file and line
      LoadTriangleMesh(shape.mesh_file, shape.mesh_scale);
    } catch (const std::invalid_argument& e) {
      mesh.Fail("file", e.what());
    }
    mesh.Finish();
    ++kinds;
  }
  if (kinds != 1) {
    map.Fail("box",
             "a shape is exactly one of box: [x, y, z], cylinder: {...}, sphere: {...}, cone: {...}, "
             "mesh: {...}");
  }
  OptionalVector3(map, "origin_m", &shape.origin_B_m);
  OptionalVector3(map, "rpy_deg", &shape.rpy_B_rad, kDegToRad);
  map.Finish();
  return shape;
}

// A number in (lo, hi) (NaN fails too), or a clear error; one not required keeps its default when absent.
void ReadInOpenRange(YamlMap& map, const std::string& key, double* value, double lo, double hi,
                     const std::string& unit, bool required = true) {
  if (required) {
    map.Required(key, value);
  } else {
    map.Optional(key, value);
  }
  if (!(*value > lo && *value < hi)) {
    map.Fail(key,
             "must be in (" + YAML::Dump(YAML::Node(lo)) + ", " + YAML::Dump(YAML::Node(hi)) + ") " + unit);
  }
}

// electric: {kv_rpm_per_V, resistance_ohm, no_load_current_A, time_constant_up_s, time_constant_down_s,
//            thrust_model_factor}
void ReadMotorElectrics(YamlMap& map, MotorElectrics* motor) {
  ReadInOpenRange(map, "kv_rpm_per_V", &motor->kv_rpm_per_V, 0.0, 1e5, "rpm/V");
  ReadInOpenRange(map, "resistance_ohm", &motor->resistance_ohm, 0.0, 100.0, "ohm");
  map.Required("no_load_current_A", &motor->no_load_current_A);
  if (!(motor->no_load_current_A >= 0.0 && motor->no_load_current_A < 100.0)) {
    map.Fail("no_load_current_A", "must be in [0, 100) A");
  }
  ReadInOpenRange(map, "time_constant_up_s", &motor->time_constant_up_s, 0.0, 10.0, "s");
  ReadInOpenRange(map, "time_constant_down_s", &motor->time_constant_down_s, 0.0, 10.0, "s");
  if (map.Has("thrust_model_factor")) {
    map.Optional("thrust_model_factor", &motor->thrust_model_factor);
    if (!(motor->thrust_model_factor >= 0.0 && motor->thrust_model_factor <= 1.0)) {
      map.Fail("thrust_model_factor", "must be in [0, 1] (PX4's THR_MDL_FAC); leave it out to fit it");
    }
  }
  map.Finish();
}

// battery: {cells, capacity_mAh, internal_resistance_ohm, polarization_resistance_ohm,
//           polarization_time_constant_s}, resistances per cell
void ReadBattery(YamlMap& map, Battery* battery) {
  map.Required("cells", &battery->cells);
  if (!(battery->cells >= 1 && battery->cells <= 24)) map.Fail("cells", "must be 1 to 24 cells in series");
  double capacity_mAh = 0.0;
  ReadInOpenRange(map, "capacity_mAh", &capacity_mAh, 0.0, 1e6, "mAh");
  battery->capacity_Ah = capacity_mAh / 1000.0;
  ReadInOpenRange(map, "internal_resistance_ohm", &battery->internal_resistance_ohm, 0.0, 10.0,
                  "ohm per cell");
  map.Required("polarization_resistance_ohm", &battery->polarization_resistance_ohm);
  if (!(battery->polarization_resistance_ohm >= 0.0 && battery->polarization_resistance_ohm < 10.0)) {
    map.Fail("polarization_resistance_ohm", "must be in [0, 10) ohm per cell");
  }
  ReadInOpenRange(map, "polarization_time_constant_s", &battery->polarization_time_constant_s, 0.0, 1e5, "s");
  map.Finish();
}

// rotors: {layout: x | plus, arm_m, thrust_coefficient, torque_coefficient, motor_time_constant_s,
//          speed_rad_s: [min, max], radius_m, drag_coefficient, rolling_moment_coefficient, electric}; motor
//          numbering and spin follow PX4's quadrotor geometries
void ReadRotors(YamlMap& map, RotorSet* rotors) {
  std::string layout = "x";
  map.OptionalChoice("layout", &layout, {"x", "plus"});
  double arm_m = 0.0;
  map.Required("arm_m", &arm_m);
  if (!(arm_m > 0.0 && arm_m < 10.0)) map.Fail("arm_m", "must be in (0, 10) m");
  map.Required("thrust_coefficient", &rotors->thrust_coefficient);
  if (!(rotors->thrust_coefficient > 0.0)) map.Fail("thrust_coefficient", "must be positive (N/(rad/s)^2)");
  map.Required("torque_coefficient", &rotors->torque_coefficient);
  if (!(rotors->torque_coefficient >= 0.0)) map.Fail("torque_coefficient", "must be >= 0 (N*m/(rad/s)^2)");
  map.Required("motor_time_constant_s", &rotors->motor_time_constant_s);
  if (!(rotors->motor_time_constant_s > 0.0 && rotors->motor_time_constant_s < 10.0))
    map.Fail("motor_time_constant_s", "must be in (0, 10) s");
  if (!map.Has("speed_rad_s")) map.Fail("speed_rad_s", "is required: [min, max] rotor speed in rad/s");
  const auto speed = bridge::ReadNumberList(map, "speed_rad_s", {2});
  if (!(speed[0] >= 0.0 && speed[1] > speed[0])) map.Fail("speed_rad_s", "expected 0 <= min < max");
  rotors->min_speed_rad_s = speed[0];
  rotors->max_speed_rad_s = speed[1];
  // neighbouring hubs are arm·√2 apart in either layout: larger propellers would overlap
  map.OptionalInRange("radius_m", &rotors->radius_m, 0.0, arm_m / std::sqrt(2.0));
  map.OptionalInRange("drag_coefficient", &rotors->drag_N_per_radps_mps, 0.0, 1.0);
  map.OptionalInRange("rolling_moment_coefficient", &rotors->rolling_moment_Nm_per_radps_mps, 0.0, 1.0);
  if (map.Has("electric")) {
    YamlMap electric = map.Map("electric");
    ReadMotorElectrics(electric, &rotors->electric);
  }
  map.Finish();

  const double a = layout == "x" ? arm_m / std::sqrt(2.0) : arm_m;
  if (layout == "x") {  // front-right, rear-left, front-left, rear-right
    rotors->hub_S_m = {{a, a, 0.0}, {-a, -a, 0.0}, {a, -a, 0.0}, {-a, a, 0.0}};
  } else {  // right, left, front, rear
    rotors->hub_S_m = {{0.0, a, 0.0}, {0.0, -a, 0.0}, {a, 0.0, 0.0}, {-a, 0.0, 0.0}};
  }
  rotors->spin = {+1, +1, -1, -1};
}

void OptionalPerAxis(YamlMap& map, const std::string& key, Eigen::Vector3d* value, double scale = 1.0) {
  OptionalVector3(map, key, value, scale);
  if (value->minCoeff() < 0.0) map.Fail(key, "must be >= 0 on every axis");
}

void ReadFlightController(YamlMap& map, FlightControllerGains* gains) {
  OptionalPerAxis(map, "attitude_p", &gains->attitude_p_per_s);
  OptionalPerAxis(map, "rate_p", &gains->rate_p_per_s);
  OptionalPerAxis(map, "rate_i", &gains->rate_i_per_s2);
  OptionalPerAxis(map, "rate_integral_limit", &gains->rate_integral_limit_rad_s2);
  OptionalPerAxis(map, "max_rate_deg_s", &gains->max_rate_rad_s, kDegToRad);
  map.Optional("battery_scale", &gains->battery_scale);
  OptionalPerAxis(map, "rate_d", &gains->rate_d);
  ReadInOpenRange(map, "gyro_cutoff_hz", &gains->gyro_cutoff_hz, 0.0, 1e4, "Hz", /*required=*/false);
  ReadInOpenRange(map, "dgyro_cutoff_hz", &gains->dgyro_cutoff_hz, 0.0, 1e4, "Hz", /*required=*/false);
  if (map.Has("imu")) {
    YamlMap imu = map.Map("imu");
    FlightControllerImu& out = gains->imu;
    for (const auto& [key, value] : {std::pair{"gyroscope_noise_density", &out.gyroscope_noise_density},
                                     {"gyroscope_random_walk", &out.gyroscope_random_walk},
                                     {"gyroscope_bias_sigma_radps", &out.gyroscope_bias_sigma_radps},
                                     {"accelerometer_noise_density", &out.accelerometer_noise_density},
                                     {"accelerometer_random_walk", &out.accelerometer_random_walk},
                                     {"accelerometer_bias_sigma_mps2", &out.accelerometer_bias_sigma_mps2}}) {
      imu.Optional(key, value);
      if (!(*value >= 0.0 && *value < 100.0)) imu.Fail(key, "must be in [0, 100)");
    }
    imu.Finish();
  }
  map.Finish();
}

// drag_area_m2: [x, y, z], C_d·A per body axis, none negative
void OptionalDragArea(YamlMap& map, Eigen::Vector3d* area_m2) {
  if (!map.Has("drag_area_m2")) return;
  OptionalVector3(map, "drag_area_m2", area_m2);
  if (!(area_m2->minCoeff() >= 0.0)) map.Fail("drag_area_m2", "expected C_d·A per body axis, each >= 0 m^2");
}

// Fills `sub` from `map`, keeping what is already there (the defaults) for keys the map leaves out.
void ReadSubAircraft(YamlMap& map, SubAircraft* sub) {
  ReadMass(map, &sub->mass);
  std::string joint = sub->joint == JointType::kFixed ? "fixed" : "spherical";
  map.OptionalChoice("joint", &joint, {"spherical", "fixed"});
  sub->joint = joint == "fixed" ? JointType::kFixed : JointType::kSpherical;
  if (map.Has("joint_friction")) {
    YamlMap friction = map.Map("joint_friction");
    friction.OptionalInRange("viscous_Nms_per_rad", &sub->joint_resistance.viscous_Nms_per_rad, 0.0, 100.0);
    friction.OptionalInRange("coulomb_Nm", &sub->joint_resistance.coulomb_Nm, 0.0, 100.0);
    friction.Finish();
  }
  if (map.Has("joint_max_tilt_deg")) {
    double tilt_deg = 0.0;
    map.Optional("joint_max_tilt_deg", &tilt_deg);
    if (!(tilt_deg > 0.0 && tilt_deg < 180.0)) {
      map.Fail("joint_max_tilt_deg",
               "expected the largest tilt of the sub-aircraft's z axis, in (0, 180) deg");
    }
    sub->joint_resistance.max_tilt_rad = tilt_deg * kDegToRad;
  }
  OptionalShapes(map, "collision", &sub->collision);
  map.Optional("mesh", &sub->mesh);
  OptionalDragArea(map, &sub->drag_area_B_m2);
  if (map.Has("rotors")) {
    YamlMap rotors = map.Map("rotors");
    ReadRotors(rotors, &sub->rotors);
  }
  if (map.Has("flight_controller")) {
    YamlMap gains = map.Map("flight_controller");
    ReadFlightController(gains, &sub->flight_controller);
  }
  if (map.Has("battery")) {
    YamlMap battery = map.Map("battery");
    ReadBattery(battery, &sub->battery);
  }
}

}  // namespace

void OptionalVector3(YamlMap& map, const std::string& key, Eigen::Vector3d* value, double scale) {
  if (!map.Has(key)) {
    map.Raw(key);  // a known key though absent: Finish() can suggest it for a misspelling
    const Eigen::Vector3d in_file_unit = *value / scale;
    map.SetResolved(key,
                    YAML::Node(std::vector<double>{in_file_unit.x(), in_file_unit.y(), in_file_unit.z()}));
    return;
  }
  const auto v = bridge::ReadNumberList(map, key, {3});
  *value = Eigen::Vector3d(v[0], v[1], v[2]) * scale;
}

void OptionalShapes(YamlMap& map, const std::string& key, std::vector<Shape>* shapes, BodyMotion motion) {
  if (!map.Has(key)) return;
  const YAML::Node node = map.Raw(key);
  if (!node.IsSequence()) map.Fail(key, "expected a list of shapes");
  shapes->clear();
  YAML::Node resolved;  // as read: mesh files absolute, so a resolved scenario finds them from anywhere
  for (size_t i = 0; i < node.size(); ++i) {
    YamlMap shape(node[i], map.file(), map.PathOf(key) + "[" + std::to_string(i) + "]");
    shapes->push_back(ReadShape(shape, motion));
    resolved.push_back(shape.Resolved());
  }
  map.SetResolved(key, resolved);
}

double Vehicle::TotalMass_kg() const {
  double m = platform.mass_kg;
  for (const auto& t : tools) m += t.mass.mass_kg;
  for (const auto& s : sub_aircraft) m += s.mass.mass_kg;
  return m;
}

Eigen::Matrix3d RotationFromRpy(const Eigen::Vector3d& rpy_rad) {
  return (Eigen::AngleAxisd(rpy_rad.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy_rad.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy_rad.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d Vehicle::CenterOfMass_P_m() const {
  Eigen::Vector3d moment = platform.mass_kg * platform.com_B_m;
  for (const auto& t : tools)
    moment += t.mass.mass_kg * (t.origin_P_m + RotationFromRpy(t.rpy_P_rad) * t.mass.com_B_m);
  for (const auto& s : sub_aircraft) {
    moment += s.mass.mass_kg *
              (s.joint_P_m + Eigen::AngleAxisd(s.initial_yaw_rad, Eigen::Vector3d::UnitZ()) * s.mass.com_B_m);
  }
  return moment / TotalMass_kg();
}

namespace {

// Inertia about a point `r` away from the CoM (parallel-axis theorem), same axes.
Eigen::Matrix3d ShiftInertia(const Eigen::Matrix3d& inertia_com, double mass_kg, const Eigen::Vector3d& r) {
  return inertia_com + mass_kg * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
}

}  // namespace

Eigen::Matrix3d Vehicle::LumpedInertia_P_kgm2() const {
  Eigen::Matrix3d J = ShiftInertia(platform.inertia_B_kgm2, platform.mass_kg, platform.com_B_m);
  for (const auto& t : tools) {
    const Eigen::Matrix3d R_PT = RotationFromRpy(t.rpy_P_rad);
    J += ShiftInertia(R_PT * t.mass.inertia_B_kgm2 * R_PT.transpose(), t.mass.mass_kg,
                      t.origin_P_m + R_PT * t.mass.com_B_m);
  }
  for (const auto& s : sub_aircraft) {
    const Eigen::Matrix3d R_PS =
        Eigen::AngleAxisd(s.initial_yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Matrix3d own = s.joint == JointType::kFixed
                                    ? Eigen::Matrix3d(R_PS * s.mass.inertia_B_kgm2 * R_PS.transpose())
                                    : Eigen::Matrix3d::Zero();
    J += ShiftInertia(own, s.mass.mass_kg, s.joint_P_m + R_PS * s.mass.com_B_m);
  }
  return J;
}

Eigen::VectorXd Vehicle::LevelHoverThrusts_N(double gravity_mps2) const {
  const Eigen::Vector3d d_0 = CenterOfMass_P_m();
  Eigen::MatrixXd A(3, sub_aircraft.size());
  for (size_t i = 0; i < sub_aircraft.size(); ++i) {
    const Eigen::Vector3d r = sub_aircraft[i].joint_P_m - d_0;
    A.col(i) << 1.0, r.x(), r.y();
  }
  return A.completeOrthogonalDecomposition().solve(Eigen::Vector3d(TotalMass_kg() * gravity_mps2, 0.0, 0.0));
}

Vehicle LoadVehicle(const std::string& path) {
  const YAML::Node root = bridge::LoadYamlFile(path);
  Vehicle vehicle;
  vehicle.source_file = path;
  YamlMap top(root, path);
  top.Required("name", &vehicle.name);
  std::string source;
  top.Optional("source", &source);  // free text: where the numbers come from

  YamlMap platform = top.Map("platform");
  ReadMass(platform, &vehicle.platform);
  CheckMass(platform, vehicle.platform, "the platform");
  OptionalShapes(platform, "collision", &vehicle.platform_collision);
  platform.Optional("mesh", &vehicle.platform_mesh);
  OptionalDragArea(platform, &vehicle.platform_drag_area_B_m2);
  platform.Finish();

  if (top.Has("tools")) {
    const YAML::Node tools = top.Raw("tools");
    if (!tools.IsSequence()) top.Fail("tools", "expected a list of tools");
    for (size_t i = 0; i < tools.size(); ++i) {
      YamlMap map(tools[i], path, "tools[" + std::to_string(i) + "]");
      Tool tool;
      map.Required("name", &tool.name);
      ReadMass(map, &tool.mass);
      CheckMass(map, tool.mass, "tool '" + tool.name + "'");
      OptionalVector3(map, "origin_m", &tool.origin_P_m);
      OptionalVector3(map, "rpy_deg", &tool.rpy_P_rad, kDegToRad);
      OptionalShapes(map, "collision", &tool.collision);
      map.Optional("mesh", &tool.mesh);
      map.Finish();
      vehicle.tools.push_back(tool);
    }
  }

  SubAircraft defaults;
  YamlMap defaults_map = top.Map("sub_aircraft_defaults");
  if (defaults_map.Has("base")) {  // a parts file, relative to this file; this map overrides its keys
    std::string base;
    defaults_map.Required("base", &base);
    const std::string base_path =
        base.empty() || base[0] == '/' ? base : (std::filesystem::path(path).parent_path() / base).string();
    YamlMap base_map(bridge::LoadYamlFile(base_path), base_path);
    ReadSubAircraft(base_map, &defaults);
    base_map.Finish();
  }
  ReadSubAircraft(defaults_map, &defaults);
  defaults_map.Finish();

  const YAML::Node subs = top.Raw("sub_aircraft");
  if (!subs || !subs.IsSequence() || subs.size() < 1) {
    top.Fail("sub_aircraft", "expected a list of sub-aircraft (two or more, or one on a fixed joint)");
  }
  for (size_t i = 0; i < subs.size(); ++i) {
    YamlMap map(subs[i], path, "sub_aircraft[" + std::to_string(i) + "]");
    SubAircraft sub = defaults;
    sub.name = "sub" + std::to_string(i + 1);
    map.Optional("name", &sub.name);
    ReadSubAircraft(map, &sub);
    CheckMass(map, sub.mass, "sub-aircraft '" + sub.name + "'");
    if (sub.rotors.hub_S_m.empty()) {
      map.Fail("rotors", "is required (here or in sub_aircraft_defaults): the sub-aircraft's rotor model");
    }
    if (!map.Has("joint_m")) map.Fail("joint_m", "is required: the joint position d_i in the platform frame");
    OptionalVector3(map, "joint_m", &sub.joint_P_m);
    double yaw_deg = 0.0;
    map.OptionalInRange("yaw_deg", &yaw_deg, -360.0, 360.0);
    sub.initial_yaw_rad = yaw_deg * kDegToRad;
    map.Finish();
    for (const auto& other : vehicle.sub_aircraft) {
      if (other.name == sub.name) map.Fail("name", "'" + sub.name + "' is used twice");
    }
    // alone on a spherical joint it could not turn the platform: a free quadrotor carries it rigidly
    if (subs.size() == 1 && sub.joint != JointType::kFixed) {
      map.Fail("joint", "a single sub-aircraft must be on a fixed joint (a quadrotor carrying the platform)");
    }
    vehicle.sub_aircraft.push_back(sub);
  }
  top.Finish();
  return vehicle;
}

}  // namespace iapsim::model
