#include "vio/imu_propagator.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "vio/testing/synthetic.h"

namespace iapsim::vio {
namespace {

using testing::kGravity_mps2;
using testing::KnownMotion;

constexpr double kImuPeriod_s = 0.005;  // the seed's 200 Hz IMU

Estimate FrameAt(double t_s, const ImuBiases& biases = {}) {
  Estimate frame;
  frame.t_s = t_s;
  frame.state = KnownMotion::State(t_s);
  frame.biases = biases;
  frame.keyframe = true;
  return frame;
}

double RotationError_rad(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

TEST(ImuPropagatorTest, NothingBeforeTheFirstFrameAndTheFrameItselfUntilANewerSample) {
  ImuPropagator propagator(kGravity_mps2, sensors::TableViNoise());
  propagator.AddImu(0.5, KnownMotion::Sample(0.5));
  EXPECT_FALSE(propagator.Latest().has_value());
  const Estimate frame = FrameAt(0.5);
  propagator.SetFrame(frame);
  const auto latest = propagator.Latest();
  ASSERT_TRUE(latest.has_value());
  EXPECT_EQ(latest->t_s, 0.5);
  EXPECT_TRUE(latest->state.p_WI_m == frame.state.p_WI_m);
  EXPECT_TRUE(latest->keyframe);
}

// Between two 20 Hz frames the frame's true state, carried by the exact readings of a known motion, stays on
// the truth: the midpoint rule's error over 50 ms at 200 Hz is a fraction of a micrometre.
// Held instead, the same motion (up to 1.8 m/s) is 9 cm behind at the end of the interval.
TEST(ImuPropagatorTest, CarriesAFrameAlongAKnownMotionAtEverySample) {
  ImuPropagator propagator(kGravity_mps2, sensors::TableViNoise());
  propagator.AddImu(0.5, KnownMotion::Sample(0.5));
  propagator.SetFrame(FrameAt(0.5));
  double held_error_m = 0.0;
  for (int k = 1; k <= 10; ++k) {
    const double t = 0.5 + k * kImuPeriod_s;
    propagator.AddImu(t, KnownMotion::Sample(t));
    const Estimate latest = *propagator.Latest();
    EXPECT_DOUBLE_EQ(latest.t_s, t);
    EXPECT_FALSE(latest.keyframe);
    const NavState truth = KnownMotion::State(t);
    EXPECT_LT((latest.state.p_WI_m - truth.p_WI_m).norm(), 5e-7) << t;  // measured <= 1.6e-7
    EXPECT_LT((latest.state.v_WI_W_mps - truth.v_WI_W_mps).norm(), 5e-5) << t;
    EXPECT_LT(RotationError_rad(latest.state.q_WI, truth.q_WI), 5e-6) << t;
    EXPECT_LT((latest.w_I_radps - KnownMotion::Kinematics(t).w_WB_B_radps).norm(), 1e-12) << t;
    held_error_m = (KnownMotion::State(0.5).p_WI_m - truth.p_WI_m).norm();
  }
  EXPECT_GT(held_error_m, 0.05);
}

// The frame's biases correct every sample after it: readings with a gyroscope and an accelerometer bias are
// carried as well as the exact ones when the frame knows the biases, and 0.5 b_a t² off when it does not.
TEST(ImuPropagatorTest, UsesTheFramesBiases) {
  ImuBiases biases;
  biases.gyroscope_radps = {0.02, -0.01, 0.03};
  biases.accelerometer_mps2 = {0.3, -0.2, 0.4};
  const auto biased = [&](double t) {
    sensors::ImuSample s = KnownMotion::Sample(t);
    s.w_I_radps += biases.gyroscope_radps;
    s.f_I_mps2 += biases.accelerometer_mps2;
    return s;
  };
  const double t_end = 0.55;
  for (const bool known : {true, false}) {
    ImuPropagator propagator(kGravity_mps2, sensors::TableViNoise());
    propagator.AddImu(0.5, biased(0.5));
    propagator.SetFrame(FrameAt(0.5, known ? biases : ImuBiases{}));
    for (int k = 1; k <= 10; ++k) propagator.AddImu(0.5 + k * kImuPeriod_s, biased(0.5 + k * kImuPeriod_s));
    const Estimate latest = *propagator.Latest();
    const double error_m = (latest.state.p_WI_m - KnownMotion::State(t_end).p_WI_m).norm();
    const double bias_drift_m = 0.5 * biases.accelerometer_mps2.norm() * 0.05 * 0.05;  // 2.3e-4 m
    if (known) {
      EXPECT_LT(error_m, 5e-6);
      EXPECT_LT((latest.w_I_radps - KnownMotion::Kinematics(t_end).w_WB_B_radps).norm(), 1e-12);
    } else {
      EXPECT_NEAR(error_m, bias_drift_m, 0.1 * bias_drift_m);
    }
  }
}

// A new frame replaces the propagated state (what the window corrected arrives as a step), and the samples
// already after it are integrated from it at once; a frame between two samples starts from their
// interpolation.
TEST(ImuPropagatorTest, ANewFrameRestartsFromItselfWithTheSamplesAfterIt) {
  ImuPropagator propagator(kGravity_mps2, sensors::TableViNoise());
  for (int k = 0; k <= 10; ++k)
    propagator.AddImu(0.5 + k * kImuPeriod_s, KnownMotion::Sample(0.5 + k * kImuPeriod_s));
  propagator.SetFrame(FrameAt(0.5));
  Estimate corrected = FrameAt(0.5225);  // between the samples at 0.52 and 0.525
  corrected.state.p_WI_m += Eigen::Vector3d(0.1, -0.2, 0.05);
  propagator.SetFrame(corrected);
  const Estimate latest = *propagator.Latest();
  EXPECT_DOUBLE_EQ(latest.t_s, 0.55);
  const Eigen::Vector3d offset_m =
      latest.state.p_WI_m - KnownMotion::State(0.55).p_WI_m - Eigen::Vector3d(0.1, -0.2, 0.05);
  EXPECT_LT(offset_m.norm(), 2e-7);  // measured 8e-8
  EXPECT_LT(RotationError_rad(latest.state.q_WI, KnownMotion::State(0.55).q_WI), 1e-7);
}

TEST(ImuPropagatorTest, RejectsSamplesOutOfOrderAndAFrameWithoutSamples) {
  ImuPropagator propagator(kGravity_mps2, sensors::TableViNoise());
  EXPECT_THROW(propagator.SetFrame(FrameAt(0.5)), std::invalid_argument);
  propagator.AddImu(0.5, KnownMotion::Sample(0.5));
  EXPECT_THROW(propagator.AddImu(0.5, KnownMotion::Sample(0.5)), std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::vio
