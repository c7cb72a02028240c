#pragma once
// IAPs in a world: each vehicle is a multibody (platform + sub-aircraft on spherical or fixed joints) whose
// sub-aircraft carry rotors driven by simulated flight controllers. In-process and bus-free: the physics
// process, the benchmarks, the tests and (later) RL environments all drive this class.
//
// Sub-aircraft torques (rotor moments and drag) act on the sub-aircraft body, reacting on the air, as in the
// seed's equations (3) and (7): the platform feels thrust only, through the joint. `torque_reaction:
// platform` instead applies them as joint torques with the reaction on the platform (the seed's Fig. 9).
//
// Docking latches (seed §IV-E, Fig. 6): two bodies, say a cone on one quadrotor and a cylinder on another,
// each carry a port. After every step the errors between the ports are measured; an automatic latch closes
// when they are within tolerance and the ports move slowly enough relative to each other, and from then on
// the two bodies are one rigid body until the latch is opened.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "bridge/link_delay.h"
#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/drive.h"
#include "physics/flight_controller.h"
#include "physics/multibody_world.h"
#include "physics/rotor.h"
#include "physics/wind.h"
#include "sensors/attitude_filter.h"

namespace iapsim::sensors {
class ImuModel;
}

namespace iapsim::physics {

enum class TorqueReaction { kAir, kPlatform };
/// Initial rotor speeds: hover carries the weight with no moment (level trim); idle is the minimum.
enum class InitialRotors { kHover, kIdle };

/// The link from the IAP computer to each sub-aircraft's flight controller (a serial or radio link on the
/// real vehicle): a setpoint takes effect `delay_s` after it was set, plus a jitter drawn uniformly from [0,
/// jitter_s] per setpoint, both rounded to whole physics steps so that runs stay deterministic, and setpoints
/// never overtake each other (bridge/link_delay.h). Zero (the default) applies a setpoint in the step it was
/// set for.
struct CommandLink {
  double delay_s = 0.0;
  double jitter_s = 0.0;
};

struct VehicleSpec {
  std::string name;
  model::Vehicle vehicle;                   // rotors and flight controllers
  model::MultibodyDescription description;  // the rigid bodies (from the vehicle's URDF)
  // the vehicle as its flight controllers know it, where the physics flies another (a model mismatch drawn
  // by physics/uncertainty.h): their inertia feed-forward, mixer, thrust-to-speed inversion and thrust curve
  // use it. Unset: `vehicle`.
  std::optional<model::Vehicle> flight_controller_model;
  Eigen::Vector3d p_WP_m = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
  // the start's attitude R_WP = Rz(yaw) Ry(pitch) Rx(roll) and the platform frame's velocity and angular
  // velocity (in W): the vehicle starts moving as one rigid body, every joint at rest (RL resets, eq. (23))
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  Eigen::Vector3d v_WP_W_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_WP_W_radps = Eigen::Vector3d::Zero();
  InitialRotors initial_rotors = InitialRotors::kHover;
  TorqueReaction torque_reaction = TorqueReaction::kAir;
  CommandLink command_link;
};

/// A docking port: a point Q of a body and the axis along which the mating part arrives, pointing out of
/// this part toward it, both in the body's frame B.
struct DockingPort {
  Eigen::Vector3d p_BQ_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_B = Eigen::Vector3d::UnitX();  // unit
};

struct LatchSpec {
  std::string name;
  std::string body_a;  // a body of the world: "<vehicle>/<link>" or an object's name
  std::string body_b;
  DockingPort port_a;
  DockingPort port_b;
  double axial_tolerance_m = 0.005;   // of |d_y|
  double radial_tolerance_m = 0.005;  // of d_xz
  // between axis a and −axis b: the ports face each other
  double angular_tolerance_rad = 10.0 * M_PI / 180.0;
  double max_relative_speed_mps = 0.5;  // of port b relative to port a, to close
  bool auto_close = true;               // close by itself when it can (else only on request)
};

/// The air (physics/wind.h, physics/rotor.h), modelled when `enabled` (a scenario's `air:`); without it the
/// air is still and nothing aerodynamic acts, as in the paper's simulator. The wind is a mean wind plus,
/// optionally, Dryden turbulence at the vehicle's height and discrete gusts; each effect on the vehicles can
/// be switched off on its own and needs its coefficients in the vehicle file.
struct AirConfig {
  bool enabled = false;
  double density_kgpm3 = 1.225;                          // ISA sea level
  Eigen::Vector3d wind_W_mps = Eigen::Vector3d::Zero();  // the mean wind's velocity, NED
  bool turbulence = false;
  double w20_mps = 7.72;  // turbulence: the wind at 20 ft; MIL-F-8785C light 15 kt, moderate 30, severe 45
  std::vector<DiscreteGust> gusts;
  bool body_drag = true;      // quadratic drag of every part with a drag_area_m2
  bool rotor_drag = true;     // rotor drag and rolling moment of rotors with their coefficients
  bool ground_effect = true;  // Cheeseman–Bennett, over the ground plane and static objects; needs radius_m
  // each rotor's wake pushes the movable bodies below it but its own sub-aircraft (physics/rotor.h's
  // WakeMomentumFlux_N); needs radius_m
  bool downwash = true;
  // C_D of what a wake hits: a disc across the flow, 1.17 (Hoerner, Fluid-Dynamic Drag, 1965); at most 2,
  // where the blocked flux leaves sideways
  double downwash_drag_coefficient = 1.17;
};

/// The sub-aircraft's electric drives (physics/drive.h: PX4's thrust curve, ESC, DC motors with their own
/// spin-up and spin-down, a sagging battery), modelled when `enabled` (a scenario's `actuation:`). Without it
/// each flight controller sets its rotors' speeds through the rotor set's first-order motors, as in the
/// paper's simulator. Every sub-aircraft then needs `rotors.electric` and `battery` in its vehicle file.
struct ActuationConfig {
  bool enabled = false;
  bool battery_sag = true;       // false: the motors run on a charged pack's voltage throughout
  double state_of_charge = 1.0;  // of every pack at the start
};

/// What each flight controller measures its rotation with: the truth (the paper's simulator), its own
/// gyroscope (the vehicle file's flight_controller.imu noise, seeded per sub-aircraft) through PX4's
/// low-pass filters, with the rate loop's D term on the filtered angular acceleration (GyroFilter in
/// physics/flight_controller.h), the attitude still the truth; or, `kEstimate`, that gyroscope and an
/// attitude estimated from its IMU (FlightControllerEstimate).
enum class FlightControllerSensing { kTruth, kGyro, kEstimate };

/// How a flight controller estimates its attitude where FlightControllerSensing::kEstimate: PX4's
/// complementary filter (sensors/attitude_filter.h) on its IMU, aided by its own velocity (a VIO or GNSS
/// velocity of the sub-aircraft, as the seed's VIRPO gives each one, §IV-D) and heading (a magnetometer's,
/// sensors/heading_sensor.h's defaults), each the truth plus white noise at its rate. Before the first step
/// the filter aligns as PX4 does on the ground: roll and pitch from the accelerometer's mean reading (its
/// bias included), yaw from a second of headings. `calibrated`: the IMU's turn-on biases are removed before
/// flight, as PX4's calibrations do (the gyroscope's at rest, the accelerometer's six-orientation and
/// level-horizon calibration), leaving its noise and its in-run random walk; their residuals are left out.
/// Uncalibrated, the vehicle file's turn-on biases stay (PX4 Gazebo's 0.196 m/s² accelerometer bias tilts the
/// estimate by b/g, 1.1° per axis one sigma; the filter learns the gyroscope's in ~10 s).
struct FlightControllerEstimate {
  sensors::ComplementaryFilterGains gains;
  bool calibrated = true;
  double velocity_rate_hz = 50.0;
  double velocity_sigma_mps = 0.02;  // per axis; the realistic profile's odometry velocity noise
  double heading_rate_hz = 10.0;
  double heading_sigma_rad = 2.0 * M_PI / 180.0;
  // PX4's IMU_INTEG_RATE (src/modules/sensors/vehicle_imu/imu_parameters.c, default 200 Hz): the filter
  // updates on the IMU's means over each such interval; between updates its attitude is turned by each
  // gyroscope sample (ComplementaryAttitudeFilter::Propagate), so the attitude loop flies at every step on
  // a current attitude (PX4 runs its attitude loop at this rate on the attitude it publishes; not modelled)
  double imu_integration_rate_hz = 200.0;
};

struct SimulationConfig {
  double step_s = 0.001;
  AirConfig air;
  ActuationConfig actuation;
  FlightControllerSensing flight_controller_sensing = FlightControllerSensing::kTruth;
  FlightControllerEstimate flight_controller_estimate;
  uint64_t seed = 0;  // the simulation's random streams (the command links' jitter)
  WorldConfig world;
  std::vector<VehicleSpec> vehicles;
  std::vector<LatchSpec> latches;
};

/// What one sub-aircraft did in the last step.
struct SubAircraftOutput {
  Eigen::Vector3d thrust_W_N = Eigen::Vector3d::Zero();   // Λ_i: force of its rotors, in W
  Eigen::Vector3d torque_S_Nm = Eigen::Vector3d::Zero();  // τ_i about its CoM, in S
  RotorVector rotor_speeds_rad_s;
  // the attitude its flight controller flew on: the truth, or its estimate (FlightControllerSensing)
  Eigen::Quaterniond q_WS_flight_controller = Eigen::Quaterniond::Identity();
  bool saturated = false;
  // force of the sub-aircraft on the platform through its joint, in P (Newton's law on the sub-aircraft)
  Eigen::Vector3d joint_force_P_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d contact_force_W_N = Eigen::Vector3d::Zero();  // from contacts with anything else
  Eigen::Vector3d air_force_W_N = Eigen::Vector3d::Zero();      // body and rotor drag and downwash on it
  RotorVector thrust_ratio;  // per rotor: thrust over its thrust out of ground effect (1 without the air)
  // the electric drive's (all zero without the actuation model)
  RotorVector throttle;            // per rotor, in [0, 1]
  double battery_voltage_V = 0.0;  // at the ESCs
  double battery_current_A = 0.0;  // drawn by the four ESCs
  double state_of_charge = 0.0;    // of the pack, in [0, 1]
};

struct VehicleOutput {
  int platform_body = 0;                 // body id in the world
  std::vector<int> sub_aircraft_bodies;  // in the vehicle's order
  std::vector<SubAircraftOutput> sub_aircraft;
  // resultant of every contact between the vehicle and anything else, moment about P's origin (the point
  // of equations (4), (10) and (19)-(21); a tool moves the platform body's CoM off it)
  Eigen::Vector3d external_force_W_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d external_torque_W_Nm = Eigen::Vector3d::Zero();
  Eigen::Vector3d external_force_P_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d external_torque_P_Nm = Eigen::Vector3d::Zero();
  Eigen::Vector3d wind_W_mps = Eigen::Vector3d::Zero();  // at the platform in the last step, gusts included
  Eigen::Vector3d air_force_W_N = Eigen::Vector3d::Zero();  // body and rotor drag, downwash on all its parts
  uint64_t invalid_commands = 0;  // rejected setpoints (NaN, infinite, non-unit quaternion)
  // setpoints asking for more collective thrust than the rotors give, or less than none: clamped to that
  // range, as a flight controller's normalised thrust is to [0, 1]
  uint64_t clamped_thrust_commands = 0;
  uint64_t saturated_steps = 0;  // sub-aircraft steps where a mixer cut
  struct {
    uint64_t roll_pitch = 0, thrust = 0, yaw = 0;
  } mixer_cut_steps;  // the same per axis (Rotors::Mix's order: yaw is cut first, roll/pitch last)
};

/// A latch after the last step. The errors are those of port b relative to port a, in a's port axes.
struct LatchOutput {
  int body_a = 0;  // body ids in the world
  int body_b = 0;
  double axial_error_m = 0.0;       // d_y: (p_WQb − p_WQa)·axis_a; > 0: b's port short of a's
  double radial_error_m = 0.0;      // d_xz: the distance of port b from a's port axis
  double angular_error_rad = 0.0;   // between axis a and −axis b
  double relative_speed_mps = 0.0;  // |v_WQb − v_WQa|
  bool can_close = false;           // every error within tolerance and slow enough
  bool latched = false;
  // an automatic latch that was opened waits until its ports have left tolerance before closing again
  bool armed = true;
  uint64_t closes = 0;
  uint64_t opens = 0;
};

class Simulation {
 public:
  /// Throws std::invalid_argument naming the vehicle or latch for anything the world cannot build. An
  /// automatic latch whose ports start within tolerance starts closed.
  explicit Simulation(const SimulationConfig& config);
  ~Simulation();

  int vehicle_count() const { return static_cast<int>(vehicles_.size()); }
  const VehicleSpec& vehicle(int v) const { return vehicles_[v]->spec; }

  /// Holds this setpoint for sub-aircraft s of vehicle v until the next one, from the next Step (or, through
  /// the vehicle's CommandLink, that many steps later). An invalid setpoint is rejected (counted, the last
  /// valid one held) and false returned.
  bool SetCommand(int v, int s, const SubAircraftSetpoint& setpoint);

  void Step();

  int64_t step_count() const { return world_.step_count(); }
  double time_s() const { return static_cast<double>(world_.step_count()) * world_.step_s(); }
  const MultibodyWorld& world() const { return world_; }
  /// For tests and disturbances: loads added here act in the next step.
  MultibodyWorld& mutable_world() { return world_; }
  const VehicleOutput& output(int v) const { return vehicles_[v]->output; }

  int latch_count() const { return static_cast<int>(latches_.size()); }
  const LatchSpec& latch(int l) const { return latches_[l].spec; }
  const LatchOutput& latch_output(int l) const { return latches_[l].output; }
  /// The latch called `name`, or -1.
  int FindLatch(const std::string& name) const;
  /// Closes latch l now if it can (see LatchOutput::can_close); returns whether it is closed.
  bool CloseLatch(int l);
  /// Opens latch l now; an automatic latch is disarmed until its ports have left tolerance.
  void OpenLatch(int l);

 private:
  struct SubAircraftSim {
    std::unique_ptr<Rotors> rotors;
    // the rotors as the flight controller knows them, where they differ
    // (VehicleSpec::flight_controller_model)
    std::unique_ptr<Rotors> known_rotors;
    const Rotors& controller_rotors() const { return known_rotors ? *known_rotors : *rotors; }
    std::unique_ptr<FlightController> controller;
    std::unique_ptr<ElectricDrive> drive;    // when the actuation is modelled
    std::unique_ptr<sensors::ImuModel> imu;  // when the flight controller runs on its own gyroscope
    std::unique_ptr<GyroFilter> gyro;
    // when it also estimates its attitude: the filter, and the stream of its aiding measurements' noise
    std::unique_ptr<sensors::ComplementaryAttitudeFilter> attitude;
    // the gyroscope's readings and the true specific force (in S) summed over the integration interval so far
    Eigen::Vector3d w_sum_S_radps = Eigen::Vector3d::Zero();
    Eigen::Vector3d f_sum_S_mps2 = Eigen::Vector3d::Zero();
    int integrated_steps = 0;
    // the forces of its rotors' wakes as last evaluated (EvaluateWakes), held until the next evaluation
    struct WakeForce {
      int body = 0;  // what the ray hit
      Eigen::Vector3d force_W_N = Eigen::Vector3d::Zero();
      Eigen::Vector3d p_CH_B_m = Eigen::Vector3d::Zero();  // the point hit from that body's CoM, in its frame
    };
    std::vector<WakeForce> wake_forces;
    Eigen::Vector3d accelerometer_offset_S_mps2 = Eigen::Vector3d::Zero();  // its calibration
    std::mt19937_64 aiding_random;
    SubAircraftSetpoint setpoint;
    // the command link, and the setpoints on their way by the step they arrive at (non-decreasing)
    bridge::LinkDelay link;
    std::deque<std::pair<int64_t, SubAircraftSetpoint>> in_flight;
  };
  struct VehicleSim {
    VehicleSpec spec;
    std::vector<SubAircraftSim> sub_aircraft;
    VehicleOutput output;
    std::unique_ptr<DrydenTurbulence> turbulence;        // when the air is turbulent
    Eigen::Vector3d gust_mps = Eigen::Vector3d::Zero();  // its last sample: u, v, w (ApplyAir)
  };

  struct LatchSim {
    LatchSpec spec;
    int world_latch = 0;
    LatchOutput output;
  };

  void ApplySubAircraft(VehicleSim& vehicle, int s);
  // what sub-aircraft s's flight controller takes for its attitude, rate and angular acceleration (in S)
  void SenseRotation(SubAircraftSim& sim, const BodyState& state, Eigen::Quaterniond* q_WS,
                     Eigen::Vector3d* w_WS_S_radps, Eigen::Vector3d* alpha_WS_S_radps2);
  void ApplyAir(VehicleSim& vehicle);
  void ApplyRotorAir(VehicleSim& vehicle, int s);  // ground effect and the rotors' drag
  // every rotor's wake, evaluated at kWakeRate_hz (physics/simulation.cc) and applied at every step
  void ApplyDownwash(VehicleSim& vehicle, int s);
  void EvaluateWakes(VehicleSim& vehicle, int s);
  void AddAirForce(int body, const Eigen::Vector3d& force_W_N, const Eigen::Vector3d& p_W_m);
  void ComputeOutputs(int v);
  bool Close(LatchSim& latch);
  void UpdateLatch(LatchSim& latch);

  MultibodyWorld world_;
  Eigen::Vector3d gravity_W_;
  AirConfig air_;
  double ground_z_m_ = 0.0;            // the turbulence's height reference (z = 0 without a ground)
  FlightControllerEstimate estimate_;  // with the aiding's periods in steps
  int64_t velocity_every_steps_ = 1;
  int64_t heading_every_steps_ = 1;
  int imu_integration_steps_ = 1;
  int64_t wake_every_steps_ = 1;
  int64_t turbulence_every_steps_ = 1;
  // which of the models slower than the physics are due in this step: four divisions a step, not one per
  // model and sub-aircraft (a 64-bit division costs tens of cycles)
  struct Due {
    bool turbulence = true, wakes = true, velocity = true, heading = true;
  } due_;
  std::vector<std::unique_ptr<VehicleSim>> vehicles_;
  std::vector<int> vehicle_of_body_;  // -1: not part of a vehicle
  // what a rotor's wake can push: movable bodies with collision shapes, with their bounding spheres as of
  // this step (one contiguous pass per rotor)
  struct WakeTarget {
    int body = 0;
    Eigen::Vector3d p_WC_m = Eigen::Vector3d::Zero();  // the sphere's centre: the body's CoM
    double radius_m = 0.0;
  };
  std::vector<WakeTarget> wake_targets_;
  std::vector<int> wake_candidates_;  // scratch, as large as wake_targets_
  std::vector<LatchSim> latches_;
};

}  // namespace iapsim::physics
