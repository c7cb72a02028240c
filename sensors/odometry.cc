#include "sensors/odometry.h"

#include <cmath>
#include <stdexcept>

#include "sensors/gaussian.h"

namespace iapsim::sensors {

OdometryModel::OdometryModel(const OdometryConfig& config, uint64_t seed) : config_(config), random_(seed) {}

void OdometryModel::Correlate(Eigen::Vector3d* error, double sigma, double dt_s) {
  // x_{k+1} = φ x_k + σ √(1 − φ²) η, φ = e^(−Δt/τ): the exact discretisation of dx = −x/τ dt + σ√(2/τ) dW,
  // whose stationary σ it keeps at any Δt; τ = 0 gives φ = 0, white noise of σ
  const double tau_s = config_.noise.correlation_time_s;
  const double phi = tau_s > 0.0 ? std::exp(-dt_s / tau_s) : 0.0;
  *error = phi * *error + sigma * std::sqrt(1.0 - phi * phi) * Gaussian3(random_);
}

OdometryState OdometryModel::Sample(const OdometryState& truth, double dt_s) {
  if (!(dt_s > 0.0)) throw std::invalid_argument("OdometryModel::Sample: dt_s must be positive");
  const OdometryNoise& n = config_.noise;
  if (!started_) {  // stationary Gauss–Markov errors, no drift yet
    started_ = true;
    position_error_W_m_ = n.position_sigma_m * Gaussian3(random_);
    attitude_error_B_rad_ = n.attitude_sigma_rad * Gaussian3(random_);
    velocity_error_B_mps_ = n.velocity_sigma_mps * Gaussian3(random_);
  } else {
    const double sqrt_dt = std::sqrt(dt_s);
    drift_W_m_ += n.position_drift_m_per_sqrt_s * sqrt_dt * Gaussian3(random_);
    yaw_drift_rad_ += n.yaw_drift_rad_per_sqrt_s * sqrt_dt * StandardNormal(random_);
    Correlate(&position_error_W_m_, n.position_sigma_m, dt_s);
    Correlate(&attitude_error_B_rad_, n.attitude_sigma_rad, dt_s);
    Correlate(&velocity_error_B_mps_, n.velocity_sigma_mps, dt_s);
  }
  OdometryState estimate;
  estimate.p_WB_m = truth.p_WB_m + drift_W_m_ + position_error_W_m_;
  const double angle_rad = attitude_error_B_rad_.norm();
  const Eigen::Quaterniond error_B =
      angle_rad > 0.0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, attitude_error_B_rad_ / angle_rad))
                      : Eigen::Quaterniond::Identity();
  estimate.q_WB =
      (Eigen::AngleAxisd(yaw_drift_rad_, Eigen::Vector3d::UnitZ()) * truth.q_WB.normalized() * error_B)
          .normalized();
  estimate.v_WB_B_mps = truth.v_WB_B_mps + velocity_error_B_mps_;
  estimate.w_WB_B_radps =
      truth.w_WB_B_radps + n.angular_rate_noise_density / std::sqrt(dt_s) * Gaussian3(random_);
  return estimate;
}

}  // namespace iapsim::sensors
