#pragma once
// An attitude EKF like a flight controller's (seed §VI-G, Fig. 18): a multiplicative (error-state) EKF on
// the body attitude with gyroscope and accelerometer bias states (Solà, "Quaternion kinematics for the
// error-state Kalman filter", 2017), propagated with the gyroscope. Two ways to see the tilt:
// - unaided: the accelerometer as a gravity reference, the body's own acceleration taken as noise. A
//   vehicle's sustained accelerations then read as tilt (a multirotor's accelerometer sees its thrust, not
//   gravity), and the bias states take up what the noise model cannot explain;
// - velocity-aided (`velocity_aided`): an inertial navigation filter, as PX4's EKF2 fusing an external
//   velocity (the seed's flight controllers fuse VIO positioning, §VI): the accelerometer is integrated into
//   a velocity state that the measured velocity corrects, so acceleration and tilt are told apart.
// Yaw is not observable from gravity: it starts at a given heading (the truth, in simulation), then follows
// the gyroscope and drifts with its z-bias, unless heading measurements (a magnetometer's, or
// HeadingSensor's) are fed in (or, velocity-aided, while the body accelerates horizontally).

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
  /// Unaided, the body's own acceleration also moves the accelerometer: it is taken as noise of this
  /// standard deviation, correlated over acceleration_correlation_s. Readings Δt apart see the same
  /// acceleration, so each counts as the time slice since the one before: variance σ² · max(1, 2τ/Δt),
  /// which over a span T ≫ τ gives the variance of the acceleration's mean, σ² 2τ/T, for a first-order
  /// Gauss-Markov process (as vio's virpo.attitude_correlation_s weighs this filter's attitudes). Taken
  /// as white (τ 0), its sustained accelerations pull the tilt and, through it, the gyroscope biases: yaw
  /// then drifts far beyond the filter's own uncertainty (sensors/README.md). Defaults: the horizontal
  /// accelerations of the seed's flights as iapsim flies them, 0.1-0.4 m/s² standard deviation over
  /// 0.2-3 s. Readings whose magnitude is further than acceleration_gate_mps2 from g are not used.
  double acceleration_sigma_mps2 = 0.5;
  double acceleration_correlation_s = 1.0;
  double acceleration_gate_mps2 = 2.0;
  /// Fed velocity measurements (UpdateVelocity) instead of the gravity reference.
  bool velocity_aided = false;
  double initial_velocity_sigma_mps = 0.5;  ///< velocity-aided: about the initial velocity
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
  /// The error state: attitude error in B as a rotation vector, gyroscope bias, accelerometer bias, and
  /// velocity in W (velocity-aided; unaided it is not tracked and keeps its initial variance).
  static constexpr int kStates = 12;
  using MatrixState = Eigen::Matrix<double, kStates, kStates>;

  explicit AttitudeEstimator(const AttitudeEstimatorConfig& config);

  /// Roll and pitch from one accelerometer reading of the body at rest (f_B = −g R_WBᵀ e3), yaw as given,
  /// biases and velocity zero.
  void InitializeFromAccelerometer(const ImuSample& sample, double yaw_rad);
  /// A given attitude, gyroscope bias (in B) and velocity, accelerometer bias zero; covariance from the
  /// config.
  void Initialize(const Eigen::Quaterniond& q_WB, const Eigen::Vector3d& gyroscope_bias_B_radps,
                  const Eigen::Vector3d& v_W_mps = Eigen::Vector3d::Zero());
  bool initialized() const { return initialized_; }

  /// One IMU reading dt_s after the previous one: propagates with the mean of its reading and the previous
  /// one (the value at mid-step, to second order); unaided, then corrects with its specific force. Returns
  /// false when that correction was gated out (the body was accelerating); velocity-aided, true.
  bool Update(const ImuSample& sample, double dt_s);
  /// Corrects with a measured yaw (rad) of standard deviation sigma_rad.
  void UpdateHeading(double yaw_rad, double sigma_rad);
  /// Velocity-aided: corrects with a measured velocity of the IMU in W, each axis of standard deviation
  /// sigma_mps. Throws std::logic_error on an unaided filter.
  void UpdateVelocity(const Eigen::Vector3d& v_W_mps, double sigma_mps);

  const Eigen::Quaterniond& q_WB() const { return q_WB_; }
  const Eigen::Vector3d& gyroscope_bias_B_radps() const { return gyroscope_bias_B_radps_; }
  const Eigen::Vector3d& accelerometer_bias_B_mps2() const { return accelerometer_bias_B_mps2_; }
  /// Velocity-aided: of the IMU in W.
  const Eigen::Vector3d& v_W_mps() const { return v_W_mps_; }
  /// Of the error state (kStates).
  const MatrixState& covariance() const { return P_; }

 private:
  void ThrowUnlessInitialized() const;
  template <int kRows>
  void Correct(const Eigen::Matrix<double, kRows, kStates>& H,
               const Eigen::Matrix<double, kRows, 1>& residual, const Eigen::Matrix<double, kRows, kRows>& R);

  AttitudeEstimatorConfig config_;
  bool initialized_ = false;
  Eigen::Quaterniond q_WB_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d gyroscope_bias_B_radps_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d accelerometer_bias_B_mps2_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W_mps_ = Eigen::Vector3d::Zero();
  std::optional<ImuSample> previous_B_;  ///< the last reading, rotated into B (biases included)
  MatrixState P_ = MatrixState::Zero();
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
