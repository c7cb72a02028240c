#pragma once
// IAPs in a world: each vehicle is a multibody (platform + sub-aircraft on spherical or fixed joints) whose
// sub-aircraft carry rotors driven by simulated flight controllers. In-process and bus-free: the physics
// process, the benchmarks, the tests and (later) RL environments all drive this class.
//
// Sub-aircraft torques (rotor moments and drag) act on the sub-aircraft body, reacting on the air, as in the
// seed's equations (3) and (7): the platform feels thrust only, through the joint. `torque_reaction:
// platform` instead applies them as joint torques with the reaction on the platform (the seed's Fig. 9).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/flight_controller.h"
#include "physics/multibody_world.h"
#include "physics/rotor.h"

namespace iapsim::physics {

enum class TorqueReaction { kAir, kPlatform };
/// Initial rotor speeds: hover carries the weight with no moment (level trim); idle is the minimum.
enum class InitialRotors { kHover, kIdle };

struct VehicleSpec {
  std::string name;
  model::Vehicle vehicle;                    // rotors and flight controllers
  model::MultibodyDescription description;  // the rigid bodies (from the vehicle's URDF)
  Eigen::Vector3d p_WP_m = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
  InitialRotors initial_rotors = InitialRotors::kHover;
  TorqueReaction torque_reaction = TorqueReaction::kAir;
};

struct SimulationConfig {
  double step_s = 0.001;
  WorldConfig world;
  std::vector<VehicleSpec> vehicles;
};

/// What one sub-aircraft did in the last step.
struct SubAircraftOutput {
  Eigen::Vector3d thrust_W_N = Eigen::Vector3d::Zero();   // Λ_i: force of its rotors, in W
  Eigen::Vector3d torque_S_Nm = Eigen::Vector3d::Zero();  // τ_i about its CoM, in S
  RotorVector rotor_speeds_rad_s;
  bool saturated = false;
  // force of the sub-aircraft on the platform through its joint, in P (Newton's law on the sub-aircraft)
  Eigen::Vector3d joint_force_P_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d contact_force_W_N = Eigen::Vector3d::Zero();  // from contacts with anything else
};

struct VehicleOutput {
  int platform_body = 0;                // body id in the world
  std::vector<int> sub_aircraft_bodies;  // in the vehicle's order
  std::vector<SubAircraftOutput> sub_aircraft;
  // resultant of every contact between the vehicle and anything else, moment about the platform's CoM
  Eigen::Vector3d external_force_W_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d external_torque_W_Nm = Eigen::Vector3d::Zero();
  Eigen::Vector3d external_force_P_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d external_torque_P_Nm = Eigen::Vector3d::Zero();
  uint64_t invalid_commands = 0;   // rejected setpoints (NaN, infinite, non-unit quaternion)
  uint64_t saturated_steps = 0;    // sub-aircraft steps where a mixer cut
};

class Simulation {
 public:
  /// Throws std::invalid_argument naming the vehicle for anything the world cannot build.
  explicit Simulation(const SimulationConfig& config);
  ~Simulation();

  int vehicle_count() const { return static_cast<int>(vehicles_.size()); }
  const VehicleSpec& vehicle(int v) const { return vehicles_[v]->spec; }

  /// Holds this setpoint for sub-aircraft s of vehicle v until the next one. An invalid setpoint is
  /// rejected (counted, the last valid one held) and false returned.
  bool SetCommand(int v, int s, const SubAircraftSetpoint& setpoint);

  void Step();

  int64_t step_count() const { return world_.step_count(); }
  double time_s() const { return static_cast<double>(world_.step_count()) * world_.step_s(); }
  const MultibodyWorld& world() const { return world_; }
  /// For tests and disturbances: loads added here act in the next step.
  MultibodyWorld& mutable_world() { return world_; }
  const VehicleOutput& output(int v) const { return vehicles_[v]->output; }

 private:
  struct SubAircraftSim {
    std::unique_ptr<Rotors> rotors;
    std::unique_ptr<FlightController> controller;
    SubAircraftSetpoint setpoint;
  };
  struct VehicleSim {
    VehicleSpec spec;
    std::vector<SubAircraftSim> sub_aircraft;
    VehicleOutput output;
  };

  void ApplySubAircraft(VehicleSim& vehicle, int s);
  void ComputeOutputs(int v);

  MultibodyWorld world_;
  Eigen::Vector3d gravity_W_;
  std::vector<std::unique_ptr<VehicleSim>> vehicles_;
  std::vector<int> vehicle_of_body_;  // -1: not part of a vehicle
};

}  // namespace iapsim::physics
