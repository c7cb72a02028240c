#include "sensors/attitude_filter.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "sensors/attitude_estimator.h"

namespace iapsim::sensors {

ComplementaryAttitudeFilter::ComplementaryAttitudeFilter(const ComplementaryFilterGains& gains,
                                                         double gravity_mps2)
    : gains_(gains), gravity_mps2_(gravity_mps2) {
  for (const auto& [name, value] : {std::pair{"accelerometer_weight_per_s", gains.accelerometer_weight_per_s},
                                    {"heading_weight_per_s", gains.heading_weight_per_s},
                                    {"gyroscope_bias_weight_per_s", gains.gyroscope_bias_weight_per_s},
                                    {"max_gyroscope_bias_radps", gains.max_gyroscope_bias_radps},
                                    {"bias_learning_max_rate_radps", gains.bias_learning_max_rate_radps}}) {
    if (!(value >= 0.0 && std::isfinite(value))) {
      throw std::invalid_argument(std::string("attitude filter: ") + name + " must be finite and >= 0");
    }
  }
  if (!(gravity_mps2 > 0.0)) throw std::invalid_argument("attitude filter: gravity must be positive");
}

void ComplementaryAttitudeFilter::Initialize(const Eigen::Quaterniond& q_WB,
                                             const Eigen::Vector3d& gyroscope_bias_B_radps) {
  q_WB_ = q_reported_WB_ = q_WB.normalized();
  gyroscope_bias_B_radps_ = gyroscope_bias_B_radps;
  a_W_mps2_.setZero();
  previous_velocity_.reset();
  initialized_ = true;
}

void ComplementaryAttitudeFilter::UpdateVelocity(const Eigen::Vector3d& v_W_mps, double t_s) {
  if (previous_velocity_ && t_s > previous_velocity_->second) {
    a_W_mps2_ = (v_W_mps - previous_velocity_->first) / (t_s - previous_velocity_->second);
  } else {
    a_W_mps2_.setZero();
  }
  previous_velocity_ = {v_W_mps, t_s};
}

void ComplementaryAttitudeFilter::UpdateHeading(double yaw_rad, double interval_s) {
  if (!initialized_)
    throw std::logic_error("ComplementaryAttitudeFilter: Initialize before the first update");
  if (!(interval_s > 0.0)) {
    throw std::invalid_argument("ComplementaryAttitudeFilter::UpdateHeading: interval_s must be positive");
  }
  // a rotation about W's z by the yaw error, expressed in B
  const Eigen::Vector3d down_B = q_WB_.conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d correction_B_rad =
      gains_.heading_weight_per_s * interval_s * WrapToPi(yaw_rad - RollPitchYaw_rad(q_WB_).z()) * down_B;
  LearnBias(correction_B_rad);
  Turn(correction_B_rad);
}

void ComplementaryAttitudeFilter::LearnBias(const Eigen::Vector3d& correction_B_rad) {
  if (!(last_rate_radps_ < gains_.bias_learning_max_rate_radps)) return;
  gyroscope_bias_B_radps_ = (gyroscope_bias_B_radps_ - gains_.gyroscope_bias_weight_per_s * correction_B_rad)
                                .cwiseMax(-gains_.max_gyroscope_bias_radps)
                                .cwiseMin(gains_.max_gyroscope_bias_radps);
}

namespace {

// q ⊗ (1, θ/2) normalised turns by 2 atan(|θ|/2): θ³/12 short, 1e-9 rad for 3 rad/s over 1 ms
Eigen::Quaterniond Turned(const Eigen::Quaterniond& q, const Eigen::Vector3d& angle_rad) {
  return (q * Eigen::Quaterniond(1.0, 0.5 * angle_rad.x(), 0.5 * angle_rad.y(), 0.5 * angle_rad.z()))
      .normalized();
}

}  // namespace

void ComplementaryAttitudeFilter::Turn(const Eigen::Vector3d& angle_B_rad) {
  q_WB_ = Turned(q_WB_, angle_B_rad);
  q_reported_WB_ = Turned(q_reported_WB_, angle_B_rad);
}

void ComplementaryAttitudeFilter::Propagate(const Eigen::Vector3d& w_B_radps, double dt_s) {
  if (!initialized_)
    throw std::logic_error("ComplementaryAttitudeFilter: Initialize before the first propagation");
  q_reported_WB_ = Turned(q_reported_WB_, dt_s * (w_B_radps - gyroscope_bias_B_radps_));
}

void ComplementaryAttitudeFilter::Update(const Eigen::Vector3d& w_B_radps, const Eigen::Vector3d& f_B_mps2,
                                         double dt_s) {
  if (!initialized_)
    throw std::logic_error("ComplementaryAttitudeFilter: Initialize before the first update");
  if (!(dt_s > 0.0))
    throw std::invalid_argument("ComplementaryAttitudeFilter::Update: dt_s must be positive");
  const Eigen::Quaterniond q_BW = q_WB_.conjugate();
  const Eigen::Vector3d down_B = q_BW * Eigen::Vector3d::UnitZ();  // v̂
  last_rate_radps_ = w_B_radps.norm();
  Eigen::Vector3d correction_B_rad = Eigen::Vector3d::Zero();
  // f = Rᵀ(a − g e₃) in NED: the down direction is −(f − Rᵀa); with R̂ for R, as PX4 does
  const Eigen::Vector3d gravity_B_mps2 = -(f_B_mps2 - q_BW * a_W_mps2_);
  const double gravity_norm_mps2 = gravity_B_mps2.norm();
  if (gravity_norm_mps2 > 1e-3 * gravity_mps2_) {  // free fall tells nothing of the tilt
    correction_B_rad =
        gains_.accelerometer_weight_per_s * dt_s * (gravity_B_mps2 / gravity_norm_mps2).cross(down_B);
  }
  LearnBias(correction_B_rad);
  q_WB_ = q_reported_WB_ = Turned(q_WB_, correction_B_rad + dt_s * (w_B_radps - gyroscope_bias_B_radps_));
}

}  // namespace iapsim::sensors
