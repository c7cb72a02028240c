#pragma once
// A flight controller's own attitude estimate: Mahony's explicit complementary filter on SO(3) with a
// gyroscope bias (Mahony, Hamel & Pflimlin, "Nonlinear complementary filters on the special orthogonal
// group", IEEE TAC 53(5), 2008, eq. 32), in the form PX4's attitude_estimator_q runs it, with PX4's
// weights as defaults:
//   q̇ = ½ q ⊗ (ω_m − b̂ + ω_c),  b̂̇ = −k_b ω_c (only while |ω_m| < 10°/s),
//   ω_c = k_a (m × v̂) + k_h (ψ_m − ψ̂) R̂ᵀe₃,
// where v̂ = R̂ᵀe₃ is the estimated and m the measured down direction in B, ψ the yaw. m comes from the
// accelerometer less the motion acceleration differenced from an aiding velocity (PX4's ATT_ACC_COMP):
// without that, a multirotor's accelerometer reads its thrust axis, not gravity, and the filter would level a
// vehicle that is tilted to hold a lateral force. Unlike AttitudeEstimator (the sensors process's EKF, 9
// states), it costs a few dozen operations per sample or interval.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>

namespace iapsim::sensors {

/// PX4's attitude_estimator_q parameters, with their names and the defaults of its parameter file.
struct ComplementaryFilterGains {
  double accelerometer_weight_per_s = 0.2;      ///< ATT_W_ACC
  double heading_weight_per_s = 0.1;            ///< ATT_W_EXT_HDG (and ATT_W_MAG)
  double gyroscope_bias_weight_per_s = 0.1;     ///< ATT_W_GYRO_BIAS
  double max_gyroscope_bias_radps = 0.05;       ///< ATT_BIAS_MAX
  double bias_learning_max_rate_radps = 0.175;  ///< above 10°/s the bias is held
};

class ComplementaryAttitudeFilter {
 public:
  /// Throws std::invalid_argument for a negative weight or a gravity that is not positive.
  ComplementaryAttitudeFilter(const ComplementaryFilterGains& gains, double gravity_mps2);

  /// Starts at this attitude and gyroscope bias (in B), with no aiding velocity or heading yet.
  void Initialize(const Eigen::Quaterniond& q_WB, const Eigen::Vector3d& gyroscope_bias_B_radps);
  bool initialized() const { return initialized_; }

  /// A velocity of the IMU (m/s, in W) measured at t_s: the difference with the previous one is the
  /// motion acceleration the accelerometer correction removes, held (in W) until the next. Before the
  /// second one, and after one with t_s not later than the previous, it is taken as zero.
  void UpdateVelocity(const Eigen::Vector3d& v_W_mps, double t_s);
  /// A measured yaw (rad, Z-Y-X Euler angles), one of a series interval_s apart: the heading term of ω_c
  /// over that interval, applied at once. (Held and applied at every Update, a heading lags the estimate
  /// by half an interval while the body yaws: 0.6° at 0.2 rad/s and 10 Hz.)
  void UpdateHeading(double yaw_rad, double interval_s);

  /// One gyroscope (rad/s) and accelerometer (specific force, m/s²) reading in B, dt_s after the previous:
  /// a sample, or the means over an integration interval of dt_s (PX4's IMU_INTEG_RATE).
  void Update(const Eigen::Vector3d& w_B_radps, const Eigen::Vector3d& f_B_mps2, double dt_s);
  /// Between two Updates on interval means: the attitude reported turns by each gyroscope sample less the
  /// bias (a predictor at the gyroscope's rate); the next Update starts from the last one's estimate, the
  /// samples being in its interval's mean.
  void Propagate(const Eigen::Vector3d& w_B_radps, double dt_s);

  /// The attitude: the last Update's, turned by the samples Propagate took since.
  const Eigen::Quaterniond& q_WB() const { return q_reported_WB_; }
  const Eigen::Vector3d& gyroscope_bias_B_radps() const { return gyroscope_bias_B_radps_; }
  const Eigen::Vector3d& motion_acceleration_W_mps2() const { return a_W_mps2_; }

 private:
  // the bias integrates −k_b ω_c dt while the body turns slower than bias_learning_max_rate_radps
  void LearnBias(const Eigen::Vector3d& correction_B_rad);
  void Turn(const Eigen::Vector3d& angle_B_rad);  // the estimate, and the attitude reported with it

  ComplementaryFilterGains gains_;
  double gravity_mps2_;
  bool initialized_ = false;
  Eigen::Quaterniond q_WB_ = Eigen::Quaterniond::Identity();           ///< as of the last Update
  Eigen::Quaterniond q_reported_WB_ = Eigen::Quaterniond::Identity();  ///< q_WB_ propagated since
  Eigen::Vector3d gyroscope_bias_B_radps_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_W_mps2_ = Eigen::Vector3d::Zero();
  std::optional<std::pair<Eigen::Vector3d, double>> previous_velocity_;  ///< v_W (m/s), t (s)
  double last_rate_radps_ = 0.0;                                         ///< |ω_m| of the last Update
};

}  // namespace iapsim::sensors
