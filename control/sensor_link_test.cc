// The IAP computer's sensor link (control/sensor_link.h): messages become current at the step their link
// delivers them, never before, in order, the same for a seed.
#include "control/sensor_link.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace iapsim::control {
namespace {

constexpr int64_t kStep_ns = 1000000;  // a 1 ms clock

// Sends message k at step k for `steps` steps; returns the current message after each step (-1: none yet).
std::vector<int> Current(double delay_s, double jitter_s, uint64_t seed, int steps) {
  SensorLink<int> link(bridge::LinkDelay(delay_s, jitter_s, 1e-3, seed), kStep_ns);
  std::vector<int> current;
  for (int k = 0; k < steps; ++k) {
    link.Push(k, k * kStep_ns);
    current.push_back(link.Advance(k * kStep_ns) ? link.current() : -1);
  }
  return current;
}

TEST(SensorLink, WithoutLatencyEachMessageIsCurrentAtOnce) {
  const std::vector<int> current = Current(0.0, 0.0, 1, 50);
  for (int k = 0; k < 50; ++k) EXPECT_EQ(current[k], k);
  // a message stamped later than the time asked for is current too: received is arrived
  SensorLink<int> link(bridge::LinkDelay(0.0, 0.0, 1e-3, 1), kStep_ns);
  link.Push(7, 10 * kStep_ns);
  ASSERT_TRUE(link.Advance(9 * kStep_ns));
  EXPECT_EQ(link.current(), 7);
}

TEST(SensorLink, ADelayHoldsEveryMessageBackByItsWholeSteps) {
  const std::vector<int> current = Current(0.0104, 0.0, 1, 100);  // 10.4 ms: 10 steps
  for (int k = 0; k < 100; ++k) EXPECT_EQ(current[k], k < 10 ? -1 : k - 10) << k;
}

TEST(SensorLink, JitteredMessagesArriveInOrderWithinTheirBoundsTheSameForASeed) {
  const std::vector<int> current = Current(0.005, 0.004, 7, 2000);
  int previous = -1;
  int at_least_delay = 0, at_most_delay = 0;
  for (int k = 9; k < 2000; ++k) {
    EXPECT_GE(current[k], k - 9) << k;  // 5 ms + at most 4 ms
    EXPECT_LE(current[k], k - 5) << k;
    EXPECT_GE(current[k], previous) << k;
    previous = current[k];
    at_least_delay += current[k] == k - 5;
    at_most_delay += current[k] == k - 9;
  }
  EXPECT_GT(at_least_delay, 0);  // both ends of the jitter are reached
  EXPECT_GT(at_most_delay, 0);
  EXPECT_EQ(current, Current(0.005, 0.004, 7, 2000));
  EXPECT_NE(current, Current(0.005, 0.004, 8, 2000));
}

TEST(SensorLink, ALinkRefusesNegativeOrNonFiniteTimes) {
  for (const auto& [delay_s, jitter_s] :
       {std::pair{-0.001, 0.0}, {0.0, -0.001}, {NAN, 0.0}, {0.0, INFINITY}}) {
    EXPECT_THROW(bridge::LinkDelay(delay_s, jitter_s, 1e-3, 1), std::invalid_argument) << delay_s << jitter_s;
  }
  EXPECT_THROW(bridge::LinkDelay(0.0, 0.0, 0.0, 1), std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::control
