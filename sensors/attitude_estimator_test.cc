#include "sensors/attitude_estimator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>

#include "sensors/heading_sensor.h"
#include "sensors/imu.h"
#include "sensors/velocity_sensor.h"

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

// For a body whose origin does not move: its accelerometer sees gravity alone, so no acceleration
// correlated over time need be allowed for (the white 0.5 m/s² stays).
AttitudeEstimatorConfig StillOriginConfig() {
  AttitudeEstimatorConfig config;
  config.acceleration_correlation_s = 0.0;
  return config;
}

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
  AttitudeEstimatorConfig config = StillOriginConfig();
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
  const StaticRun run = RunStatic(BiasedImu(), StillOriginConfig(), 31);
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

// What a flight leaves the estimator with, against the truth.
struct FlightEnd {
  double yaw_error_rad = 0.0;
  double yaw_sigma_rad = 0.0;
  Eigen::Vector3d gyroscope_bias_error_radps;
  Eigen::Vector3d gyroscope_bias_sigma_radps;
};

FlightEnd EndOfFlight(const AttitudeEstimator& estimator, const Eigen::Quaterniond& q_WB_true,
                      const ImuModel& imu) {
  FlightEnd end;
  end.yaw_error_rad = WrapToPi(RollPitchYaw_rad(estimator.q_WB()).z() - RollPitchYaw_rad(q_WB_true).z());
  end.yaw_sigma_rad = YawSigma_rad(estimator);
  end.gyroscope_bias_error_radps = estimator.gyroscope_bias_B_radps() - imu.gyroscope_bias_radps();
  end.gyroscope_bias_sigma_radps = estimator.covariance().diagonal().segment<3>(3).cwiseSqrt();
  return end;
}

// One line for the test's output: the settled errors and the flight's end.
void PrintFlight(const std::string& what, const AttitudeErrorStatistics& settled, const FlightEnd& end) {
  const Eigen::Vector3d rmse = settled.RootMeanSquare_rad() / kDeg, max = settled.MaxAbs_rad() / kDeg;
  std::printf(
      "%s: RMSE roll %.3f, pitch %.3f, yaw %.3f deg; max %.3f, %.3f, %.3f deg; final yaw error %.2f deg "
      "(filter sigma %.2f); gyro bias error %.1e %.1e %.1e rad/s (filter sigma %.1e %.1e %.1e)\n",
      what.c_str(), rmse.x(), rmse.y(), rmse.z(), max.x(), max.y(), max.z(), end.yaw_error_rad / kDeg,
      end.yaw_sigma_rad / kDeg, end.gyroscope_bias_error_radps.x(), end.gyroscope_bias_error_radps.y(),
      end.gyroscope_bias_error_radps.z(), end.gyroscope_bias_sigma_radps.x(),
      end.gyroscope_bias_sigma_radps.y(), end.gyroscope_bias_sigma_radps.z());
}

struct TumblingFlight {
  AttitudeErrorStatistics settled;  ///< after the first 20 s
  double max_tilt_rad = 0.0;
  FlightEnd end;
};

// Two minutes of TumblingBody at 200 Hz with Table VI noise and a biased gyroscope; the estimator starts
// from the first accelerometer sample, yaw `initial_yaw_error_rad` off, and with a 10 Hz heading if asked.
TumblingFlight FlyTumbling(bool with_heading, double initial_yaw_error_rad, uint64_t seed) {
  ImuModel imu(BiasedImu(), seed);
  HeadingSensor heading(HeadingSensorConfig(), seed + 1000);
  TumblingBody body;
  AttitudeEstimatorConfig config = StillOriginConfig();
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
  flight.end = EndOfFlight(estimator, body.truth().q_WB, imu);
  char what[64];
  std::snprintf(what, sizeof(what), "tumbling%s (tilt up to %.1f deg)", with_heading ? " with heading" : "",
                flight.max_tilt_rad / kDeg);
  PrintFlight(what, flight.settled, flight.end);
  return flight;
}

// The gyroscope bias (initially 14 mrad/s off) is found within the filter's uncertainty and 5 mrad/s: the
// Table VI bias walks 0.2 mrad/s per √s, so the filter never knows it much better than 1 mrad/s.
void ExpectGyroscopeBiasFoundWithin(const Eigen::Vector3d& error_radps, const Eigen::Vector3d& sigma_radps) {
  for (int axis = 0; axis < 3; ++axis) EXPECT_LT(std::fabs(error_radps[axis]), kSigmas * sigma_radps[axis]);
}

void ExpectGyroscopeBiasFound(const Eigen::Vector3d& error_radps, const Eigen::Vector3d& sigma_radps) {
  ExpectGyroscopeBiasFoundWithin(error_radps, sigma_radps);
  EXPECT_LT(sigma_radps.maxCoeff(), 1.5e-3);
  EXPECT_LT(error_radps.norm(), 5e-3);  // 60 seeds: at most 3.7 mrad/s
}

TEST(AttitudeEstimator, TracksATumblingBodyWithTableViNoise) {
  const TumblingFlight flight = FlyTumbling(false, 0.0, 32);
  EXPECT_GT(flight.max_tilt_rad, 20 * kDeg);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().x(), 0.5 * kDeg);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().y(), 0.5 * kDeg);
  EXPECT_LT(flight.settled.MaxAbs_rad().head<2>().maxCoeff(), 2.0 * kDeg);
  // yaw is unaided: it drifts, and the filter knows by how much
  EXPECT_LT(std::fabs(flight.end.yaw_error_rad), kSigmas * flight.end.yaw_sigma_rad);
  ExpectGyroscopeBiasFound(flight.end.gyroscope_bias_error_radps, flight.end.gyroscope_bias_sigma_radps);
}

TEST(AttitudeEstimator, HeadingMeasurementsHoldYawFromAWrongStart) {
  const TumblingFlight flight = FlyTumbling(true, 20 * kDeg, 33);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().head<2>().maxCoeff(), 0.5 * kDeg);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().z(), 1.0 * kDeg);
  EXPECT_LT(std::fabs(flight.end.yaw_error_rad), kSigmas * flight.end.yaw_sigma_rad);
  ExpectGyroscopeBiasFound(flight.end.gyroscope_bias_error_radps, flight.end.gyroscope_bias_sigma_radps);
}

// TumblingBody's rotation while its origin flies a Lissajous figure of 6 × 4 × 1 m: accelerations up to
// 1 m/s² that change direction in W and in B, sustained over seconds, as a flight's are.
struct TumblingLissajous {
  TumblingBody rotation;
  BodyKinematics truth() const {
    BodyKinematics truth = rotation.truth();
    const double t = rotation.t_s();
    truth.a_WB_W_mps2 = {
        -kAmplitude_m.x() * kRate_radps.x() * kRate_radps.x() * std::sin(kRate_radps.x() * t),
        -kAmplitude_m.y() * kRate_radps.y() * kRate_radps.y() * std::sin(kRate_radps.y() * t),
        -kAmplitude_m.z() * kRate_radps.z() * kRate_radps.z() * std::sin(kRate_radps.z() * t)};
    return truth;
  }
  Eigen::Vector3d v_W_mps() const {
    const double t = rotation.t_s();
    return {kAmplitude_m.x() * kRate_radps.x() * std::cos(kRate_radps.x() * t),
            kAmplitude_m.y() * kRate_radps.y() * std::cos(kRate_radps.y() * t),
            kAmplitude_m.z() * kRate_radps.z() * std::cos(kRate_radps.z() * t)};
  }
  inline static const Eigen::Vector3d kAmplitude_m{3.0, 2.0, 0.5};
  inline static const Eigen::Vector3d kRate_radps{0.5, 0.7, 0.9};
};

struct AcceleratingFlight {
  AttitudeErrorStatistics settled;  ///< after the first 20 s
  double max_velocity_error_sigmas = 0.0;
  FlightEnd end;
};

// Two minutes of TumblingLissajous with Table VI noise and a biased gyroscope, the estimator started at the
// true attitude and velocity but yaw `initial_yaw_error_rad` off; velocity-aided at 20 Hz (σ 0.1 m/s) if
// the config says so, without a heading.
AcceleratingFlight FlyAccelerating(AttitudeEstimatorConfig config, double initial_yaw_error_rad,
                                   uint64_t seed) {
  ImuModel imu(BiasedImu(), seed);
  VelocitySensor velocity(VelocitySensorConfig(), seed + 1000);
  TumblingLissajous body;
  const bool velocity_aided = config.velocity_aided;
  config.initial_yaw_sigma_rad = std::max(config.initial_yaw_sigma_rad, 1.5 * initial_yaw_error_rad);
  AttitudeEstimator estimator(config);
  estimator.Initialize(Eigen::AngleAxisd(initial_yaw_error_rad, Eigen::Vector3d::UnitZ()) * body.truth().q_WB,
                       Eigen::Vector3d::Zero(), body.v_W_mps());
  const int steps_per_velocity = static_cast<int>(1.0 / (velocity.config().rate_hz * kDt));
  AcceleratingFlight flight;
  for (int k = 1; body.rotation.t_s() < 120.0; ++k) {
    body.rotation.Step(kDt);
    estimator.Update(imu.Sample(body.truth(), kDt), kDt);
    if (velocity_aided && k % steps_per_velocity == 0) {
      estimator.UpdateVelocity(velocity.Measure(body.v_W_mps()), velocity.config().sigma_mps);
    }
    if (body.rotation.t_s() <= 20.0) continue;
    flight.settled.Add(estimator.q_WB(), body.truth().q_WB);
    if (velocity_aided) {
      const Eigen::Vector3d error_mps = estimator.v_W_mps() - body.v_W_mps();
      const Eigen::Vector3d sigma_mps = estimator.covariance().diagonal().tail<3>().cwiseSqrt();
      flight.max_velocity_error_sigmas = std::max(flight.max_velocity_error_sigmas,
                                                  error_mps.cwiseQuotient(sigma_mps).cwiseAbs().maxCoeff());
    }
  }
  flight.end = EndOfFlight(estimator, body.truth().q_WB, imu);
  PrintFlight(velocity_aided ? "accelerating, velocity-aided" : "accelerating", flight.settled, flight.end);
  if (velocity_aided) std::printf("  velocity error up to %.1f sigmas\n", flight.max_velocity_error_sigmas);
  return flight;
}

TEST(AttitudeEstimator, AGravityReferenceAllowsForSustainedAccelerationToStayConsistent) {
  // the accelerations read as tilt (seed 41: RMSE 0.8° roll, 1.0° pitch), and the errors stay within the
  // filter's own uncertainty: yaw drifts by 11° where it believes 8°
  const AcceleratingFlight flight = FlyAccelerating(AttitudeEstimatorConfig(), 0.0, 41);
  EXPECT_GT(flight.settled.RootMeanSquare_rad().head<2>().maxCoeff(), 0.5 * kDeg);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().head<2>().maxCoeff(), 1.5 * kDeg);
  EXPECT_LT(std::fabs(flight.end.yaw_error_rad), kSigmas * flight.end.yaw_sigma_rad);
  ExpectGyroscopeBiasFoundWithin(flight.end.gyroscope_bias_error_radps,
                                 flight.end.gyroscope_bias_sigma_radps);
  // taken as white, the same accelerations pull the tilt further (2.7°, 2.2°) and, through it, the gyroscope
  // biases: yaw ends 85° off where the filter believes 1.3°
  const AcceleratingFlight white = FlyAccelerating(StillOriginConfig(), 0.0, 41);
  EXPECT_GT(white.settled.RootMeanSquare_rad().head<2>().maxCoeff(), 2.0 * kDeg);
  EXPECT_GT(std::fabs(white.end.yaw_error_rad), 10.0 * white.end.yaw_sigma_rad);
}

TEST(AttitudeEstimator, VelocityAidedTellsAccelerationFromTiltAndFindsYaw) {
  // from 20° of yaw off, without a heading: the horizontal acceleration makes yaw observable. Seeds 42-48:
  // RMSE roll and pitch 0.22-0.36°, yaw 0.59-0.87°, velocity error up to 3.2-4.5 σ over 100 s.
  AttitudeEstimatorConfig config;
  config.velocity_aided = true;
  const AcceleratingFlight flight = FlyAccelerating(config, 20 * kDeg, 42);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().head<2>().maxCoeff(), 0.5 * kDeg);
  EXPECT_LT(flight.settled.RootMeanSquare_rad().z(), 1.5 * kDeg);
  EXPECT_LT(std::fabs(flight.end.yaw_error_rad), kSigmas * flight.end.yaw_sigma_rad);
  EXPECT_LT(flight.max_velocity_error_sigmas, 5.5);
  ExpectGyroscopeBiasFound(flight.end.gyroscope_bias_error_radps, flight.end.gyroscope_bias_sigma_radps);
}

TEST(AttitudeEstimator, OnlyAVelocityAidedFilterTakesVelocities) {
  AttitudeEstimator estimator{AttitudeEstimatorConfig()};
  estimator.Initialize(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
  EXPECT_THROW(estimator.UpdateVelocity(Eigen::Vector3d::Zero(), 0.1), std::logic_error);
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
