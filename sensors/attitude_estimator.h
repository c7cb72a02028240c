#pragma once
// An attitude EKF like a flight controller's (seed §VI-G, Fig. 18): a multiplicative (error-state) EKF on
// the body attitude with gyroscope and accelerometer bias states, propagated with the gyroscope and
// corrected with the accelerometer as a gravity reference. Yaw is not observable from gravity: it starts at
// a given heading (the truth, in simulation), then follows the gyroscope and drifts with its z-bias, unless
// heading measurements (a magnetometer's, or HeadingSensor's) are fed in.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <optional>
#include <vector>

#include "sensors/imu.h"

namespace iapsim::sensors {

struct AttitudeEstimatorConfig {
  ImuNoise imu_noise = TableViNoise();  ///< the noise the filter assumes (by default the simulated IMU's)
  Eigen::Quaterniond q_BI = Eigen::Quaterniond::Identity();  ///< IMU mounting: readings are rotated into B
  double gravity_mps2 = 9.81;
  /// Standard deviations of the initial state.
  double initial_tilt_sigma_rad = 5.0 * M_PI / 180.0;  ///< roll and pitch
  double initial_yaw_sigma_rad = 10.0 * M_PI / 180.0;
  double initial_gyroscope_bias_sigma_radps = 0.01;
  double initial_accelerometer_bias_sigma_mps2 = 0.2;
  /// Linear acceleration also moves the accelerometer: it is treated as extra white noise of this standard
  /// deviation, and readings whose magnitude is further than acceleration_gate_mps2 from g are not used.
  double acceleration_sigma_mps2 = 0.5;
  double acceleration_gate_mps2 = 2.0;
};

/// R_WB = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Quaterniond FromRollPitchYaw(double roll_rad, double pitch_rad, double yaw_rad);
/// Roll, pitch, yaw (rad) of R_WB = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Vector3d RollPitchYaw_rad(const Eigen::Quaterniond& q_WB);
/// The attitude whose specific force at rest, −g R_WBᵀ e₃, points along f_B, at the given yaw (rad): the
/// roll and pitch a flight controller aligns to on the ground.
Eigen::Quaterniond LevelFromSpecificForce(const Eigen::Vector3d& f_B_mps2, double yaw_rad);
/// The angle in (−π, π].
double WrapToPi(double angle_rad);

class AttitudeEstimator {
 public:
  using Matrix9d = Eigen::Matrix<double, 9, 9>;

  explicit AttitudeEstimator(const AttitudeEstimatorConfig& config);

  /// Roll and pitch from one accelerometer reading of the body at rest (f_B = −g R_WBᵀ e3), yaw as given,
  /// biases zero.
  void InitializeFromAccelerometer(const ImuSample& sample, double yaw_rad);
  /// A given attitude and gyroscope bias (in B), accelerometer bias zero; covariance from the config.
  void Initialize(const Eigen::Quaterniond& q_WB, const Eigen::Vector3d& gyroscope_bias_B_radps);
  bool initialized() const { return initialized_; }

  /// One IMU reading dt_s after the previous one: propagates with the mean of its angular rate and the
  /// previous one (the rate at mid-step, to second order), then corrects with its specific force. Returns
  /// false when the correction was gated out (the body was accelerating).
  bool Update(const ImuSample& sample, double dt_s);
  /// Corrects with a measured yaw (rad) of standard deviation sigma_rad.
  void UpdateHeading(double yaw_rad, double sigma_rad);

  const Eigen::Quaterniond& q_WB() const { return q_WB_; }
  const Eigen::Vector3d& gyroscope_bias_B_radps() const { return gyroscope_bias_B_radps_; }
  const Eigen::Vector3d& accelerometer_bias_B_mps2() const { return accelerometer_bias_B_mps2_; }
  /// Of the error state (attitude error in B as a rotation vector, gyroscope bias, accelerometer bias).
  const Matrix9d& covariance() const { return P_; }

 private:
  void ThrowUnlessInitialized() const;
  template <int kRows>
  void Correct(const Eigen::Matrix<double, kRows, 9>& H, const Eigen::Matrix<double, kRows, 1>& residual,
               const Eigen::Matrix<double, kRows, kRows>& R);

  AttitudeEstimatorConfig config_;
  bool initialized_ = false;
  Eigen::Quaterniond q_WB_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d gyroscope_bias_B_radps_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d accelerometer_bias_B_mps2_ = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> previous_w_B_radps_;  ///< the last measured rate, in B (bias included)
  Matrix9d P_ = Matrix9d::Zero();
};

/// Roll, pitch and yaw errors of an estimate against the truth, over many samples.
class AttitudeErrorStatistics {
 public:
  /// With the time between Adds (> 0), it also keeps the errors' 50 ms means for CorrelationTime_s.
  explicit AttitudeErrorStatistics(double sample_interval_s = 0.0);

  void Add(const Eigen::Quaterniond& q_WB_estimate, const Eigen::Quaterniond& q_WB_true);
  size_t count() const { return count_; }
  /// Root mean square of the (wrapped) roll, pitch and yaw differences; zero before the first Add.
  Eigen::Vector3d RootMeanSquare_rad() const;
  Eigen::Vector3d MaxAbs_rad() const { return max_abs_rad_; }
  /// How long each axis's error persists: the lag at which its autocorrelation (mean removed; over the
  /// 50 ms means) first falls to 1/e, interpolated between lags; the time constant of a first-order
  /// Gauss-Markov error. A consumer that weighs samples as independent must know it (vio's
  /// virpo.attitude_correlation_s). NaN where it does not fall to 1/e within 30 s or half the run, or
  /// with under 1 s of errors or no sample interval.
  Eigen::Vector3d CorrelationTime_s() const;

 private:
  size_t count_ = 0;
  Eigen::Vector3d sum_of_squares_rad2_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_abs_rad_ = Eigen::Vector3d::Zero();
  size_t samples_per_block_ = 0;  ///< 0: no series kept
  double block_s_ = 0.0;
  Eigen::Vector3d block_sum_rad_ = Eigen::Vector3d::Zero();
  size_t block_samples_ = 0;
  std::vector<Eigen::Vector3d> block_means_rad_;
};

}  // namespace iapsim::sensors
