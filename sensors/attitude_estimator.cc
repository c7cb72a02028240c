#include "sensors/attitude_estimator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace iapsim::sensors {
namespace {

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return S;
}

// the rotation of rotation vector v
Eigen::Quaterniond Exp(const Eigen::Vector3d& v) {
  const double angle = v.norm();
  if (angle < 1e-12) return Eigen::Quaterniond(1.0, 0.5 * v.x(), 0.5 * v.y(), 0.5 * v.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, v / angle));
}

}  // namespace

Eigen::Quaterniond FromRollPitchYaw(double roll_rad, double pitch_rad, double yaw_rad) {
  return Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX());
}

Eigen::Vector3d RollPitchYaw_rad(const Eigen::Quaterniond& q_WB) {
  const Eigen::Matrix3d R = q_WB.normalized().toRotationMatrix();
  return {std::atan2(R(2, 1), R(2, 2)), std::asin(std::clamp(-R(2, 0), -1.0, 1.0)),
          std::atan2(R(1, 0), R(0, 0))};
}

Eigen::Quaterniond LevelFromSpecificForce(const Eigen::Vector3d& f_B_mps2, double yaw_rad) {
  // f_B = −g (−sin θ, sin φ cos θ, cos φ cos θ)
  const double roll_rad = std::atan2(-f_B_mps2.y(), -f_B_mps2.z());
  const double pitch_rad = std::atan2(f_B_mps2.x(), std::hypot(f_B_mps2.y(), f_B_mps2.z()));
  return FromRollPitchYaw(roll_rad, pitch_rad, yaw_rad);
}

double WrapToPi(double angle_rad) {
  const double wrapped = std::remainder(angle_rad, 2.0 * M_PI);
  return wrapped <= -M_PI ? wrapped + 2.0 * M_PI : wrapped;
}

AttitudeEstimator::AttitudeEstimator(const AttitudeEstimatorConfig& config) : config_(config) {
  config_.q_BI.normalize();
}

void AttitudeEstimator::InitializeFromAccelerometer(const ImuSample& sample, double yaw_rad) {
  Initialize(LevelFromSpecificForce(config_.q_BI * sample.f_I_mps2, yaw_rad), Eigen::Vector3d::Zero());
  previous_B_ = ImuSample{config_.q_BI * sample.f_I_mps2, config_.q_BI * sample.w_I_radps};
}

void AttitudeEstimator::Initialize(const Eigen::Quaterniond& q_WB,
                                   const Eigen::Vector3d& gyroscope_bias_B_radps,
                                   const Eigen::Vector3d& v_W_mps) {
  q_WB_ = q_WB.normalized();
  gyroscope_bias_B_radps_ = gyroscope_bias_B_radps;
  accelerometer_bias_B_mps2_.setZero();
  v_W_mps_ = v_W_mps;
  previous_B_.reset();
  const double tilt2 = config_.initial_tilt_sigma_rad * config_.initial_tilt_sigma_rad;
  P_.setZero();
  // the attitude error is in B: near level, its x and y are roll and pitch, its z yaw
  P_.diagonal() << tilt2, tilt2, config_.initial_yaw_sigma_rad * config_.initial_yaw_sigma_rad,
      Eigen::Vector3d::Constant(std::pow(config_.initial_gyroscope_bias_sigma_radps, 2)),
      Eigen::Vector3d::Constant(std::pow(config_.initial_accelerometer_bias_sigma_mps2, 2)),
      Eigen::Vector3d::Constant(std::pow(config_.initial_velocity_sigma_mps, 2));
  initialized_ = true;
}

void AttitudeEstimator::ThrowUnlessInitialized() const {
  if (!initialized_) throw std::logic_error("AttitudeEstimator: Initialize before the first update");
}

bool AttitudeEstimator::Update(const ImuSample& sample, double dt_s) {
  ThrowUnlessInitialized();
  if (!(dt_s > 0.0)) throw std::invalid_argument("AttitudeEstimator::Update: dt_s must be positive");
  const ImuNoise& noise = config_.imu_noise;

  // propagate: q ← q ⊗ Exp((ω − b_g)Δt); the error rotates back by that step and integrates −δb_g.
  // The rate at the step's end alone would be off by αΔt/2 (1 mrad/s at 0.4 rad/s² and 200 Hz), more
  // than the gyroscope bias the filter is after.
  const ImuSample measured_B{config_.q_BI * sample.f_I_mps2, config_.q_BI * sample.w_I_radps};
  const ImuSample& previous_B = previous_B_.value_or(measured_B);
  const Eigen::Vector3d w_B_radps =
      0.5 * (measured_B.w_I_radps + previous_B.w_I_radps) - gyroscope_bias_B_radps_;
  previous_B_ = measured_B;
  const Eigen::Quaterniond step = Exp(w_B_radps * dt_s);
  MatrixState F = MatrixState::Identity();
  F.block<3, 3>(0, 0) = step.toRotationMatrix().transpose();
  F.block<3, 3>(0, 3) = -dt_s * Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, kStates, 1> Q = Eigen::Matrix<double, kStates, 1>::Zero();
  Q.head<9>() << Eigen::Vector3d::Constant(std::pow(noise.gyroscope_noise_density, 2) * dt_s),
      Eigen::Vector3d::Constant(std::pow(noise.gyroscope_random_walk, 2) * dt_s),
      Eigen::Vector3d::Constant(std::pow(noise.accelerometer_random_walk, 2) * dt_s);
  if (config_.velocity_aided) {
    // v ← v + (R_WB(mid-step) (f − b_a) + g e3)Δt; δv gains −R[f]×δθ Δt − R δb_a Δt (Solà 2017)
    const Eigen::Vector3d f_B_mps2 =
        0.5 * (measured_B.f_I_mps2 + previous_B.f_I_mps2) - accelerometer_bias_B_mps2_;
    const Eigen::Matrix3d R_WB_mid = (q_WB_ * Exp(0.5 * w_B_radps * dt_s)).toRotationMatrix();
    v_W_mps_ += (R_WB_mid * f_B_mps2 + config_.gravity_mps2 * Eigen::Vector3d::UnitZ()) * dt_s;
    F.block<3, 3>(9, 0) = -dt_s * R_WB_mid * Skew(f_B_mps2);
    F.block<3, 3>(9, 6) = -dt_s * R_WB_mid;
    Q.tail<3>() = Eigen::Vector3d::Constant(std::pow(noise.accelerometer_noise_density, 2) * dt_s);
  }
  q_WB_ = (q_WB_ * step).normalized();
  P_ = F * P_ * F.transpose();
  P_.diagonal() += Q;
  if (config_.velocity_aided) return true;

  // correct with gravity: f_B = −g R_WBᵀ e3 + b_a; a perturbation δθ in B changes it by −g [R_WBᵀe3]× δθ
  if (std::fabs(measured_B.f_I_mps2.norm() - config_.gravity_mps2) > config_.acceleration_gate_mps2)
    return false;
  const Eigen::Vector3d down_B = q_WB_.conjugate() * Eigen::Vector3d::UnitZ();
  Eigen::Matrix<double, 3, kStates> H = Eigen::Matrix<double, 3, kStates>::Zero();
  H.block<3, 3>(0, 0) = -config_.gravity_mps2 * Skew(down_B);
  H.block<3, 3>(0, 6) = Eigen::Matrix3d::Identity();
  const double reading_variance_m2ps4 = std::pow(noise.accelerometer_noise_density, 2) / dt_s +
                                        std::pow(config_.acceleration_sigma_mps2, 2) *
                                            std::max(1.0, 2.0 * config_.acceleration_correlation_s / dt_s);
  Correct<3>(H, measured_B.f_I_mps2 - (-config_.gravity_mps2 * down_B + accelerometer_bias_B_mps2_),
             reading_variance_m2ps4 * Eigen::Matrix3d::Identity());
  return true;
}

void AttitudeEstimator::UpdateHeading(double yaw_rad, double sigma_rad) {
  ThrowUnlessInitialized();
  if (!(sigma_rad > 0.0)) {
    throw std::invalid_argument("AttitudeEstimator::UpdateHeading: sigma_rad must be positive");
  }
  // yaw rate from body rates: ψ̇ = (sin φ q + cos φ r)/cos θ
  const Eigen::Vector3d rpy = RollPitchYaw_rad(q_WB_);
  Eigen::Matrix<double, 1, kStates> H = Eigen::Matrix<double, 1, kStates>::Zero();
  H(0, 1) = std::sin(rpy.x()) / std::cos(rpy.y());
  H(0, 2) = std::cos(rpy.x()) / std::cos(rpy.y());
  Correct<1>(H, Eigen::Matrix<double, 1, 1>(WrapToPi(yaw_rad - rpy.z())),
             Eigen::Matrix<double, 1, 1>(sigma_rad * sigma_rad));
}

void AttitudeEstimator::UpdateVelocity(const Eigen::Vector3d& v_W_mps, double sigma_mps) {
  ThrowUnlessInitialized();
  if (!config_.velocity_aided) {
    throw std::logic_error("AttitudeEstimator::UpdateVelocity: the filter is not velocity_aided");
  }
  if (!(sigma_mps > 0.0)) {
    throw std::invalid_argument("AttitudeEstimator::UpdateVelocity: sigma_mps must be positive");
  }
  Eigen::Matrix<double, 3, kStates> H = Eigen::Matrix<double, 3, kStates>::Zero();
  H.block<3, 3>(0, 9) = Eigen::Matrix3d::Identity();
  Correct<3>(H, v_W_mps - v_W_mps_, sigma_mps * sigma_mps * Eigen::Matrix3d::Identity());
}

template <int kRows>
void AttitudeEstimator::Correct(const Eigen::Matrix<double, kRows, kStates>& H,
                                const Eigen::Matrix<double, kRows, 1>& residual,
                                const Eigen::Matrix<double, kRows, kRows>& R) {
  const Eigen::Matrix<double, kRows, kRows> S = H * P_ * H.transpose() + R;
  const Eigen::Matrix<double, kStates, kRows> K = P_ * H.transpose() * S.inverse();
  const Eigen::Matrix<double, kStates, 1> dx = K * residual;
  // Joseph form: stays symmetric and positive definite in long runs
  const MatrixState I_KH = MatrixState::Identity() - K * H;
  P_ = I_KH * P_ * I_KH.transpose() + K * R * K.transpose();
  q_WB_ = (q_WB_ * Exp(dx.head<3>())).normalized();
  gyroscope_bias_B_radps_ += dx.segment<3>(3);
  accelerometer_bias_B_mps2_ += dx.segment<3>(6);
  v_W_mps_ += dx.tail<3>();
}

AttitudeErrorStatistics::AttitudeErrorStatistics(double sample_interval_s) {
  if (!(sample_interval_s > 0.0)) return;
  samples_per_block_ = std::max<size_t>(1, static_cast<size_t>(std::lround(0.05 / sample_interval_s)));
  block_s_ = static_cast<double>(samples_per_block_) * sample_interval_s;
}

void AttitudeErrorStatistics::Add(const Eigen::Quaterniond& q_WB_estimate,
                                  const Eigen::Quaterniond& q_WB_true) {
  const Eigen::Vector3d estimate = RollPitchYaw_rad(q_WB_estimate);
  const Eigen::Vector3d truth = RollPitchYaw_rad(q_WB_true);
  Eigen::Vector3d error_rad;
  for (int axis = 0; axis < 3; ++axis) {
    error_rad[axis] = WrapToPi(estimate[axis] - truth[axis]);
    sum_of_squares_rad2_[axis] += error_rad[axis] * error_rad[axis];
    max_abs_rad_[axis] = std::max(max_abs_rad_[axis], std::fabs(error_rad[axis]));
  }
  ++count_;
  if (samples_per_block_ == 0) return;
  block_sum_rad_ += error_rad;
  if (++block_samples_ < samples_per_block_) return;
  block_means_rad_.push_back(block_sum_rad_ / static_cast<double>(block_samples_));
  block_sum_rad_.setZero();
  block_samples_ = 0;
}

Eigen::Vector3d AttitudeErrorStatistics::CorrelationTime_s() const {
  Eigen::Vector3d tau_s = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const size_t n = block_means_rad_.size();
  if (samples_per_block_ == 0 || static_cast<double>(n) * block_s_ < 1.0) return tau_s;
  const size_t max_lag = std::min(n / 2, static_cast<size_t>(30.0 / block_s_));
  const double threshold = std::exp(-1.0);
  for (int axis = 0; axis < 3; ++axis) {
    double mean = 0.0;
    for (const Eigen::Vector3d& e : block_means_rad_) mean += e[axis];
    mean /= static_cast<double>(n);
    std::vector<double> x(n);
    for (size_t i = 0; i < n; ++i) x[i] = block_means_rad_[i][axis] - mean;
    double variance = 0.0;
    for (double v : x) variance += v * v;
    if (!(variance > 0.0)) continue;
    // the biased estimator (divided by the whole sum at every lag), the usual one: it stays a valid
    // autocorrelation and errs less at long lags
    double previous = 1.0;
    for (size_t lag = 1; lag <= max_lag; ++lag) {
      double sum = 0.0;
      for (size_t i = 0; i + lag < n; ++i) sum += x[i] * x[i + lag];
      const double r = sum / variance;
      if (r < threshold) {
        tau_s[axis] = block_s_ * (static_cast<double>(lag - 1) + (previous - threshold) / (previous - r));
        break;
      }
      previous = r;
    }
  }
  return tau_s;
}

Eigen::Vector3d AttitudeErrorStatistics::RootMeanSquare_rad() const {
  if (count_ == 0) return Eigen::Vector3d::Zero();
  return (sum_of_squares_rad2_ / static_cast<double>(count_)).cwiseSqrt();
}

}  // namespace iapsim::sensors
