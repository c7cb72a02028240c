#include "vio/run_setup.h"

#include <gtest/gtest.h>

#include "bridge/eigen_msgs.h"
#include "sensors/attitude_estimator.h"
#include "vio/so3.h"
#include "vio/testing/synthetic.h"

namespace iapsim::vio {
namespace {

using testing::KnownMotion;

// The odometry of a body whose origin is the joint at d (in P) of the platform moving as KnownMotion, with
// an attitude of its own (a spherical joint leaves it free).
nav_msgs::Odometry JointBodyOdometry(double t, const Eigen::Vector3d& d_P, const Eigen::Quaterniond& q_WB) {
  const Eigen::Isometry3d X_WP = KnownMotion::Pose(t);
  const Eigen::Vector3d w_P = KnownMotion::Kinematics(t).w_WB_B_radps;
  nav_msgs::Odometry odometry;
  odometry.header.stamp = bridge::ToRosTime(static_cast<int64_t>(t * 1e9));
  odometry.pose.pose.position = bridge::ToPointMsg(X_WP * d_P);
  odometry.pose.pose.orientation = bridge::ToQuaternionMsg(q_WB);
  const Eigen::Vector3d v_W = KnownMotion::Velocity(t) + X_WP.linear() * w_P.cross(d_P);
  odometry.twist.twist.linear = bridge::ToVector3Msg(q_WB.conjugate() * v_W);
  return odometry;
}

// Three joints of a rigid platform give back its pose and twist (in P) exactly, whatever the sub-aircraft's
// own attitudes.
TEST(RunSetupTest, ThePlatformFromItsJointsIsTheRigidMotion) {
  const std::vector<Eigen::Vector3d> joints_P{{0.48, 0.0, 0.0}, {-0.24, 0.416, 0.0}, {-0.24, -0.416, 0.0}};
  for (double t : {0.0, 0.8, 2.6}) {
    std::vector<nav_msgs::Odometry> subs;
    for (std::size_t i = 0; i < joints_P.size(); ++i)
      subs.push_back(
          JointBodyOdometry(t, joints_P[i], ExpQuaternion(Eigen::Vector3d(0.1 * i, -0.2, 0.3 * i))));
    const nav_msgs::Odometry platform = PlatformOdometryOf(joints_P, subs, "iap");
    EXPECT_EQ(platform.child_frame_id, "iap/platform");
    const Eigen::Isometry3d X_WP = KnownMotion::Pose(t);
    EXPECT_LT((bridge::FromMsg(platform.pose.pose.position) - X_WP.translation()).norm(), 1e-12);
    const Eigen::Quaterniond q_WP(X_WP.linear());
    EXPECT_LT(
        Log(Eigen::Quaterniond(q_WP.conjugate() * bridge::FromMsg(platform.pose.pose.orientation))).norm(),
        1e-12);
    EXPECT_LT(
        (bridge::FromMsg(platform.twist.twist.linear) - X_WP.linear().transpose() * KnownMotion::Velocity(t))
            .norm(),
        1e-12);
    EXPECT_LT(
        (bridge::FromMsg(platform.twist.twist.angular) - KnownMotion::Kinematics(t).w_WB_B_radps).norm(),
        1e-12);
  }
}

// One sub-aircraft's height drift tilts the platform fitted to the joints; with the platform's own attitude
// estimate, the tilt and the rate are that estimate's, the yaw stays the fit's, and the drift moves the
// position by its mean over the joints only (these joints are centred on P's origin).
TEST(RunSetupTest, ThePlatformsOwnAttitudeTakesTheTiltASubAircraftsHeightDriftGaveTheFit) {
  const std::vector<Eigen::Vector3d> joints_P{{0.48, 0.0, 0.0}, {-0.24, 0.416, 0.0}, {-0.24, -0.416, 0.0}};
  const Eigen::Vector3d drift_W_m(0.0, 0.0, -0.05);
  const double t = 1.1;
  std::vector<nav_msgs::Odometry> subs;
  for (std::size_t i = 0; i < joints_P.size(); ++i) {
    subs.push_back(JointBodyOdometry(t, joints_P[i], ExpQuaternion(Eigen::Vector3d(0.2, 0.1 * i, -0.3))));
    if (i == 1) {
      subs.back().pose.pose.position =
          bridge::ToPointMsg(bridge::FromMsg(subs.back().pose.pose.position) + drift_W_m);
    }
  }
  const Eigen::Isometry3d X_WP = KnownMotion::Pose(t);
  const Eigen::Quaterniond q_WP(X_WP.linear());
  const Eigen::Vector3d w_P = KnownMotion::Kinematics(t).w_WB_B_radps;
  // the tilt error: the angle between the estimated and the true direction of gravity in P (what an
  // accelerometer observes; it does not depend on the yaw)
  const auto tilt_error = [&](const nav_msgs::Odometry& platform) {
    const Eigen::Quaterniond q = bridge::FromMsg(platform.pose.pose.orientation);
    const Eigen::Vector3d g_estimate_P = q.conjugate() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d g_P = q_WP.conjugate() * Eigen::Vector3d::UnitZ();
    return std::atan2(g_estimate_P.cross(g_P).norm(), g_estimate_P.dot(g_P));
  };
  const nav_msgs::Odometry fitted = PlatformOdometryOf(joints_P, subs, "iap");
  // 5 cm at 0.72 m from the line through the other two joints: 0.067 rad (3.8 deg), measured
  EXPECT_GT(tilt_error(fitted), 0.05);

  const PlatformAttitude attitude{q_WP, w_P};
  const nav_msgs::Odometry fused = PlatformOdometryOf(joints_P, subs, "iap", &attitude);
  const Eigen::Quaterniond q_fused = bridge::FromMsg(fused.pose.pose.orientation);
  const Eigen::Vector3d rpy_fused = sensors::RollPitchYaw_rad(q_fused);
  const Eigen::Vector3d rpy_truth = sensors::RollPitchYaw_rad(q_WP);
  EXPECT_NEAR(rpy_fused.x(), rpy_truth.x(), 1e-12);
  EXPECT_NEAR(rpy_fused.y(), rpy_truth.y(), 1e-12);
  EXPECT_NEAR(rpy_fused.z(), sensors::RollPitchYaw_rad(bridge::FromMsg(fitted.pose.pose.orientation)).z(),
              1e-12);
  EXPECT_LT(tilt_error(fused), 1e-12);
  EXPECT_LT((bridge::FromMsg(fused.pose.pose.position) - (X_WP.translation() + drift_W_m / 3.0)).norm(),
            1e-12);
  EXPECT_LT((q_fused * bridge::FromMsg(fused.twist.twist.linear) - KnownMotion::Velocity(t)).norm(), 1e-12);
  EXPECT_LT((bridge::FromMsg(fused.twist.twist.angular) - w_P).norm(), 1e-15);
}

// What a sub-aircraft shares is its body's pose and velocity; the IMU's state comes back out of it, lever arm
// included, and the joint the others read is the body's origin.
TEST(RunSetupTest, SharedOdometryRoundTrips) {
  SubAircraftSetup sub;
  sub.body = "iap/sub1";
  sub.X_BI.translation() = Eigen::Vector3d(0.01, -0.02, 0.03);
  sub.X_BI.linear() = Exp(Eigen::Vector3d(0.0, 0.0, M_PI / 2));
  Estimate estimate;
  estimate.state = KnownMotion::State(1.3);
  estimate.w_I_radps = Eigen::Vector3d(0.2, -0.4, 0.9);
  const nav_msgs::Odometry odometry = OdometryOf(estimate, sub, 1'300'000'000);
  EXPECT_EQ(odometry.child_frame_id, "iap/sub1");
  const NavState back = ImuStateOf(odometry, sub.X_BI);
  EXPECT_LT((back.p_WI_m - estimate.state.p_WI_m).norm(), 1e-12);
  EXPECT_LT((back.v_WI_W_mps - estimate.state.v_WI_W_mps).norm(), 1e-12);
  EXPECT_LT(Log(Eigen::Quaterniond(back.q_WI.conjugate() * estimate.state.q_WI)).norm(), 1e-12);
  const PeerJoint joint = PeerJointOf(odometry);
  const PeerJoint origin = JointOf(estimate, sub.X_BI.inverse().translation());
  EXPECT_LT((joint.p_WJ_m - origin.p_WJ_m).norm(), 1e-12);
  EXPECT_LT((joint.v_WJ_W_mps - origin.v_WJ_W_mps).norm(), 1e-12);
}

// The manual flight (b) is three_star_stereo.yaml with Table XI's anchors; uwb.anchors picks some of them by
// name (the anchor sweep of Table VII), and a name the scenario lacks is an error that lists what it has.
TEST(RunSetupTest, TheAnchorsAreTheScenariosOrThoseNamed) {
  const bridge::Scenario scenario = bridge::LoadScenario(std::string(IAPSIM_SOURCE_DIR) +
                                                         "/configs/scenarios/three_star_pilot_station.yaml");
  const RunSetup all = ReadRunSetup(scenario, "vio_uwb", LoadVioConfig("", {}), {});
  ASSERT_EQ(all.subs.size(), 3u);
  EXPECT_EQ(all.anchor_names, (std::vector<std::string>{"anchor1", "anchor2", "anchor3", "anchor4"}));
  ASSERT_EQ(all.subs[0].anchors_W.size(), 4u);
  EXPECT_EQ(all.subs[0].anchors_W.at("anchor3"), Eigen::Vector3d(38.76, 46.12, -1.59));  // seed Table XI
  const RunSetup two =
      ReadRunSetup(scenario, "vio_uwb", LoadVioConfig("", {"uwb.anchors=[anchor4,anchor2]"}), {"iap/sub2"});
  ASSERT_EQ(two.subs.size(), 1u);
  EXPECT_EQ(two.subs[0].anchors_W.size(), 2u);
  EXPECT_EQ(two.subs[0].anchors_W.count("anchor4"), 1u);
  EXPECT_EQ(two.subs[0].anchors_W.count("anchor1"), 0u);
  try {
    ReadRunSetup(scenario, "vio_uwb", LoadVioConfig("", {"uwb.anchors=[anchor5]"}), {});
    ADD_FAILURE() << "an unknown anchor was accepted";
  } catch (const bridge::ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("uwb.anchors: no anchor 'anchor5'"), std::string::npos) << what;
    EXPECT_NE(what.find("anchor1, anchor2, anchor3, anchor4"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace iapsim::vio
