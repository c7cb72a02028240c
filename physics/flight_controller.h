#pragma once
// The flight controller of one sub-aircraft, simulated at the physics rate inside the physics process: a
// PX4-style cascade (attitude P with tilt priority -> body-rate PID with inertia feed-forward -> mixer). It
// runs on the true attitude and body rate, or (a scenario's flight_controller_sensing) on its own gyroscope
// through PX4's filters. What a real IAP computer sends to each quadrotor is its setpoint.

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
  // kAttitude, kBodyRate: an angular acceleration added to the rate loop's (feed-forward, rad/s², in S),
  // for commands that are accelerations (the RL docking actions, seed §IV-E); zero on the wire
  Eigen::Vector3d angular_acceleration_S_radps2 = Eigen::Vector3d::Zero();

  /// Whether every number is finite and the attitude is a unit quaternion (within 1e-6).
  bool IsValid() const;
};

/// PX4's two-pole low-pass filter (math::LowPassFilter2p), per axis: a second-order Butterworth filter
/// discretised with the bilinear transform with its cutoff pre-warped, in direct form II. Written here
/// because Eigen has no filters and the design is the textbook's (Oppenheim & Schafer, Discrete-Time Signal
/// Processing, §7.1).
class ButterworthLowPass {
 public:
  /// Requires 0 < cutoff_hz < sample_hz / 2.
  ButterworthLowPass(double cutoff_hz, double sample_hz);
  Eigen::Vector3d Apply(const Eigen::Vector3d& input);
  /// As if the input had been `input` forever.
  void Reset(const Eigen::Vector3d& input);

 private:
  double b0_, b1_, b2_, a1_, a2_;
  Eigen::Vector3d delay1_ = Eigen::Vector3d::Zero(), delay2_ = Eigen::Vector3d::Zero();
};

/// What the rate loop measures on a PX4 flight controller (its VehicleAngularVelocity): the gyroscope
/// through the IMU_GYRO_CUTOFF low-pass, and the gyroscope's difference quotient through the
/// IMU_DGYRO_CUTOFF low-pass as the angular acceleration for the D term. Sampled once per physics step.
class GyroFilter {
 public:
  GyroFilter(const model::FlightControllerGains& gains, double step_s);
  void Update(const Eigen::Vector3d& gyro_S_radps);
  const Eigen::Vector3d& rate_S_radps() const { return rate_S_radps_; }
  const Eigen::Vector3d& acceleration_S_radps2() const { return acceleration_S_radps2_; }

 private:
  double step_s_;
  ButterworthLowPass rate_filter_, acceleration_filter_;
  bool started_ = false;
  Eigen::Vector3d last_gyro_S_radps_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d rate_S_radps_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d acceleration_S_radps2_ = Eigen::Vector3d::Zero();
};

class FlightController {
 public:
  /// `inertia_S_kgm2` about the sub-aircraft's CoM; `rotors` is the rotor model the mixer drives.
  FlightController(const model::FlightControllerGains& gains, const Eigen::Matrix3d& inertia_S_kgm2,
                   const Rotors& rotors);

  /// One step: from the setpoint (kAttitude or kBodyRate), the attitude and body rate, and the angular
  /// acceleration the D term acts on (zero: no D term), the rotor thrusts the mixer asks for. Returns
  /// what the mixer cut (saturation).
  MixerCut Update(const SubAircraftSetpoint& setpoint, const Eigen::Quaterniond& q_WS,
                  const Eigen::Vector3d& w_WS_S, const Eigen::Vector3d& alpha_WS_S, double dt_s,
                  RotorVector* thrusts_N);

  /// The body-rate setpoint of the attitude loop (PX4's tilt-priority attitude controller).
  Eigen::Vector3d RateSetpoint(const Eigen::Quaterniond& q_WS_setpoint, const Eigen::Quaterniond& q_WS) const;

  void Reset() { rate_integral_rad_s2_.setZero(); }

 private:
  model::FlightControllerGains gains_;
  Eigen::Matrix3d inertia_S_kgm2_;
  const Rotors& rotors_;
  Eigen::Vector3d rate_integral_rad_s2_ = Eigen::Vector3d::Zero();
  MixerCut cut_;
};

}  // namespace iapsim::physics
