#include "vio/run_setup.h"

#include <gtest/gtest.h>

#include "bridge/eigen_msgs.h"
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
