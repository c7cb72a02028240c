#include "physics/flight_controller.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iapsim::physics {

bool SubAircraftSetpoint::IsValid() const {
  return std::isfinite(thrust_N) && q_WS.coeffs().allFinite() && std::abs(q_WS.norm() - 1.0) < 1e-6 &&
         w_WS_S.allFinite() && thrust_W_N.allFinite() && torque_S_Nm.allFinite() &&
         angular_acceleration_S_radps2.allFinite();
}

ButterworthLowPass::ButterworthLowPass(double cutoff_hz, double sample_hz) {
  if (!(cutoff_hz > 0.0 && cutoff_hz < sample_hz / 2.0)) {
    throw std::invalid_argument("a low-pass cutoff must lie between 0 and half the sample rate");
  }
  // H(s) = 1 / (s² + √2 s + 1) at s = (1/Ω) (1 − z⁻¹)/(1 + z⁻¹), Ω = tan(π f_c / f_s)
  const double omega = std::tan(M_PI * cutoff_hz / sample_hz);
  const double scale = 1.0 + std::sqrt(2.0) * omega + omega * omega;
  b0_ = omega * omega / scale;
  b1_ = 2.0 * b0_;
  b2_ = b0_;
  a1_ = 2.0 * (omega * omega - 1.0) / scale;
  a2_ = (1.0 - std::sqrt(2.0) * omega + omega * omega) / scale;
}

Eigen::Vector3d ButterworthLowPass::Apply(const Eigen::Vector3d& input) {
  const Eigen::Vector3d state = input - a1_ * delay1_ - a2_ * delay2_;
  const Eigen::Vector3d output = b0_ * state + b1_ * delay1_ + b2_ * delay2_;
  delay2_ = delay1_;
  delay1_ = state;
  return output;
}

void ButterworthLowPass::Reset(const Eigen::Vector3d& input) {
  delay1_ = delay2_ = input / (1.0 + a1_ + a2_);
}

GyroFilter::GyroFilter(const model::FlightControllerGains& gains, double step_s)
    : step_s_(step_s),
      rate_filter_(gains.gyro_cutoff_hz, 1.0 / step_s),
      acceleration_filter_(gains.dgyro_cutoff_hz, 1.0 / step_s) {}

void GyroFilter::Update(const Eigen::Vector3d& gyro_S_radps) {
  if (!started_) {
    rate_filter_.Reset(gyro_S_radps);
    acceleration_filter_.Reset(Eigen::Vector3d::Zero());
    last_gyro_S_radps_ = gyro_S_radps;
    started_ = true;
  }
  rate_S_radps_ = rate_filter_.Apply(gyro_S_radps);
  acceleration_S_radps2_ = acceleration_filter_.Apply((gyro_S_radps - last_gyro_S_radps_) / step_s_);
  last_gyro_S_radps_ = gyro_S_radps;
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

MixerCut FlightController::Update(const SubAircraftSetpoint& setpoint, const Eigen::Quaterniond& q_WS,
                                  const Eigen::Vector3d& w_WS_S, const Eigen::Vector3d& alpha_WS_S,
                                  double dt_s, RotorVector* thrusts_N) {
  const Eigen::Vector3d rate_setpoint = setpoint.mode == SubAircraftSetpoint::Mode::kBodyRate
                                            ? setpoint.w_WS_S
                                            : RateSetpoint(setpoint.q_WS, q_WS);
  const Eigen::Vector3d rate_error = rate_setpoint - w_WS_S;
  if (!cut_.any()) {  // anti-windup: no integration while the mixer cuts
    rate_integral_rad_s2_ += gains_.rate_i_per_s2.cwiseProduct(rate_error) * dt_s;
    rate_integral_rad_s2_ = rate_integral_rad_s2_.cwiseMax(-gains_.rate_integral_limit_rad_s2)
                                .cwiseMin(gains_.rate_integral_limit_rad_s2);
  }
  // PX4's rate controller: the D term acts on the measured angular acceleration, not on the error's
  const Eigen::Vector3d angular_acceleration =
      gains_.rate_p_per_s.cwiseProduct(rate_error) + rate_integral_rad_s2_ -
      gains_.rate_d.cwiseProduct(alpha_WS_S) + setpoint.angular_acceleration_S_radps2;
  const Eigen::Vector3d torque_S =
      inertia_S_kgm2_ * angular_acceleration + w_WS_S.cross(inertia_S_kgm2_ * w_WS_S);
  cut_ = rotors_.Mix(setpoint.thrust_N, torque_S, thrusts_N);
  return cut_;
}

}  // namespace iapsim::physics
