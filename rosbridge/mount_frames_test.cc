#include "rosbridge/mount_frames.h"

#include <gtest/gtest.h>

namespace iapsim::rosbridge {
namespace {

const bridge::Scenario& StereoScenario() {
  static const bridge::Scenario scenario =
      bridge::LoadScenario(IAPSIM_SOURCE_DIR "/configs/scenarios/three_star_stereo.yaml");
  return scenario;
}

// the frames the sensors' IMU messages name, on the sub-aircraft they are mounted on
TEST(MountFrames, EachSubAircraftsImuHangsFromItsBody) {
  const MountFrames frames = ReadMountFrames(StereoScenario(), "sensors");
  ASSERT_EQ(frames.fixed.size(), 3u);
  for (int s = 1; s <= 3; ++s) {
    const FrameTransform& imu = frames.fixed[s - 1];
    EXPECT_EQ(imu.parent, "iap/sub" + std::to_string(s));
    EXPECT_EQ(imu.child, "iap/sub" + std::to_string(s) + "/imu");
  }
}

// the seed's stereo rig (§VI-G): 0.198 m ahead of the body origin, eyes 0.12 m apart across it, looking
// forward (the optical z axis along the body's x), and the chase camera left out as moving
TEST(MountFrames, StereoEyesSitWhereTheRigIsAndLookForward) {
  const MountFrames frames = ReadMountFrames(StereoScenario(), "render");
  ASSERT_EQ(frames.fixed.size(), 6u);
  for (int s = 0; s < 3; ++s) {
    const FrameTransform& left = frames.fixed[2 * s];
    const FrameTransform& right = frames.fixed[2 * s + 1];
    const std::string body = "iap/sub" + std::to_string(s + 1);
    EXPECT_EQ(left.parent, body);
    EXPECT_EQ(left.child, body + "/stereo/left_optical");
    EXPECT_EQ(right.child, body + "/stereo/right_optical");
    EXPECT_TRUE((0.5 * (left.p_parent_child_m + right.p_parent_child_m))
                    .isApprox(Eigen::Vector3d(0.198, 0, 0), 1e-12));
    EXPECT_NEAR((left.p_parent_child_m - right.p_parent_child_m).norm(), 0.12, 1e-12);
    EXPECT_TRUE((left.q_parent_child * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
    // the right eye is to the right: +y of an FRD body
    EXPECT_GT(right.p_parent_child_m.y(), left.p_parent_child_m.y());
  }
  ASSERT_EQ(frames.moving.size(), 1u);
  EXPECT_EQ(frames.moving[0], "iap/platform/chase_optical");
}

TEST(MountFrames, AProcessWithoutMountsIsNamed) {
  try {
    ReadMountFrames(StereoScenario(), "physics");
    FAIL() << "no error";
  } catch (const bridge::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'physics' runs iapsim_physics"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadMountFrames(StereoScenario(), "nonesuch"), bridge::ConfigError);
}

}  // namespace
}  // namespace iapsim::rosbridge
