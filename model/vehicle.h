#pragma once
// Vehicle description: a central platform P carrying n sub-aircraft S1..Sn on spherical (or fixed) joints,
// seed paper §III. One sub-aircraft on a fixed joint is a free quadrotor whose "platform" is its payload
// (the docking-part carrier of seed §IV-E). Loaded from configs/vehicles/*.yaml; frames are FRD bodies in a
// NED world.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "bridge/config.h"

namespace iapsim::model {

/// A collision (and default visual) shape, placed in its body's frame. Cylinders and cones lie along the
/// shape's own z axis, centred on half their length; a cone's apex points along +z, its base circle at −z.
/// A mesh keeps the file's own origin and axes (model/mesh.h).
struct Shape {
  enum class Kind { kBox, kCylinder, kSphere, kCone, kMesh };
  Kind kind = Kind::kBox;
  Eigen::Vector3d box_size_m = Eigen::Vector3d::Zero();  // kBox: full extents along x, y, z
  double radius_m = 0.0;                                 // kCylinder, kSphere; kCone: of the base
  double length_m = 0.0;                                 // kCylinder, kCone: along the shape's z axis
  std::string mesh_file;                                 // kMesh: a file assimp reads
  Eigen::Vector3d mesh_scale = Eigen::Vector3d::Ones();  // kMesh: per axis of the file, to metres
  // kMesh: true collides as one convex hull per part of the file; false with its triangles (static bodies)
  bool mesh_convex = true;
  Eigen::Vector3d origin_B_m = Eigen::Vector3d::Zero();  // shape centre in the body frame
  Eigen::Vector3d rpy_B_rad = Eigen::Vector3d::Zero();   // shape orientation (roll, pitch, yaw)
};

/// Rigid-body mass properties. Inertia is about the centre of mass, in body axes.
struct MassProperties {
  double mass_kg = 0.0;
  Eigen::Vector3d com_B_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia_B_kgm2 = Eigen::Matrix3d::Zero();
};

/// A body fixed to the platform (a pole, a docking part): part of the platform's rigid body.
struct Tool {
  std::string name;
  MassProperties mass;                                   // in the tool's own frame
  Eigen::Vector3d origin_P_m = Eigen::Vector3d::Zero();  // tool frame in P
  Eigen::Vector3d rpy_P_rad = Eigen::Vector3d::Zero();
  std::vector<Shape> collision;
  std::string mesh;
};

enum class JointType { kSpherical, kFixed };

/// What a spherical joint resists (all zero: an ideal, frictionless ball joint with no limit, as the seed).
/// Friction torques oppose the child's angular velocity relative to the parent: viscous c·ω and Coulomb
/// τ_c·ω/|ω| (the MuJoCo `damping` and `frictionloss` of a ball joint, the latter isotropic here). The cone
/// limit bounds the tilt of the child's z axis from its direction at the zero joint position; twist is free.
struct JointResistance {
  double viscous_Nms_per_rad = 0.0;
  double coulomb_Nm = 0.0;
  double max_tilt_rad = 0.0;  // 0: no limit
};

/// The brushless motor and ESC behind each rotor, as a DC motor the ESC drives at a fraction (the throttle)
/// of the battery voltage (physics/drive.h).
struct MotorElectrics {
  double kv_rpm_per_V = 0.0;          // speed constant; 0: no electric model
  double resistance_ohm = 0.0;        // winding, ESC and wiring
  double no_load_current_A = 0.0;     // friction and iron losses, as a constant current
  double time_constant_up_s = 0.0;    // speed response to a higher throttle ...
  double time_constant_down_s = 0.0;  // ... and to a lower one: an ESC without active braking is slower
  // PX4's THR_MDL_FAC, the flight controller's thrust curve; < 0: fitted on a simulated thrust stand
  double thrust_model_factor = -1.0;
};

/// A lithium-polymer battery pack: cells in series, each an open-circuit voltage over state of charge behind
/// an ohmic resistance and one polarisation RC pair (the Thevenin model; physics/drive.h).
struct Battery {
  int cells = 0;  // 0: no battery model
  double capacity_Ah = 0.0;
  double internal_resistance_ohm = 0.0;      // per cell
  double polarization_resistance_ohm = 0.0;  // per cell
  double polarization_time_constant_s = 0.0;
};

/// The rotors of one sub-aircraft: thrust k_f·ω² along −z_S at each hub, drag torque k_m·ω² about z_S,
/// first-order motor speed dynamics with saturation.
struct RotorSet {
  std::vector<Eigen::Vector3d> hub_S_m;  // rotor hubs in S (FRD), relative to the joint
  // +1: the rotor spins counter-clockwise seen from above, so its drag yaws S to the right (about +z_S)
  std::vector<int> spin;
  double thrust_coefficient = 0.0;  // k_f, N/(rad/s)^2
  double torque_coefficient = 0.0;  // k_m, N·m/(rad/s)^2
  double motor_time_constant_s = 0.0;
  double min_speed_rad_s = 0.0;
  double max_speed_rad_s = 0.0;
  // aerodynamics, used when a scenario models the air (physics/rotor.h); 0: not modelled
  double radius_m = 0.0;  // propeller radius, for ground effect
  // rotor drag and rolling moment per unit rotor speed and in-plane airspeed
  double drag_N_per_radps_mps = 0.0;
  double rolling_moment_Nm_per_radps_mps = 0.0;

  // the motors and ESCs, used when a scenario models the actuation (physics/drive.h); kv 0: not modelled
  MotorElectrics electric;

  double MaxThrust_N() const { return thrust_coefficient * max_speed_rad_s * max_speed_rad_s; }
  double MinThrust_N() const { return thrust_coefficient * min_speed_rad_s * min_speed_rad_s; }
};

/// The flight controller's own IMU, as continuous-time densities (Kalibr's convention, sensors/imu.h). The
/// defaults are PX4 Gazebo's and RotorS' IMU plugin's (an ADIS16448).
struct FlightControllerImu {
  double gyroscope_noise_density = 3.394e-4;    // rad/s/√Hz
  double gyroscope_random_walk = 3.8785e-5;     // rad/s²/√Hz
  double gyroscope_bias_sigma_radps = 0.0087;   // turn-on bias, per axis
  double accelerometer_noise_density = 4.0e-3;  // m/s²/√Hz
  double accelerometer_random_walk = 6.0e-3;    // m/s³/√Hz
  double accelerometer_bias_sigma_mps2 = 0.196;
};

/// Gains of the simulated flight controller (PX4-style cascade: attitude P -> body-rate PI -> mixer).
/// Per axis (roll, pitch, yaw) of the sub-aircraft body frame.
struct FlightControllerGains {
  Eigen::Vector3d attitude_p_per_s{6.5, 6.5, 2.8};            // rate setpoint per attitude error (PX4 MC_*_P)
  Eigen::Vector3d rate_p_per_s{20.0, 20.0, 10.0};             // angular acceleration per rate error
  Eigen::Vector3d rate_i_per_s2{10.0, 10.0, 5.0};             // ... per integrated rate error
  Eigen::Vector3d rate_integral_limit_rad_s2{5.0, 5.0, 2.0};  // bound of the integral's contribution
  Eigen::Vector3d max_rate_rad_s{3.84, 3.84, 3.49};           // PX4 MC_*RATE_MAX: 220, 220, 200 deg/s
  bool battery_scale = false;  // PX4 MC_BAT_SCALE_EN: thrust scaled up as the pack sags (physics/drive.h)
  // where the flight controller runs on its own IMU (a scenario's flight_controller_sensing): the rate loop's
  // D term on the measured angular acceleration, and PX4's low-pass filters of the gyroscope and of its
  // derivative (IMU_GYRO_CUTOFF, IMU_DGYRO_CUTOFF)
  Eigen::Vector3d rate_d{0.0, 0.0, 0.0};  // angular acceleration per measured angular acceleration
  double gyro_cutoff_hz = 40.0;
  double dgyro_cutoff_hz = 30.0;
  FlightControllerImu imu;
};

struct SubAircraft {
  std::string name;
  MassProperties mass;  // CoM at the joint (seed §III-A) unless com_B_m says
  JointType joint = JointType::kSpherical;
  JointResistance joint_resistance;                     // spherical joints only
  Eigen::Vector3d joint_P_m = Eigen::Vector3d::Zero();  // d_i: joint (= CoM) position in P
  double initial_yaw_rad = 0.0;                         // initial yaw of S_i relative to P
  RotorSet rotors;
  FlightControllerGains flight_controller;
  Battery battery;  // what drives the motors when a scenario models the actuation
  std::vector<Shape> collision;
  std::string mesh;
  Eigen::Vector3d drag_area_B_m2 = Eigen::Vector3d::Zero();  // C_d·A per body axis (physics/wind.h); 0: none
};

struct Vehicle {
  std::string name;
  std::string source_file;
  MassProperties platform;  // com_B_m is d_c
  std::vector<Shape> platform_collision;
  std::string platform_mesh;
  Eigen::Vector3d platform_drag_area_B_m2 = Eigen::Vector3d::Zero();  // C_d·A per P axis, tools included
  std::vector<Tool> tools;
  std::vector<SubAircraft> sub_aircraft;

  /// m: total mass of platform, tools and sub-aircraft.
  double TotalMass_kg() const;
  /// d_0: the whole IAP's centre of mass in P, with every joint at its initial position (seed §III-B).
  Eigen::Vector3d CenterOfMass_P_m() const;
  /// J of the seed's equation (3), about P's origin, in P: the platform and tools as rigid bodies, each
  /// sub-aircraft as a point mass at its joint (its own rotation is free on a spherical joint) or, on a
  /// fixed joint, as a rigid body. Joints at their initial positions.
  Eigen::Matrix3d LumpedInertia_P_kgm2() const;
  /// Level-hover trim: the vertical thrust of each sub-aircraft that carries the weight with no moment
  /// about the centre of mass, of least norm (equal shares for a symmetric IAP).
  Eigen::VectorXd LevelHoverThrusts_N(double gravity_mps2) const;
};

/// YAML readers shared by the configuration files that place shapes and frames (vehicles, worlds).
/// `value` keeps its default when the key is absent (and is recorded as resolved); `scale` converts units
/// (degrees to radians).
void OptionalVector3(bridge::YamlMap& map, const std::string& key, Eigen::Vector3d* value,
                     double scale = 1.0);
/// Whether the body that carries shapes moves. Bullet collides a mesh's triangles (not its convex hull) with
/// other bodies reliably only when the mesh does not move (model/mesh.h, physics/multibody_world.h).
enum class BodyMotion { kMoving, kStatic };
/// A list of shapes: each {box: [x, y, z]} | {cylinder: {radius_m, length_m}} | {sphere: {radius_m}} |
/// {cone: {radius_m, length_m}} | {mesh: {file, scale: s or [x, y, z], convex: true}}, with optional
/// origin_m and rpy_deg. A mesh file is relative to the YAML file that names it, else to the working
/// folder; it is read here, so a bad one fails with this file and line. `convex: false` needs kStatic.
void OptionalShapes(bridge::YamlMap& map, const std::string& key, std::vector<Shape>* shapes,
                    BodyMotion motion = BodyMotion::kMoving);

/// URDF's roll-pitch-yaw convention: R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Matrix3d RotationFromRpy(const Eigen::Vector3d& rpy_rad);

/// Loads and validates a vehicle YAML file. Throws bridge::ConfigError (file:line: key: what).
Vehicle LoadVehicle(const std::string& path);

}  // namespace iapsim::model
