#include "sensors/imu.h"

#include <cmath>
#include <stdexcept>

#include "sensors/gaussian.h"

namespace iapsim::sensors {

ImuNoise TableViNoise() {
  // Table VI: r_a^ω 0.0212, r_b^ω 1.4e-5, r_a^a 0.2828, r_b^a 1.4e-3, standard deviations per 200 Hz sample
  const double sqrt_dt = std::sqrt(1.0 / kTableViRate_hz);
  ImuNoise noise;
  noise.gyroscope_noise_density = 0.0212 * sqrt_dt;
  noise.gyroscope_random_walk = 1.4e-5 / sqrt_dt;
  noise.accelerometer_noise_density = 0.2828 * sqrt_dt;
  noise.accelerometer_random_walk = 1.4e-3 / sqrt_dt;
  return noise;
}

ImuSample IdealImuSample(const BodyKinematics& truth, const Eigen::Vector3d& p_BI_m,
                         const Eigen::Quaterniond& q_BI, double gravity_mps2) {
  const Eigen::Vector3d& w = truth.w_WB_B_radps;
  // r is fixed in B, so the IMU point's acceleration adds R_WB (α×r + ω×(ω×r)) to that of B's origin
  const Eigen::Vector3d a_WI_B_mps2 = truth.q_WB.conjugate() * truth.a_WB_W_mps2 +
                                      truth.alpha_WB_B_radps2.cross(p_BI_m) + w.cross(w.cross(p_BI_m));
  const Eigen::Vector3d gravity_B_mps2 = truth.q_WB.conjugate() * Eigen::Vector3d(0.0, 0.0, gravity_mps2);
  ImuSample sample;
  sample.f_I_mps2 = q_BI.conjugate() * (a_WI_B_mps2 - gravity_B_mps2);
  sample.w_I_radps = q_BI.conjugate() * w;
  return sample;
}

ImuModel::ImuModel(const ImuConfig& config, uint64_t seed)
    : config_(config), random_(seed + config.seed_offset) {
  config_.q_BI.normalize();
  gyroscope_bias_radps_ =
      config_.initial_gyroscope_bias_radps + config_.initial_gyroscope_bias_sigma_radps * Gaussian3(random_);
  accelerometer_bias_mps2_ = config_.initial_accelerometer_bias_mps2 +
                             config_.initial_accelerometer_bias_sigma_mps2 * Gaussian3(random_);
}

ImuSample ImuModel::Sample(const BodyKinematics& truth, double dt_s) {
  if (!(dt_s > 0.0)) throw std::invalid_argument("ImuModel::Sample: dt_s must be positive");
  const ImuNoise& n = config_.noise;
  const double sqrt_dt = std::sqrt(dt_s);
  gyroscope_bias_radps_ += n.gyroscope_random_walk * sqrt_dt * Gaussian3(random_);
  accelerometer_bias_mps2_ += n.accelerometer_random_walk * sqrt_dt * Gaussian3(random_);
  ImuSample sample = IdealImuSample(truth, config_.p_BI_m, config_.q_BI, config_.gravity_mps2);
  sample.w_I_radps += gyroscope_bias_radps_ + n.gyroscope_noise_density / sqrt_dt * Gaussian3(random_);
  sample.f_I_mps2 += accelerometer_bias_mps2_ + n.accelerometer_noise_density / sqrt_dt * Gaussian3(random_);
  return sample;
}

Eigen::Vector3d ImuModel::SampleGyroscope(const Eigen::Vector3d& w_WB_B_radps, double dt_s) {
  if (!(dt_s > 0.0)) throw std::invalid_argument("ImuModel::SampleGyroscope: dt_s must be positive");
  gyroscope_bias_radps_ += config_.noise.gyroscope_random_walk * std::sqrt(dt_s) * Gaussian3(random_);
  return SampleGyroscopeInInterval(w_WB_B_radps, dt_s);
}

Eigen::Vector3d ImuModel::SampleGyroscopeInInterval(const Eigen::Vector3d& w_WB_B_radps, double dt_s) {
  if (!(dt_s > 0.0))
    throw std::invalid_argument("ImuModel::SampleGyroscopeInInterval: dt_s must be positive");
  return config_.q_BI.conjugate() * w_WB_B_radps + gyroscope_bias_radps_ +
         config_.noise.gyroscope_noise_density / std::sqrt(dt_s) * Gaussian3(random_);
}

Eigen::Vector3d ImuModel::EndInterval(const Eigen::Vector3d& f_B_mps2, double interval_s) {
  if (!(interval_s > 0.0)) throw std::invalid_argument("ImuModel::EndInterval: interval_s must be positive");
  const ImuNoise& n = config_.noise;
  const double sqrt_interval = std::sqrt(interval_s);
  gyroscope_bias_radps_ += n.gyroscope_random_walk * sqrt_interval * Gaussian3(random_);
  accelerometer_bias_mps2_ += n.accelerometer_random_walk * sqrt_interval * Gaussian3(random_);
  return config_.q_BI.conjugate() * f_B_mps2 + accelerometer_bias_mps2_ +
         n.accelerometer_noise_density / sqrt_interval * Gaussian3(random_);
}

}  // namespace iapsim::sensors
