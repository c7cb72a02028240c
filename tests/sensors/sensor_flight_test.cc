// Issue 5's end-to-end check: a three-star flight records IMU, attitude estimate, UWB and the filtered wrench
// for every sub-aircraft, each sample stamped with the physics time of the state it derives from; with
// platform_imu, the platform's IMU and attitude estimate too, and an odometry that takes its tilt from them.
#include <geometry_msgs/WrenchStamped.h>
#include <gtest/gtest.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/UwbRanges.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <vector>

#include "bridge/bag.h"
#include "bridge/eigen_msgs.h"
#include "bridge/launcher.h"
#include "bridge/message.h"
#include "sensors/attitude_estimator.h"

namespace iapsim::bridge {
namespace {

constexpr int64_t kPhysicsStep_ns = 1000000;

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

TEST(SensorFlight, EverySubAircraftRecordsItsSensorsOnThePhysicsClock) {
  const std::filesystem::path out =
      std::filesystem::path(::testing::TempDir()) / ("iapsim-sensors-" + std::to_string(getpid()));
  LaunchOptions options;
  options.scenario_path = std::string(IAPSIM_SOURCE_DIR) + "/configs/scenarios/three_star_sensors.yaml";
  options.overrides = {"duration_s=5"};
  options.out_dir = out.string();
  options.bin_dir = ExecutableDir();
  const LaunchResult result = Launch(options);
  ASSERT_EQ(result.exit_code, 0) << result.message;

  BagReader bag(result.run_dir + "/run.bag");
  std::map<int64_t, Eigen::Vector3d> sub1_position_W;  // truth, by stamp
  std::map<std::string, uint64_t> counts;
  std::map<std::string, int64_t> last_stamp_ns;
  double max_uwb_error_m = 0.0, max_specific_force_error = 0.0;
  uint64_t anchor_ranges = 0;
  std::string error;
  const auto check_stamp = [&](const std::string& topic, const ros::Time& stamp) {
    const int64_t ns = ToNanoseconds(stamp);
    EXPECT_EQ(ns % kPhysicsStep_ns, 0) << topic << " sampled off the physics grid";
    if (last_stamp_ns.count(topic)) {
      EXPECT_GT(ns, last_stamp_ns[topic]) << topic;
    }
    last_stamp_ns[topic] = ns;
    ++counts[topic];
  };
  bag.ForEach({"/iap/state"}, [&](const BagMessage& m) {
    iapsim_msgs::IapState state;
    EXPECT_TRUE(Decode(m.bytes, &state, &error)) << error;
    sub1_position_W[ToNanoseconds(state.header.stamp)] = FromMsg(state.bodies.at(1).pose_W.position);
    return true;
  });
  bag.ForEach({}, [&](const BagMessage& m) {
    if (EndsWith(m.topic, "/imu") || EndsWith(m.topic, "/attitude")) {
      sensor_msgs::Imu imu;
      EXPECT_TRUE(Decode(m.bytes, &imu, &error)) << error;
      check_stamp(m.topic, imu.header.stamp);
      if (EndsWith(m.topic, "/imu")) {
        // hovering and cruising gently, the sub-aircraft's specific force stays near g (noise: 0.28 m/s²)
        const double f = FromMsg(imu.linear_acceleration).norm();
        max_specific_force_error = std::max(max_specific_force_error, std::abs(f - 9.81));
      } else {
        EXPECT_NEAR(FromMsg(imu.orientation).norm(), 1.0, 1e-9);
      }
    } else if (EndsWith(m.topic, "/uwb")) {
      iapsim_msgs::UwbRanges ranges;
      EXPECT_TRUE(Decode(m.bytes, &ranges, &error)) << error;
      check_stamp(m.topic, ranges.header.stamp);
      EXPECT_EQ(ranges.peers.size(), ranges.ranges_m.size());
      if (m.topic == "/iap/sub1/uwb") {
        // the anchor ranges are the geometry of the stamped state plus noise of σ 0.71 m (5σ bound)
        const Eigen::Vector3d anchor1(-8.17, -4.35, -1.38);
        for (size_t i = 0; i < ranges.peers.size(); ++i) {
          if (ranges.peers[i] != "anchor1") continue;
          const double truth_m = (sub1_position_W.at(ToNanoseconds(ranges.header.stamp)) - anchor1).norm();
          max_uwb_error_m = std::max(max_uwb_error_m, std::abs(ranges.ranges_m[i] - truth_m));
          ++anchor_ranges;
        }
      }
    } else if (m.topic == "/iap/wrench/filtered") {
      geometry_msgs::WrenchStamped wrench;
      EXPECT_TRUE(Decode(m.bytes, &wrench, &error)) << error;
      check_stamp(m.topic, wrench.header.stamp);
      EXPECT_EQ(FromMsg(wrench.wrench.force).norm(), 0.0);  // 2.5 m up: no contact, nothing to filter
    }
    return true;
  });
  for (const std::string sub : {"sub1", "sub2", "sub3"}) {
    EXPECT_EQ(counts["/iap/" + sub + "/imu"], 1001u) << sub;  // 200 Hz for 5 s, steps 0..5000
    EXPECT_EQ(counts["/iap/" + sub + "/attitude"], 1001u) << sub;
    EXPECT_EQ(counts["/iap/" + sub + "/uwb"], 251u) << sub;  // 50 Hz
  }
  EXPECT_EQ(counts["/iap/wrench/filtered"], 1001u);
  EXPECT_EQ(anchor_ranges, 251u);
  EXPECT_LT(max_uwb_error_m, 5 * 0.7071);
  EXPECT_GT(max_uwb_error_m, 0.1);  // noisy, not the bare geometry
  EXPECT_LT(max_specific_force_error, 2.5);

  // seeded and deterministic in lockstep: a second run gives the same noisy samples, byte for byte, with
  // an IMU and an attitude EKF added on the platform (the IAP computer's): its streams are seeded apart
  options.out_dir = (out / "again").string();
  options.overrides.push_back("processes.sensors.params.platform_imu={}");
  // and a noise-free odometry that reports the platform's tilt and rate from that IMU and its EKF
  options.overrides.push_back("processes.sensors.params.odometry={attitude_source: platform_imu}");
  const LaunchResult again = Launch(options);
  ASSERT_EQ(again.exit_code, 0) << again.message;
  BagReader again_bag(again.run_dir + "/run.bag");
  std::map<int64_t, Eigen::Quaterniond> q_WP;  // truth, by stamp
  again_bag.ForEach({"/iap/state"}, [&](const BagMessage& m) {
    iapsim_msgs::IapState state;
    EXPECT_TRUE(Decode(m.bytes, &state, &error)) << error;
    q_WP[ToNanoseconds(state.header.stamp)] = FromMsg(state.bodies.at(0).pose_W.orientation).normalized();
    return true;
  });
  uint64_t platform_imu = 0, platform_attitude = 0;
  std::map<int64_t, sensor_msgs::Imu> platform_attitude_by_stamp;
  double max_platform_tilt_error_deg = 0.0, max_start_tilt_error_deg = 0.0;  // after the first second, in it
  again_bag.ForEach({"/iap/imu", "/iap/attitude"}, [&](const BagMessage& m) {
    sensor_msgs::Imu imu;
    EXPECT_TRUE(Decode(m.bytes, &imu, &error)) << error;
    if (m.topic == "/iap/imu") {
      EXPECT_EQ(imu.header.frame_id, "iap/P/imu");
      ++platform_imu;
      return true;
    }
    EXPECT_EQ(imu.header.frame_id, "iap/P");
    ++platform_attitude;
    platform_attitude_by_stamp[ToNanoseconds(imu.header.stamp)] = imu;
    // the tilt error: the angle between the estimated and the true direction of gravity in P (what the
    // accelerometer observes; a yaw error does not enter it)
    const Eigen::Vector3d g_estimate_P =
        FromMsg(imu.orientation).normalized().conjugate() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d g_P =
        q_WP.at(ToNanoseconds(imu.header.stamp)).conjugate() * Eigen::Vector3d::UnitZ();
    const double tilt_error_deg =
        std::atan2(g_estimate_P.cross(g_P).norm(), g_estimate_P.dot(g_P)) * 180.0 / M_PI;
    double& max_deg = ToNanoseconds(imu.header.stamp) >= 1'000'000'000 ? max_platform_tilt_error_deg
                                                                       : max_start_tilt_error_deg;
    max_deg = std::max(max_deg, tilt_error_deg);
    return true;
  });
  EXPECT_EQ(platform_imu, 1001u);
  EXPECT_EQ(platform_attitude, 1001u);
  // the EKF starts from one accelerometer sample (Table VI: 1.65 deg of tilt, 1 sigma; measured 2.2 deg) and
  // then holds the tilt of the gently cruising platform as it does a sub-aircraft's (measured 1.35 deg)
  EXPECT_LT(max_start_tilt_error_deg, 5.0);
  EXPECT_LT(max_platform_tilt_error_deg, 2.7);
  EXPECT_GT(max_platform_tilt_error_deg, 0.01);  // an estimate, not the truth
  uint64_t odometry_samples = 0;
  again_bag.ForEach({"/iap/odometry"}, [&](const BagMessage& m) {
    nav_msgs::Odometry odometry;
    EXPECT_TRUE(Decode(m.bytes, &odometry, &error)) << error;
    const int64_t t_ns = ToNanoseconds(odometry.header.stamp);
    const sensor_msgs::Imu& attitude = platform_attitude_by_stamp.at(t_ns);
    // roll and pitch are the EKF's, the yaw the (noise-free) odometry's: the truth's
    const Eigen::Vector3d rpy = sensors::RollPitchYaw_rad(FromMsg(odometry.pose.pose.orientation));
    const Eigen::Vector3d ekf_rpy = sensors::RollPitchYaw_rad(FromMsg(attitude.orientation));
    EXPECT_NEAR(rpy.x(), ekf_rpy.x(), 1e-12);
    EXPECT_NEAR(rpy.y(), ekf_rpy.y(), 1e-12);
    EXPECT_NEAR(rpy.z(), sensors::RollPitchYaw_rad(q_WP.at(t_ns)).z(), 1e-12);
    EXPECT_EQ(FromMsg(odometry.twist.twist.angular), FromMsg(attitude.angular_velocity));
    ++odometry_samples;
    return true;
  });
  EXPECT_EQ(odometry_samples, 1001u);
  const auto samples = [](const std::string& bag_path) {
    std::vector<std::vector<uint8_t>> bytes;
    BagReader(bag_path).ForEach({"/iap/sub2/imu", "/iap/sub3/uwb"}, [&](const BagMessage& m) {
      bytes.push_back(m.bytes);
      return true;
    });
    return bytes;
  };
  const auto first = samples(result.run_dir + "/run.bag");
  EXPECT_EQ(first.size(), 1001u + 251u);
  EXPECT_TRUE(first == samples(again.run_dir + "/run.bag"));
  std::filesystem::remove_all(out);
}

}  // namespace
}  // namespace iapsim::bridge
