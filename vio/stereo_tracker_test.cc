#include "vio/stereo_tracker.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "render/renderer.h"
#include "render/scene_config.h"
#include "vio/testing/synthetic.h"

namespace iapsim::vio {
namespace {

// The seed's stereo camera (§VI-G), rendered in the textured yard of Fig. 17 (a)-2; the renderer's depth
// image is the ground truth every check compares against.
using testing::SeedStereoCamera;

struct StereoShot {
  Eigen::Isometry3d X_WL;  // left optical frame
  render::Image left, right;
  render::DepthImage depth_left;
};

class StereoTrackerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    renderer_ = render::MakeRenderer().release();
    renderer_->SetScene(
        render::LoadScene(std::string(IAPSIM_SOURCE_DIR) + "/configs/scenes/textured_walls.yaml"));
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }

  // The body 2 m above the yard's floor, 5 m south of the north wall, looking at it and the floor (pitched
  // 20° down), displaced by `p_m` and yawed by `yaw_deg`.
  static StereoShot Shoot(const Eigen::Vector3d& p_m = Eigen::Vector3d::Zero(), double yaw_deg = 0.0) {
    const render::CameraConfig camera = SeedStereoCamera();
    Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
    X_WB.translation() = Eigen::Vector3d(7.0, 0.0, -2.0) + p_m;
    X_WB.linear() = (Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(-20.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()))
                        .toRotationMatrix();
    const std::vector<Eigen::Isometry3d> X_WC = render::CameraPoses_W(camera, X_WB);
    StereoShot shot;
    shot.X_WL = X_WC[0];
    renderer_->Render(camera.camera, X_WC[0], &shot.left, &shot.depth_left);
    renderer_->Render(camera.camera, X_WC[1], &shot.right, nullptr);
    return shot;
  }

  static StereoRig Rig() { return testing::SeedRig(); }

  static double Median(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    return values.empty() ? NAN : values[values.size() / 2];
  }

  static render::Renderer* renderer_;
};

render::Renderer* StereoTrackerTest::renderer_ = nullptr;

TEST_F(StereoTrackerTest, StereoMatchesGiveTheRenderedDepth) {
  const StereoShot shot = Shoot();
  const StereoRig rig = Rig();
  StereoTracker tracker(rig);
  const StereoFrame frame = tracker.Track(0.0, shot.left, shot.right);
  ASSERT_GE(frame.features.size(), 120u);
  EXPECT_TRUE(frame.keyframe);
  std::vector<double> relative_error;
  for (const TrackedFeature& f : frame.features) {
    if (!f.uv_right) continue;
    EXPECT_NEAR(f.uv_right->y(), f.uv_left.y(), 1.5);
    const auto p_L = rig.Triangulate(f.uv_left, f.uv_left.x() - f.uv_right->x());
    if (!p_L) continue;
    const double truth_m = shot.depth_left.At(static_cast<int>(std::lround(f.uv_left.x())),
                                              static_cast<int>(std::lround(f.uv_left.y())));
    relative_error.push_back(std::abs(p_L->z() - truth_m) / truth_m);
  }
  // Most corners find their match (the rest are near the image's left edge, out of the right eye's view).
  EXPECT_GE(relative_error.size(), frame.features.size() * 8 / 10);
  // The wall and floor are 3-6 m away, 6-13 px of disparity: 0.1 px of matching error would be about 1 % of
  // depth (measured: 146 of 150 matched, median 0.4 %).
  EXPECT_LT(Median(relative_error), 0.015);
}

TEST_F(StereoTrackerTest, TracksFollowTheKnownMotionOfTheCamera) {
  const StereoShot first = Shoot();
  const StereoShot second = Shoot(Eigen::Vector3d(0.15, 0.08, -0.05), 3.0);
  const StereoRig rig = Rig();
  StereoTracker tracker(rig);
  const StereoFrame frame0 = tracker.Track(0.0, first.left, first.right);
  const StereoFrame frame1 = tracker.Track(0.05, second.left, second.right);
  std::map<std::uint64_t, Eigen::Vector2d> uv0;
  for (const TrackedFeature& f : frame0.features) uv0[f.id] = f.uv_left;

  // Each tracked corner, lifted to 3-D with the first frame's rendered depth, must land where the second
  // camera sees it.
  const render::CameraIntrinsics& K = rig.intrinsics;
  std::vector<double> error_px;
  for (const TrackedFeature& f : frame1.features) {
    const auto it = uv0.find(f.id);
    if (it == uv0.end()) continue;
    EXPECT_EQ(f.track_length, 2);
    const Eigen::Vector2d& uv = it->second;
    const double depth_m =
        first.depth_left.At(static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y())));
    const Eigen::Vector3d p_W =
        first.X_WL * (depth_m * Eigen::Vector3d(rig.Normalised(uv).x(), rig.Normalised(uv).y(), 1.0));
    error_px.push_back((K.Project(second.X_WL.inverse() * p_W) - f.uv_left).norm());
  }
  // Measured: 126 of 150 tracked (the rest left the view or failed the checks), median 0.12 px, p90 0.29 px.
  EXPECT_GE(error_px.size(), frame0.features.size() * 7 / 10);
  EXPECT_LT(Median(error_px), 0.25);
  std::sort(error_px.begin(), error_px.end());
  EXPECT_LT(error_px[error_px.size() * 9 / 10], 0.6);
  // The same number of features again: lost ones replaced by new corners with new ids.
  EXPECT_GE(frame1.features.size(), 140u);
  EXPECT_GT(frame1.features.back().id, frame0.features.back().id);
}

TEST_F(StereoTrackerTest, KeyframesComeWithParallaxOrWhenTracksAreLost) {
  const StereoShot still = Shoot();
  const StereoShot turned = Shoot(Eigen::Vector3d::Zero(), 6.0);       // ≈ 34 px of image motion
  const StereoShot elsewhere = Shoot(Eigen::Vector3d::Zero(), 120.0);  // nothing in common
  StereoTracker tracker(Rig());
  EXPECT_TRUE(tracker.Track(0.0, still.left, still.right).keyframe);
  const StereoFrame again = tracker.Track(0.05, still.left, still.right);
  EXPECT_FALSE(again.keyframe);
  EXPECT_LT(again.parallax_px, 0.05);
  EXPECT_EQ(again.rejected_forward_backward + again.rejected_ransac, 0);
  const StereoFrame after_turn = tracker.Track(0.1, turned.left, turned.right);
  EXPECT_TRUE(after_turn.keyframe);
  EXPECT_GT(after_turn.parallax_px, 20.0);
  EXPECT_GT(after_turn.tracked_since_keyframe, 80);
  const StereoFrame lost = tracker.Track(0.15, elsewhere.left, elsewhere.right);
  EXPECT_TRUE(lost.keyframe);
  EXPECT_LT(lost.tracked_since_keyframe, 20);
  EXPECT_GT(lost.rejected_forward_backward + lost.rejected_ransac, 100);
}

TEST_F(StereoTrackerTest, TheSameImagesGiveTheSameFeatures) {
  const StereoShot first = Shoot();
  const StereoShot second = Shoot(Eigen::Vector3d(0.1, 0.0, 0.0), 2.0);
  std::vector<StereoFrame> runs[2];
  for (auto& run : runs) {
    StereoTracker tracker(Rig());
    run.push_back(tracker.Track(0.0, first.left, first.right));
    run.push_back(tracker.Track(0.05, second.left, second.right));
  }
  for (int k = 0; k < 2; ++k) {
    ASSERT_EQ(runs[0][k].features.size(), runs[1][k].features.size());
    for (std::size_t i = 0; i < runs[0][k].features.size(); ++i) {
      const TrackedFeature &a = runs[0][k].features[i], &b = runs[1][k].features[i];
      EXPECT_EQ(a.id, b.id);
      EXPECT_EQ(a.uv_left, b.uv_left);
      EXPECT_EQ(a.uv_right.has_value(), b.uv_right.has_value());
      if (a.uv_right && b.uv_right) {
        EXPECT_EQ(*a.uv_right, *b.uv_right);
      }
    }
  }
}

TEST(StereoRigTest, ComesFromTheRenderConfigurationAndRefusesWhatIsNotAStereoPair) {
  const StereoRig rig = StereoRig::FromCamera(SeedStereoCamera(), Eigen::Isometry3d::Identity());
  // The left eye: 19.8 cm ahead of the IMU and 6 cm to its left (−y of FRD), looking forward (z_L = x_I).
  EXPECT_LT((rig.X_IL.translation() - Eigen::Vector3d(0.198, -0.06, 0.0)).norm(), 1e-12);
  EXPECT_LT((rig.X_IL.linear() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  const Eigen::Vector3d p_L = *rig.Triangulate(Eigen::Vector2d(rig.intrinsics.cx, rig.intrinsics.cy), 4.0);
  EXPECT_NEAR(p_L.z(), rig.intrinsics.fx * 0.12 / 4.0, 1e-12);
  EXPECT_FALSE(rig.Triangulate(Eigen::Vector2d(100, 100), 0.2).has_value());

  render::CameraConfig mono = SeedStereoCamera();
  mono.baseline_m = 0.0;
  try {
    StereoRig::FromCamera(mono, Eigen::Isometry3d::Identity());
    FAIL() << "a mono camera was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("camera 'stereo' on 'iap/sub1'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("baseline_m"), std::string::npos) << e.what();
  }
}

TEST(StereoTrackerSizeTest, AnImageOfAnotherSizeIsAClearError) {
  StereoTracker tracker(StereoRig::FromCamera(SeedStereoCamera(), Eigen::Isometry3d::Identity()));
  render::Image small;
  small.width = 320;
  small.height = 240;
  small.rgb.assign(320 * 240 * 3, 0);
  try {
    tracker.Track(0.0, small, small);
    FAIL() << "a 320x240 image was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("left image is 320x240, the camera model expects 640x480"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace iapsim::vio
