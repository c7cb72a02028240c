#pragma once
// The platform's pose and twist as an onboard odometry reports them: what an IAP computer flies on outside a
// motion-capture hall (the seed's real flights: positioning at 200 Hz from multi-agent visual-inertial
// localisation, §VI, refs [62], [63]). Two kinds of error, each per axis and seeded:
//  - drift: random walks of position (in W) and of yaw (about W's z), the four directions visual-inertial
//    odometry cannot observe (Hesch et al., "Consistency analysis and improvement of vision-aided inertial
//    navigation", IEEE T-RO 30(1), 2014; VINS-Mono's 4-DOF pose graph). Roll and pitch see gravity, so they
//    do not drift. The seed's Table IX states its VIO drift as continuous σ of position and yaw.
//  - noise: first-order Gauss–Markov errors (stationary σ, a correlation time; white when it is 0) on
//    position, attitude (a small rotation in the body frame) and velocity; white noise on the angular rate,
//    given as the gyroscope's density (what the estimate's rate is: the bias-corrected gyroscope).
// It is a model of the estimate's errors, not an estimator: VIO itself is issue 16's (vio/).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <random>

namespace iapsim::sensors {

struct OdometryNoise {
  double position_sigma_m = 0.0;             ///< Gauss–Markov σ per W axis
  double attitude_sigma_rad = 0.0;           ///< Gauss–Markov σ per body axis
  double velocity_sigma_mps = 0.0;           ///< Gauss–Markov σ per body axis
  double correlation_time_s = 0.0;           ///< of those three; 0: independent per sample
  double angular_rate_noise_density = 0.0;   ///< rad/s/√Hz, white per body axis
  double position_drift_m_per_sqrt_s = 0.0;  ///< random walk per W axis
  double yaw_drift_rad_per_sqrt_s = 0.0;     ///< random walk about W's z
};

struct OdometryConfig {
  OdometryNoise noise;
  double rate_hz = 200.0;  ///< for the caller's schedule (the seed's positioning rate)
  /// The sensors process replaces the model's roll, pitch and rate with the platform's own IMU and attitude
  /// EKF (its platform_imu), as an IAP computer fusing its odometry with its IMU would report them; the
  /// position, velocity and yaw (with its drift) stay the model's.
  bool attitude_from_platform_imu = false;
};

/// A body's pose in W and its twist in its own frame B (nav_msgs/Odometry's convention).
struct OdometryState {
  Eigen::Vector3d p_WB_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_WB_B_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_WB_B_radps = Eigen::Vector3d::Zero();
};

class OdometryModel {
 public:
  OdometryModel(const OdometryConfig& config, uint64_t seed);

  /// The estimate of `truth`, `dt_s` after the previous sample (dt_s > 0; the first sample starts the
  /// drift at zero and draws the Gauss–Markov errors from their stationary distribution):
  /// p̂ = p + d_p + e_p, q̂ = R_z(ψ_d)·q·Exp(e_θ), v̂ = v + e_v, ω̂ = ω + n_ω.
  OdometryState Sample(const OdometryState& truth, double dt_s);

  const Eigen::Vector3d& position_drift_W_m() const { return drift_W_m_; }
  double yaw_drift_rad() const { return yaw_drift_rad_; }
  const OdometryConfig& config() const { return config_; }

 private:
  // one Gauss–Markov step of `error` (stationary σ), exact for any dt
  void Correlate(Eigen::Vector3d* error, double sigma, double dt_s);

  OdometryConfig config_;
  std::mt19937_64 random_;
  bool started_ = false;
  Eigen::Vector3d drift_W_m_ = Eigen::Vector3d::Zero();
  double yaw_drift_rad_ = 0.0;
  Eigen::Vector3d position_error_W_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d attitude_error_B_rad_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_error_B_mps_ = Eigen::Vector3d::Zero();
};

}  // namespace iapsim::sensors
