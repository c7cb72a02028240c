#pragma once
// The flight controller of one sub-aircraft, simulated at the physics rate inside the physics process: a
// PX4-style cascade (attitude P with tilt priority -> body-rate PI with inertia feed-forward -> mixer) on the
// true attitude and body rate. What a real IAP computer sends to each quadrotor is its setpoint.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "model/vehicle.h"
#include "physics/rotor.h"

namespace iapsim::physics {

/// Per-sub-aircraft command (the wire's iapsim_msgs/SubAircraftCommand, as a plain struct).
struct SubAircraftSetpoint {
  enum class Mode { kAttitude, kBodyRate, kThrustTorque };
  Mode mode = Mode::kAttitude;
  double thrust_N = 0.0;                                        // collective, along −z_S
  Eigen::Quaterniond q_WS = Eigen::Quaterniond::Identity();     // kAttitude
  Eigen::Vector3d w_WS_S = Eigen::Vector3d::Zero();             // kBodyRate, rad/s
  Eigen::Vector3d thrust_W_N = Eigen::Vector3d::Zero();         // kThrustTorque: Λ_i in W
  Eigen::Vector3d torque_S_Nm = Eigen::Vector3d::Zero();        // kThrustTorque: τ_i in S, about the CoM

  /// Whether every number is finite and the attitude is a unit quaternion (within 1e-6).
  bool IsValid() const;
};

class FlightController {
 public:
  /// `inertia_S_kgm2` about the sub-aircraft's CoM; `rotors` is the rotor model the mixer drives.
  FlightController(const model::FlightControllerGains& gains, const Eigen::Matrix3d& inertia_S_kgm2,
                   const Rotors& rotors);

  /// One step: from the setpoint (kAttitude or kBodyRate) and the true attitude and body rate, the rotor
  /// thrusts the mixer asks for. Returns whether the mixer cut anything (saturation).
  bool Update(const SubAircraftSetpoint& setpoint, const Eigen::Quaterniond& q_WS,
              const Eigen::Vector3d& w_WS_S, double dt_s, RotorVector* thrusts_N);

  /// The body-rate setpoint of the attitude loop (PX4's tilt-priority attitude controller).
  Eigen::Vector3d RateSetpoint(const Eigen::Quaterniond& q_WS_setpoint, const Eigen::Quaterniond& q_WS) const;

  void Reset() { rate_integral_rad_s2_.setZero(); }

 private:
  model::FlightControllerGains gains_;
  Eigen::Matrix3d inertia_S_kgm2_;
  const Rotors& rotors_;
  Eigen::Vector3d rate_integral_rad_s2_ = Eigen::Vector3d::Zero();
  bool saturated_ = false;
};

}  // namespace iapsim::physics
