#pragma once
// The IMU of the seed paper §V-D (AirSim's model): specific force and angular rate of the IMU frame I from
// the true body kinematics, plus Gaussian white noise and a bias that random-walks, per axis, for the
// gyroscope and the accelerometer. Noise is stated as continuous-time densities (Kalibr's convention);
// TableViNoise() gives the paper's Table VI values (see sensors/README.md for how they map).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <random>

namespace iapsim::sensors {

/// The true motion of a rigid body B at one instant (W is NED, B is FRD).
struct BodyKinematics {
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_WB_B_radps = Eigen::Vector3d::Zero();       ///< angular velocity of B in W, in B
  Eigen::Vector3d alpha_WB_B_radps2 = Eigen::Vector3d::Zero();  ///< its time derivative, in B
  Eigen::Vector3d a_WB_W_mps2 = Eigen::Vector3d::Zero();        ///< acceleration of B's origin in W, in W
};

/// Continuous-time noise of an IMU (Kalibr's imu.yaml). A sample Δt apart has white noise of standard
/// deviation density/√Δt and a bias that steps by random_walk·√Δt (both per axis, Gaussian).
struct ImuNoise {
  double gyroscope_noise_density = 0.0;      ///< rad/s/√Hz
  double gyroscope_random_walk = 0.0;        ///< rad/s²/√Hz
  double accelerometer_noise_density = 0.0;  ///< m/s²/√Hz
  double accelerometer_random_walk = 0.0;    ///< m/s³/√Hz
};

/// The rate at which Table VI gives per-sample standard deviations (§VI-G: the sensors ran at 200 Hz).
constexpr double kTableViRate_hz = 200.0;

/// Table VI as densities: r_a = density/√(1/200 s) and r_b = random_walk·√(1/200 s), with r the standard
/// deviation per 200 Hz sample. At 200 Hz the simulated IMU reproduces the table exactly.
ImuNoise TableViNoise();

struct ImuConfig {
  ImuNoise noise = TableViNoise();
  double rate_hz = kTableViRate_hz;  ///< for the caller's schedule; the model itself takes Δt per sample
  Eigen::Vector3d p_BI_m = Eigen::Vector3d::Zero();  ///< IMU origin in B
  Eigen::Quaterniond q_BI = Eigen::Quaterniond::Identity();
  double gravity_mps2 = 9.81;  ///< along +z of W (NED)
  /// Initial biases: the mean plus a Gaussian draw of the given standard deviation per axis.
  Eigen::Vector3d initial_gyroscope_bias_radps = Eigen::Vector3d::Zero();
  double initial_gyroscope_bias_sigma_radps = 0.0;
  Eigen::Vector3d initial_accelerometer_bias_mps2 = Eigen::Vector3d::Zero();
  double initial_accelerometer_bias_sigma_mps2 = 0.0;
  uint64_t seed_offset = 0;  ///< added to the seed given to ImuModel: another draw of this IMU's noise
};

/// One IMU reading, in the IMU frame I (FRD when mounted level: at rest f_I = (0, 0, −g)).
struct ImuSample {
  Eigen::Vector3d f_I_mps2 = Eigen::Vector3d::Zero();   ///< specific force (acceleration minus gravity)
  Eigen::Vector3d w_I_radps = Eigen::Vector3d::Zero();  ///< angular velocity of I in W
};

/// The noise-free reading of an IMU at p_BI_m with orientation q_BI on body B: the acceleration of the IMU
/// point (B's origin plus the Euler α×r and centripetal ω×(ω×r) terms) minus gravity, and ω, both in I.
ImuSample IdealImuSample(const BodyKinematics& truth, const Eigen::Vector3d& p_BI_m,
                         const Eigen::Quaterniond& q_BI, double gravity_mps2);

/// A noisy IMU with its own seeded random stream: the same seed and inputs give the same samples.
class ImuModel {
 public:
  ImuModel(const ImuConfig& config, uint64_t seed);

  /// The reading `dt_s` after the previous one (dt_s > 0): each bias first takes its random-walk step
  /// (b_t = b_{t−1} + η_b, as in §V-D), then the reading is the ideal one plus bias plus white noise.
  ImuSample Sample(const BodyKinematics& truth, double dt_s);
  /// The gyroscope alone, `dt_s` after the previous reading, for a consumer that reads no specific force
  /// (a flight controller's rate loop): its bias walks and its white noise as in Sample, the accelerometer's
  /// left untouched. `w_WB_B_radps` is B's angular velocity in B; the reading is in I.
  Eigen::Vector3d SampleGyroscope(const Eigen::Vector3d& w_WB_B_radps, double dt_s);

  /// A flight controller's IMU, whose readings its estimator takes as means over integration intervals (a
  /// delta velocity and a delta angle over each, divided by it, as PX4's vehicle_imu integrates at
  /// IMU_INTEG_RATE) while its rate loop takes every gyroscope reading: within an interval, a gyroscope
  /// reading with its white noise on the bias as it stands;
  Eigen::Vector3d SampleGyroscopeInInterval(const Eigen::Vector3d& w_WB_B_radps, double dt_s);
  /// at the interval's end, both biases take the interval's random-walk step (its variance exact, the
  /// biases held within it: they drift over minutes), and the accelerometer's reading is the mean of its
  /// readings over the interval, whose white noise has σ/√T. `f_B_mps2` is the true specific force at I
  /// averaged over the interval, in B; the reading is in I.
  Eigen::Vector3d EndInterval(const Eigen::Vector3d& f_B_mps2, double interval_s);

  /// The biases in the last sample (in I).
  const Eigen::Vector3d& gyroscope_bias_radps() const { return gyroscope_bias_radps_; }
  const Eigen::Vector3d& accelerometer_bias_mps2() const { return accelerometer_bias_mps2_; }

 private:
  ImuConfig config_;
  std::mt19937_64 random_;
  Eigen::Vector3d gyroscope_bias_radps_;
  Eigen::Vector3d accelerometer_bias_mps2_;
};

}  // namespace iapsim::sensors
