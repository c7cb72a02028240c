// A scenario's cameras over one renderer: body poses move what is drawn on a body and the cameras mounted on
// it together, a stereo pair sees the seed's disparity, the PNG is the image, and the messages carry the
// pinhole ROS tools expect.

#include "render/camera_system.h"

#include <gtest/gtest.h>

#include <cstring>

#include "render/camera_messages.h"
#include "render/testing/markers.h"

namespace iapsim::render {
namespace {

using iapsim::render::testing::Centroid;
using iapsim::render::testing::DiscMarkerScene;

constexpr double kMarkerAhead_m = 2.0;  // on the body's x axis

std::vector<CameraConfig> Cameras(const std::string& yaml) {
  bridge::YamlMap map(YAML::Load(yaml), "test.yaml");
  auto cameras = ReadCameras(map, "cameras");
  map.Finish();
  return cameras;
}

// The disc marker on body "iap/sub1", facing back along the body's x axis (the cylinder's axis z_O along
// x_B).
Scene MarkerOnBody() {
  return DiscMarkerScene(
      Eigen::Translation3d(kMarkerAhead_m, 0.0, 0.0) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()),
      0.2, "iap/sub1");
}

const char* const kRig = R"(
cameras:
  - {name: stereo, body: iap/sub1, position_m: [0.198, 0, 0], width: 160, height: 120, hfov_deg: 90,
     baseline_m: 0.12, rate_hz: 20}
  - {name: tower, mount: world, position_m: [-3, 0, -1], width: 80, height: 60, depth: true}
)";

TEST(CameraSystem, CamerasOnABodyMoveWithWhatIsDrawnOnIt) {
  CameraSystem system(MarkerOnBody(), Cameras(kRig), {});
  std::vector<EyeFrame> frames;
  const Eigen::Vector3d p_L(0.06, 0.0, kMarkerAhead_m - 0.198);  // the marker in the left eye's optical frame
  const CameraIntrinsics& k = system.cameras()[0].camera.intrinsics;
  for (const Eigen::Isometry3d& X_WB :
       {Eigen::Isometry3d::Identity(),
        Eigen::Isometry3d(Eigen::Translation3d(4.0, -2.0, -3.0) *
                          Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.2, 1.0).normalized()))}) {
    system.SetBodyPose("iap/sub1", X_WB);
    system.Render({0}, &frames);
    ASSERT_EQ(frames.size(), 2u);
    EXPECT_EQ(frames[0].eye, 0);
    EXPECT_EQ(frames[1].eye, 1);
    const Eigen::Vector2d left = Centroid(frames[0].rgb), right = Centroid(frames[1].rgb);
    EXPECT_LT((left - k.Project(p_L)).norm(), 0.2) << "the marker rides with the camera wherever the body is";
    EXPECT_NEAR(left.x() - right.x(), 0.12 * k.fx / p_L.z(), 0.2) << "disparity b·fx/Z";
    EXPECT_EQ(DecodeImage(frames[0].png, "left").rgb, frames[0].rgb.rgb) << "the PNG is the image, lossless";
    EXPECT_TRUE(frames[0].depth.depth_m.empty()) << "no depth asked for";
  }
}

TEST(CameraSystem, RendersOnlyTheCamerasAskedForAndNeedsTheirMountPoses) {
  CameraSystem system(MarkerOnBody(), Cameras(kRig), {});
  EXPECT_EQ(system.MissingMounts(), std::vector<std::string>{"iap/sub1"});
  std::vector<EyeFrame> frames;
  system.Render({1}, &frames);  // the world-fixed camera needs no body
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].camera, 1);
  EXPECT_EQ(frames[0].rgb.width, 80);
  EXPECT_EQ(frames[0].depth.width, 80) << "depth: true";
  EXPECT_THROW(system.Render({0}, &frames), std::logic_error);
  system.SetBodyPose("iap/other", Eigen::Isometry3d::Identity());
  EXPECT_FALSE(system.MissingMounts().empty());
  system.SetBodyPose("iap/sub1", Eigen::Isometry3d::Identity());
  EXPECT_TRUE(system.MissingMounts().empty());
}

TEST(CameraMessages, RightEyeCarriesTheBaselineInP) {
  const std::vector<CameraConfig> cameras = Cameras(kRig);
  const CameraConfig& stereo = cameras[0];
  const std_msgs::Header right_header = EyeHeader(stereo, 1, 1250000000);
  EXPECT_EQ(right_header.frame_id, "iap/sub1/stereo/right_optical");
  EXPECT_EQ(right_header.stamp.sec, 1u);
  EXPECT_EQ(right_header.stamp.nsec, 250000000u);
  EXPECT_EQ(stereo.TopicNamespace(0), "/iap/sub1/stereo/left");
  EXPECT_EQ(cameras[1].TopicNamespace(0), "/tower");

  const CameraIntrinsics& k = stereo.camera.intrinsics;
  const sensor_msgs::CameraInfo left = CameraInfoMessage(stereo, 0, EyeHeader(stereo, 0, 0));
  const sensor_msgs::CameraInfo right = CameraInfoMessage(stereo, 1, right_header);
  EXPECT_EQ(left.width, 160u);
  EXPECT_EQ(left.height, 120u);
  EXPECT_EQ(left.K[0], k.fx);
  EXPECT_EQ(left.K[2], k.cx);
  EXPECT_EQ(left.K[5], k.cy);
  EXPECT_EQ(left.P[3], 0.0);
  // image_geometry's StereoCameraModel: baseline = −Tx / fx
  EXPECT_NEAR(-right.P[3] / right.P[0], 0.12, 1e-12);
  for (const double d : right.D) EXPECT_EQ(d, 0.0);
}

TEST(CameraMessages, DepthIsThirtyTwoBitFloatMetres) {
  DepthImage depth;
  depth.width = 2;
  depth.height = 1;
  depth.depth_m = {1.5f, std::numeric_limits<float>::infinity()};
  const sensor_msgs::Image message = DepthMessage(depth, std_msgs::Header());
  EXPECT_EQ(message.encoding, "32FC1");
  EXPECT_EQ(message.step, 8u);
  float back[2];
  ASSERT_EQ(message.data.size(), sizeof(back));
  std::memcpy(back, message.data.data(), sizeof(back));
  EXPECT_EQ(back[0], 1.5f);
  EXPECT_TRUE(std::isinf(back[1]));
}

}  // namespace
}  // namespace iapsim::render
