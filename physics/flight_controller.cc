#include "physics/flight_controller.h"

#include <algorithm>
#include <cmath>

namespace iapsim::physics {

bool SubAircraftSetpoint::IsValid() const {
  return std::isfinite(thrust_N) && q_WS.coeffs().allFinite() && std::abs(q_WS.norm() - 1.0) < 1e-6 &&
         w_WS_S.allFinite() && thrust_W_N.allFinite() && torque_S_Nm.allFinite();
}

FlightController::FlightController(const model::FlightControllerGains& gains,
                                   const Eigen::Matrix3d& inertia_S_kgm2, const Rotors& rotors)
    : gains_(gains), inertia_S_kgm2_(inertia_S_kgm2), rotors_(rotors) {}

// The tilt-priority attitude law of PX4 (Brescianini, Hehn, D'Andrea 2013, "Nonlinear quadrocopter attitude
// control", as in PX4's AttitudeControl): first turn the body z axis onto the setpoint's, then add the yaw
// part scaled by yaw gain / tilt gain, so yaw errors never steal authority from tilt.
Eigen::Vector3d FlightController::RateSetpoint(const Eigen::Quaterniond& q_WS_setpoint,
                                               const Eigen::Quaterniond& q_WS) const {
  const Eigen::Vector3d& gain = gains_.attitude_p_per_s;
  const double tilt_gain = std::max(gain.x(), 1e-9);
  const double yaw_weight = std::clamp(gain.z() / tilt_gain, 0.0, 1.0);

  const Eigen::Vector3d z_W = q_WS * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d z_setpoint_W = q_WS_setpoint * Eigen::Vector3d::UnitZ();
  Eigen::Quaterniond reduced;
  if (z_W.dot(z_setpoint_W) < -1.0 + 1e-9) {
    reduced = q_WS_setpoint;  // thrust axes opposite: no unique shortest tilt
  } else {
    reduced = Eigen::Quaterniond::FromTwoVectors(z_W, z_setpoint_W) * q_WS;
  }
  Eigen::Quaterniond mix = reduced.conjugate() * q_WS_setpoint;  // the remaining rotation, about z
  if (mix.w() < 0.0) mix.coeffs() *= -1.0;
  const double w = std::clamp(mix.w(), -1.0, 1.0);
  const double z = std::clamp(mix.z(), -1.0, 1.0);
  const Eigen::Quaterniond target =
      reduced * Eigen::Quaterniond(std::cos(yaw_weight * std::acos(w)), 0.0, 0.0, std::sin(yaw_weight * std::asin(z)));

  Eigen::Quaterniond error = q_WS.conjugate() * target;
  if (error.w() < 0.0) error.coeffs() *= -1.0;
  Eigen::Vector3d effective_gain = gain;
  if (yaw_weight > 1e-4) effective_gain.z() = gain.z() / yaw_weight;  // the weight already scaled yaw down
  const Eigen::Vector3d rate = (2.0 * error.vec()).cwiseProduct(effective_gain);
  return rate.cwiseMax(-gains_.max_rate_rad_s).cwiseMin(gains_.max_rate_rad_s);
}

bool FlightController::Update(const SubAircraftSetpoint& setpoint, const Eigen::Quaterniond& q_WS,
                              const Eigen::Vector3d& w_WS_S, double dt_s, RotorVector* thrusts_N) {
  const Eigen::Vector3d rate_setpoint = setpoint.mode == SubAircraftSetpoint::Mode::kBodyRate
                                            ? setpoint.w_WS_S
                                            : RateSetpoint(setpoint.q_WS, q_WS);
  const Eigen::Vector3d rate_error = rate_setpoint - w_WS_S;
  if (!saturated_) {  // anti-windup: no integration while the mixer cuts
    rate_integral_rad_s2_ += gains_.rate_i_per_s2.cwiseProduct(rate_error) * dt_s;
    rate_integral_rad_s2_ = rate_integral_rad_s2_.cwiseMax(-gains_.rate_integral_limit_rad_s2)
                                .cwiseMin(gains_.rate_integral_limit_rad_s2);
  }
  const Eigen::Vector3d angular_acceleration = gains_.rate_p_per_s.cwiseProduct(rate_error) + rate_integral_rad_s2_;
  const Eigen::Vector3d torque_S =
      inertia_S_kgm2_ * angular_acceleration + w_WS_S.cross(inertia_S_kgm2_ * w_WS_S);
  saturated_ = rotors_.Mix(setpoint.thrust_N, torque_S, thrusts_N);
  return saturated_;
}

}  // namespace iapsim::physics
