#include "vio/imu_preintegration.h"

#include <stdexcept>

#include "vio/so3.h"

namespace iapsim::vio {

sensors::ImuSample InterpolatedSample(const ImuSamples& samples, double t) {
  if (t <= samples.front().first) return samples.front().second;
  for (std::size_t k = 1; k < samples.size(); ++k) {
    if (samples[k].first < t) continue;
    const double a = (t - samples[k - 1].first) / (samples[k].first - samples[k - 1].first);
    sensors::ImuSample s;
    s.f_I_mps2 = (1.0 - a) * samples[k - 1].second.f_I_mps2 + a * samples[k].second.f_I_mps2;
    s.w_I_radps = (1.0 - a) * samples[k - 1].second.w_I_radps + a * samples[k].second.w_I_radps;
    return s;
  }
  return samples.back().second;
}

ImuPreintegration::ImuPreintegration(const sensors::ImuSample& first, const ImuBiases& biases,
                                     const sensors::ImuNoise& noise)
    : first_(first), noise_(noise) {
  Reset(biases);
}

void ImuPreintegration::Reset(const ImuBiases& biases) {
  biases_ = biases;
  dt_s_ = 0.0;
  delta_ = ImuDelta{};
  covariance_.setZero();
  d_delta_d_bg_.setZero();
  d_delta_d_ba_.setZero();
}

void ImuPreintegration::Integrate(double dt_s, const sensors::ImuSample& sample) {
  if (!(dt_s > 0.0)) throw std::invalid_argument("ImuPreintegration: dt_s must be > 0");
  const sensors::ImuSample& previous = intervals_.empty() ? first_ : intervals_.back().sample;
  Propagate(dt_s, previous, sample);
  intervals_.push_back({dt_s, sample});
}

void ImuPreintegration::Repropagate(const ImuBiases& biases) {
  Reset(biases);
  const sensors::ImuSample* previous = &first_;
  for (const Interval& interval : intervals_) {
    Propagate(interval.dt_s, *previous, interval.sample);
    previous = &interval.sample;
  }
}

void ImuPreintegration::Propagate(double dt, const sensors::ImuSample& previous,
                                  const sensors::ImuSample& sample) {
  const Eigen::Vector3d w_mid = 0.5 * (previous.w_I_radps + sample.w_I_radps) - biases_.gyroscope_radps;
  const Eigen::Vector3d a_k = previous.f_I_mps2 - biases_.accelerometer_mps2;
  const Eigen::Vector3d a_k1 = sample.f_I_mps2 - biases_.accelerometer_mps2;
  const Eigen::Matrix3d E = Exp(w_mid * dt);
  const Eigen::Matrix3d R_k = delta_.delta_R;
  const Eigen::Matrix3d R_k1 = R_k * E;
  const Eigen::Vector3d a_mid = 0.5 * (R_k * a_k + R_k1 * a_k1);

  // The step linearised about the mean: x_{k+1} = A x_k + B u, x = [δφ, δv, δp], u = [δω̄, δf] (an additive
  // error of the mid-interval rate and of both specific forces). A bias error enters as u = −δb, so the bias
  // Jacobians follow the same recursion: J_{k+1} = A J_k − B.
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d Jr_dt = RightJacobian(w_mid * dt) * dt;
  const Eigen::Matrix3d da_dphi = -0.5 * (R_k * Skew(a_k) + R_k1 * Skew(a_k1) * E.transpose());
  const Eigen::Matrix3d da_dw = -0.5 * R_k1 * Skew(a_k1) * Jr_dt;
  const Eigen::Matrix3d da_df = 0.5 * (R_k + R_k1);
  Matrix9d A = Matrix9d::Identity();
  A.block<3, 3>(0, 0) = E.transpose();
  A.block<3, 3>(3, 0) = da_dphi * dt;
  A.block<3, 3>(6, 0) = 0.5 * da_dphi * dt * dt;
  A.block<3, 3>(6, 3) = I * dt;
  Matrix93d B_w, B_f;
  B_w << Jr_dt, da_dw * dt, 0.5 * da_dw * dt * dt;
  B_f << Eigen::Matrix3d::Zero(), da_df * dt, 0.5 * da_df * dt * dt;

  const double gyro_variance = noise_.gyroscope_noise_density * noise_.gyroscope_noise_density / dt;
  const double accel_variance = noise_.accelerometer_noise_density * noise_.accelerometer_noise_density / dt;
  covariance_ = A * covariance_ * A.transpose() + gyro_variance * B_w * B_w.transpose() +
                accel_variance * B_f * B_f.transpose();
  d_delta_d_bg_ = A * d_delta_d_bg_ - B_w;
  d_delta_d_ba_ = A * d_delta_d_ba_ - B_f;

  delta_.delta_p_m += delta_.delta_v_mps * dt + 0.5 * a_mid * dt * dt;
  delta_.delta_v_mps += a_mid * dt;
  delta_.delta_R = R_k1;
  dt_s_ += dt;
}

ImuDelta ImuPreintegration::Corrected(const ImuBiases& biases) const {
  const Eigen::Vector3d d_bg = biases.gyroscope_radps - biases_.gyroscope_radps;
  const Eigen::Vector3d d_ba = biases.accelerometer_mps2 - biases_.accelerometer_mps2;
  const Vector9d correction = d_delta_d_bg_ * d_bg + d_delta_d_ba_ * d_ba;
  ImuDelta corrected;
  corrected.delta_R = delta_.delta_R * Exp(correction.head<3>());
  corrected.delta_v_mps = delta_.delta_v_mps + correction.segment<3>(3);
  corrected.delta_p_m = delta_.delta_p_m + correction.tail<3>();
  return corrected;
}

NavState ImuPreintegration::Predict(const NavState& state_i, const ImuBiases& biases,
                                    const Eigen::Vector3d& g_W_mps2) const {
  const ImuDelta d = Corrected(biases);
  const Eigen::Matrix3d R_i = state_i.q_WI.toRotationMatrix();
  NavState state_j;
  state_j.q_WI = Eigen::Quaterniond(R_i * d.delta_R).normalized();
  state_j.v_WI_W_mps = state_i.v_WI_W_mps + g_W_mps2 * dt_s_ + R_i * d.delta_v_mps;
  state_j.p_WI_m =
      state_i.p_WI_m + state_i.v_WI_W_mps * dt_s_ + 0.5 * g_W_mps2 * dt_s_ * dt_s_ + R_i * d.delta_p_m;
  return state_j;
}

Vector9d ImuPreintegration::Residual(const NavState& state_i, const NavState& state_j,
                                     const ImuBiases& biases, const Eigen::Vector3d& g_W_mps2) const {
  const ImuDelta d = Corrected(biases);
  const Eigen::Matrix3d R_iT = state_i.q_WI.toRotationMatrix().transpose();
  Vector9d r;
  r.head<3>() = Log(Eigen::Matrix3d(d.delta_R.transpose() * R_iT * state_j.q_WI.toRotationMatrix()));
  r.segment<3>(3) = R_iT * (state_j.v_WI_W_mps - state_i.v_WI_W_mps - g_W_mps2 * dt_s_) - d.delta_v_mps;
  r.tail<3>() =
      R_iT * (state_j.p_WI_m - state_i.p_WI_m - state_i.v_WI_W_mps * dt_s_ - 0.5 * g_W_mps2 * dt_s_ * dt_s_) -
      d.delta_p_m;
  return r;
}

}  // namespace iapsim::vio
