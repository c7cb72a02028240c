#include "sensors/attitude_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "sensors/heading_sensor.h"
#include "sensors/imu.h"

namespace iapsim::sensors {
namespace {

constexpr double kDt = 0.005;  // 200 Hz, the seed's IMU rate
constexpr double kDeg = M_PI / 180.0;
// an error "within the filter's own uncertainty" is within this many of its standard deviations (over 100
// seeds the worst was 3.0)
constexpr double kSigmas = 3.5;

// A body turning about its fixed origin with body rates whose frequencies stay away from the yaw rate, so
// that its tilt stays bounded (below 40° here).
class TumblingBody {
 public:
  const BodyKinematics& truth() const { return truth_; }
  double t_s() const { return t_s_; }
  void Step(double dt_s) {
    const Eigen::Vector3d w_mid_B_radps = Rate(t_s_ + 0.5 * dt_s);  // never zero: its z is constant
    truth_.q_WB = (truth_.q_WB * Eigen::AngleAxisd(w_mid_B_radps.norm() * dt_s, w_mid_B_radps.normalized()))
                      .normalized();
    t_s_ += dt_s;
    truth_.w_WB_B_radps = Rate(t_s_);
    truth_.alpha_WB_B_radps2 = {0.44 * std::cos(1.1 * t_s_), -0.24 * std::sin(0.8 * t_s_), 0.0};
  }

 private:
  static Eigen::Vector3d Rate(double t) { return {0.4 * std::sin(1.1 * t), 0.3 * std::cos(0.8 * t), 0.25}; }
  BodyKinematics truth_{FromRollPitchYaw(0.1, -0.05, 0.3), Rate(0.0), Eigen::Vector3d(0.44, 0.0, 0.0),
                        Eigen::Vector3d::Zero()};
  double t_s_ = 0.0;
};

ImuConfig BiasedImu() {
  ImuConfig config;  // Table VI noise
  config.initial_gyroscope_bias_radps = {0.01, -0.008, 0.005};
  return config;
}

TEST(AttitudeEstimator, RollPitchYawRoundTripsAndWraps) {
  const Eigen::Vector3d rpy = RollPitchYaw_rad(FromRollPitchYaw(0.3, -0.4, 2.9));
  EXPECT_LT((rpy - Eigen::Vector3d(0.3, -0.4, 2.9)).norm(), 1e-12);
  EXPECT_NEAR(WrapToPi(3.0 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(WrapToPi(-M_PI), M_PI, 1e-12);
  EXPECT_NEAR(WrapToPi(-0.5 - 4.0 * M_PI), -0.5, 1e-12);
}

TEST(AttitudeEstimator, InitialisesRollAndPitchFromTheAccelerometer) {
  BodyKinematics truth;
  truth.q_WB = FromRollPitchYaw(0.3, -0.2, 0.0);
  const ImuSample sample =
      IdealImuSample(truth, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), 9.81);
  AttitudeEstimator estimator{AttitudeEstimatorConfig()};
  EXPECT_FALSE(estimator.initialized());
  EXPECT_THROW(estimator.Update(sample, kDt), std::logic_error);
  estimator.InitializeFromAccelerometer(sample, 1.2);
  EXPECT_LT((RollPitchYaw_rad(estimator.q_WB()) - Eigen::Vector3d(0.3, -0.2, 1.2)).norm(), 1e-12);
}

// A minute at rest (roll 5°, pitch −3°, yaw 30°), the estimator started 15° off in roll and −10° in pitch.
struct StaticRun {
  Eigen::Vector3d error_rad;       ///< roll, pitch, yaw
  Eigen::Vector2d tilt_sigma_rad;  ///< the filter's, about W's x and y (about B's axes, yaw would leak in)
  Eigen::Vector3d f_error_B_mps2;  ///< the predicted reading −g R̂ᵀe3 + b̂_a against the true −g Rᵀe3 + b_a
  Eigen::Vector2d gyroscope_bias_error_radps;  ///< x and y
  Eigen::Vector2d gyroscope_bias_sigma_radps;
};

StaticRun RunStatic(const ImuConfig& imu_config, const AttitudeEstimatorConfig& estimator_config,
                    uint64_t seed) {
  ImuModel imu(imu_config, seed);
  BodyKinematics truth;
  truth.q_WB = FromRollPitchYaw(5 * kDeg, -3 * kDeg, 30 * kDeg);
  AttitudeEstimator estimator(estimator_config);
  estimator.Initialize(truth.q_WB * FromRollPitchYaw(15 * kDeg, -10 * kDeg, 0.0), Eigen::Vector3d::Zero());
  for (int k = 0; k < static_cast<int>(60.0 / kDt); ++k) estimator.Update(imu.Sample(truth, kDt), kDt);
  const double g = imu_config.gravity_mps2;
  StaticRun run;
  run.error_rad = RollPitchYaw_rad(estimator.q_WB()) - RollPitchYaw_rad(truth.q_WB);
  const Eigen::Matrix3d R_WB = estimator.q_WB().toRotationMatrix();
  run.tilt_sigma_rad = (R_WB * estimator.covariance().topLeftCorner<3, 3>() * R_WB.transpose())
                           .diagonal()
                           .head<2>()
                           .cwiseSqrt();
  run.f_error_B_mps2 =
      (-g * (estimator.q_WB().conjugate() * Eigen::Vector3d::UnitZ()) +
       estimator.accelerometer_bias_B_mps2()) -
      (-g * (truth.q_WB.conjugate() * Eigen::Vector3d::UnitZ()) + imu.accelerometer_bias_mps2());
  run.gyroscope_bias_error_radps =
      (estimator.gyroscope_bias_B_radps() - imu.gyroscope_bias_radps()).head<2>();
  run.gyroscope_bias_sigma_radps = estimator.covariance().diagonal().segment<2>(3).cwiseSqrt();
  std::printf(
      "static: roll error %.3f deg, pitch error %.3f deg (filter sigma %.3f, %.3f); reading error %.3f m/s2; "
      "gyro bias error %.1e %.1e rad/s (filter sigma %.1e %.1e)\n",
      run.error_rad.x() / kDeg, run.error_rad.y() / kDeg, run.tilt_sigma_rad.x() / kDeg,
      run.tilt_sigma_rad.y() / kDeg, run.f_error_B_mps2.norm(), run.gyroscope_bias_error_radps.x(),
      run.gyroscope_bias_error_radps.y(), run.gyroscope_bias_sigma_radps.x(),
      run.gyroscope_bias_sigma_radps.y());
  return run;
}

// The horizontal gyroscope biases (10 and −8 mrad/s) are observable at rest (the vertical one needs a heading
// or motion): found within the filter's uncertainty, which has come down from 10 to about 1 mrad/s.
void ExpectHorizontalGyroscopeBiasFound(const StaticRun& run) {
  for (int axis = 0; axis < 2; ++axis) {
    EXPECT_LT(run.gyroscope_bias_sigma_radps[axis], 1.5e-3);
    EXPECT_LT(std::fabs(run.gyroscope_bias_error_radps[axis]),
              kSigmas * run.gyroscope_bias_sigma_radps[axis]);
  }
}

TEST(AttitudeEstimator, ConvergesToTheTrueTiltOfAStaticImuFromAWrongStart) {
  // Table VI noise with a steady accelerometer bias that the filter knows to be small: nothing hides the tilt
  ImuConfig imu = BiasedImu();
  imu.noise.accelerometer_random_walk = 0.0;
  AttitudeEstimatorConfig config;
  config.imu_noise = imu.noise;
  config.initial_accelerometer_bias_sigma_mps2 = 0.01;
  const StaticRun run = RunStatic(imu, config, 31);
  EXPECT_LT(std::fabs(run.error_rad.x()), 0.75 * kDeg);  // the filter's σ is 0.18°; 100 seeds: at most 0.56°
  EXPECT_LT(std::fabs(run.error_rad.y()), 0.75 * kDeg);
  ExpectHorizontalGyroscopeBiasFound(run);
}

TEST(AttitudeEstimator, AtRestWithTableViNoiseTheTiltIsKnownUpToTheAccelerometerBias) {
  // at rest, gravity cannot tell a tilt from a horizontal accelerometer bias, and Table VI's walks about
  // 0.15 m/s² (0.9°) a minute: the filter finds the reading they make together, and its own uncertainty
  // covers how the two are split
  const StaticRun run = RunStatic(BiasedImu(), AttitudeEstimatorConfig(), 31);
  EXPECT_LT(run.f_error_B_mps2.norm(), 0.15);
  EXPECT_LT(std::fabs(run.error_rad.x()), kSigmas * run.tilt_sigma_rad.x());
  EXPECT_LT(std::fabs(run.error_rad.y()), kSigmas * run.tilt_sigma_rad.y());
  ExpectHorizontalGyroscopeBiasFound(run);
}

// The filter's own standard deviation of its yaw error (the heading update's Jacobian applied to P).
double YawSigma_rad(const AttitudeEstimator& estimator) {
  const Eigen::Vector3d rpy = RollPitchYaw_rad(estimator.q_WB());
  const Eigen::Vector3d dyaw_dtheta(0.0, std::sin(rpy.x()) / std::cos(rpy.y()),
                                    std::cos(rpy.x()) / std::cos(rpy.y()));
  return std::sqrt(dyaw_dtheta.dot(estimator.covariance().topLeftCorner<3, 3>() * dyaw_dtheta));
}

struct TumblingFlight {
  AttitudeErrorStatistics settled;  ///< after the first 20 s
  double max_tilt_rad = 0.0;
  double final_yaw_error_rad = 0.0;
  double final_yaw_sigma_rad = 0.0;
  Eigen::Vector3d gyroscope_bias_error_radps;
  Eigen::Vector3d gyroscope_bias_sigma_radps;
};

// Two minutes of TumblingBody at 200 Hz with Table VI noise and a biased gyroscope; the estimator starts
// from the first accelerometer sample, yaw `initial_yaw_error_rad` off, and with a 10 Hz heading if asked.
TumblingFlight FlyTumbling(bool with_heading, double initial_yaw_error_rad, uint64_t seed) {
  ImuModel imu(BiasedImu(), seed);
  HeadingSensor heading(HeadingSensorConfig(), seed + 1000);
  TumblingBody body;
  AttitudeEstimatorConfig config;
  config.initial_yaw_sigma_rad = std::max(config.initial_yaw_sigma_rad, 1.5 * initial_yaw_error_rad);
  AttitudeEstimator estimator(config);
  estimator.InitializeFromAccelerometer(imu.Sample(body.truth(), kDt),
                                        RollPitchYaw_rad(body.truth().q_WB).z() + initial_yaw_error_rad);
  const int steps_per_heading = static_cast<int>(1.0 / (heading.config().rate_hz * kDt));
  TumblingFlight flight;
  for (int k = 1; body.t_s() < 120.0; ++k) {
    body.Step(kDt);
    estimator.Update(imu.Sample(body.truth(), kDt), kDt);
    if (with_heading && k % steps_per_heading == 0) {
      estimator.UpdateHeading(heading.Measure(body.truth().q_WB), heading.config().sigma_rad);
    }
    const Eigen::Vector3d rpy = RollPitchYaw_rad(body.truth().q_WB);
    flight.max_tilt_rad = std::max({flight.max_tilt_rad, std::fabs(rpy.x()), std::fabs(rpy.y())});
    if (body.t_s() > 20.0) flight.settled.Add(estimator.q_WB(), body.truth().q_WB);
  }
  flight.final_yaw_error_rad =
      WrapToPi(RollPitchYaw_rad(estimator.q_WB()).z() - RollPitchYaw_rad(body.truth().q_WB).z());
  flight.final_yaw_sigma_rad = YawSigma_rad(estimator);
  flight.gyroscope_bias_error_radps = estimator.gyroscope_bias_B_radps() - imu.gyroscope_bias_radps();
  flight.gyroscope_bias_sigma_radps = estimator.covariance().diagonal().segment<3>(3).cwiseSqrt();
  const Eigen::Vector3d rmse = flight.settled.RootMeanSquare_rad(), max = flight.settled.MaxAbs_rad();
  std::printf(
      "tumbling%s (tilt up to %.1f deg): RMSE roll %.3f, pitch %.3f, yaw %.3f deg; max %.3f, %.3f, "
      "%.3f deg; final yaw error %.2f deg (filter sigma %.2f); gyro bias error %.1e %.1e %.1e rad/s "
      "(filter sigma %.1e %.1e %.1e)\n",
      with_heading ? " with heading" : "", flight.max_tilt_rad / kDeg, rmse.x() / kDeg, rmse.y() / kDeg,
      rmse.z() / kDeg, max.x() / kDeg, max.y() / kDeg, max.z() / kDeg, flight.final_yaw_error_rad / kDeg,
      flight.final_yaw_sigma_rad / kDeg, flight.gyroscope_bias_error_radps.x(),
      flight.gyroscope_bias_error_radps.y(), flight.gyroscope_bias_error_radps.z(),
      flight.gyroscope_bias_sigma_radps.x(), flight.gyroscope_bias_sigma_radps.y(),
      flight.gyroscope_bias_sigma_radps.z());
  return flight;
}

// The gyroscope bias (initially 14 mrad/s off) is found within the filter's uncertainty and 5 mrad/s: the
// Table VI bias walks 0.2 mrad/s per √s, so the filter never knows it much better than 1 mrad/s.
void ExpectGyroscopeBiasFound(const TumblingFlight& flight) {
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_LT(std::fabs(flight.gyroscope_bias_error_radps[axis]),
              kSigmas * flight.gyroscope_bias_sigma_radps[axis]);
  }
  EXPECT_LT(flight.gyroscope_bias_sigma_radps.maxCoeff(), 1.5e-3);
  EXPECT_LT(flight.gyroscope_bias_error_radps.norm(), 5e-3);  // 60 seeds: at most 3.7 mrad/s
}

TEST(AttitudeEstimator, TracksATumblingBodyWithTableViNoise) {
  const TumblingFlight flight = FlyTumbling(false, 0.0, 32);
  EXPECT_GT(flight.max_tilt_rad, 20 * kDeg);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().x(), 0.5 * kDeg);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().y(), 0.5 * kDeg);
  EXPECT_LT(flight.settled.MaxAbs_rad().head<2>().maxCoeff(), 2.0 * kDeg);
  // yaw is unaided: it drifts, and the filter knows by how much
  EXPECT_LT(std::fabs(flight.final_yaw_error_rad), kSigmas * flight.final_yaw_sigma_rad);
  ExpectGyroscopeBiasFound(flight);
}

TEST(AttitudeEstimator, HeadingMeasurementsHoldYawFromAWrongStart) {
  const TumblingFlight flight = FlyTumbling(true, 20 * kDeg, 33);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().head<2>().maxCoeff(), 0.5 * kDeg);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().z(), 1.0 * kDeg);
  EXPECT_LT(std::fabs(flight.final_yaw_error_rad), kSigmas * flight.final_yaw_sigma_rad);
  ExpectGyroscopeBiasFound(flight);
}

TEST(AttitudeEstimator, IgnoresTheAccelerometerWhileTheBodyAccelerates) {
  ImuConfig config;
  config.noise = ImuNoise();
  ImuModel imu(config, 1);
  BodyKinematics truth;
  AttitudeEstimator estimator{AttitudeEstimatorConfig()};
  estimator.Initialize(truth.q_WB, Eigen::Vector3d::Zero());
  EXPECT_TRUE(estimator.Update(imu.Sample(truth, kDt), kDt));
  truth.a_WB_W_mps2 = {0.0, 0.0, -4.0};  // climbing at 4 m/s²: |f| = 13.81 m/s², beyond the 2 m/s² gate
  EXPECT_FALSE(estimator.Update(imu.Sample(truth, kDt), kDt));
  EXPECT_LT(estimator.q_WB().angularDistance(truth.q_WB), 1e-12);
}

TEST(AttitudeErrorStatistics, RootMeanSquareAndMaximumPerAxis) {
  AttitudeErrorStatistics stats;
  EXPECT_EQ(stats.RootMeanSquare_rad(), Eigen::Vector3d::Zero());
  const Eigen::Quaterniond truth = FromRollPitchYaw(0.1, 0.2, 3.1);
  stats.Add(FromRollPitchYaw(0.13, 0.2, 3.1), truth);
  stats.Add(FromRollPitchYaw(0.06, 0.2, -3.1), truth);  // yaw across ±π: 0.083 rad apart, not 6.2
  EXPECT_EQ(stats.count(), 2u);
  EXPECT_NEAR(stats.RootMeanSquare_rad().x(), std::sqrt((0.03 * 0.03 + 0.04 * 0.04) / 2.0), 1e-12);
  EXPECT_NEAR(stats.RootMeanSquare_rad().y(), 0.0, 1e-12);
  EXPECT_NEAR(stats.MaxAbs_rad().z(), 2.0 * M_PI - 6.2, 1e-12);
  EXPECT_NEAR(stats.MaxAbs_rad().x(), 0.04, 1e-12);
}

// First-order Gauss-Markov errors of known time constants (2 s in roll, 0.5 s in pitch, white in yaw) at
// 200 Hz over 20 min come back as those time constants within 15 %: the estimate's spread is about
// sqrt(2 tau / T) of tau (6 % in roll, 3 % in pitch), measured 2.14 / 0.50 / 0.03 s. Without a sample
// interval, or with under 1 s of errors, there is no figure.
TEST(AttitudeErrorStatistics, CorrelationTimeOfGaussMarkovErrors) {
  const double dt_s = 0.005;
  const Eigen::Vector2d tau_s(2.0, 0.5);
  std::mt19937_64 random(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  AttitudeErrorStatistics stats(dt_s);
  AttitudeErrorStatistics no_interval;
  Eigen::Vector2d error_rad = Eigen::Vector2d::Zero();
  const Eigen::Quaterniond truth = FromRollPitchYaw(0.0, 0.0, 1.0);
  for (int k = 0; k < 240000; ++k) {
    for (int axis = 0; axis < 2; ++axis) {  // exact discretisation, stationary sigma 0.02 rad
      const double phi = std::exp(-dt_s / tau_s[axis]);
      error_rad[axis] = phi * error_rad[axis] + 0.02 * std::sqrt(1.0 - phi * phi) * normal(random);
    }
    const Eigen::Quaterniond estimate =
        FromRollPitchYaw(error_rad.x(), error_rad.y(), 1.0 + 0.02 * normal(random));
    stats.Add(estimate, truth);
    no_interval.Add(estimate, truth);
    if (k == 150) {
      EXPECT_TRUE(stats.CorrelationTime_s().array().isNaN().all()) << "0.75 s of errors";
    }
  }
  const Eigen::Vector3d measured_s = stats.CorrelationTime_s();
  std::printf("correlation time roll %.3f s (2), pitch %.3f s (0.5), yaw %.3f s (white)\n", measured_s.x(),
              measured_s.y(), measured_s.z());
  EXPECT_NEAR(measured_s.x(), 2.0, 0.3);
  EXPECT_NEAR(measured_s.y(), 0.5, 0.075);
  EXPECT_LT(measured_s.z(), 0.05);  // white: within the first 50 ms block
  EXPECT_TRUE(no_interval.CorrelationTime_s().array().isNaN().all());
}

}  // namespace
}  // namespace iapsim::sensors
