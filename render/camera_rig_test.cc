// Cameras read from YAML and placed on bodies, and a vehicle drawn on its bodies.

#include "render/camera_rig.h"

#include <gtest/gtest.h>

#include "render/renderer.h"
#include "render/vehicle_visual.h"

namespace iapsim::render {
namespace {

std::vector<CameraConfig> Read(const std::string& yaml) {
  bridge::YamlMap map(YAML::Load(yaml), "test.yaml");
  auto cameras = ReadCameras(map, "cameras");
  map.Finish();
  return cameras;
}

// Seed §VI-G: a stereo camera per sub-aircraft, 640x480, 12 cm baseline, image planes 19.8 cm in front of
// the IMU (at the sub-aircraft's centre of mass), no distortion, about 20 Hz.
TEST(CameraRig, SeedStereoPairSitsInFrontOfTheImu) {
  const auto cameras = Read(R"(
cameras:
  - {name: stereo, body: iap/sub1, position_m: [0.198, 0, 0], width: 640, height: 480, hfov_deg: 90,
     baseline_m: 0.12, rate_hz: 20}
)");
  ASSERT_EQ(cameras.size(), 1u);
  const CameraConfig& stereo = cameras[0];
  EXPECT_EQ(stereo.EyeNames(), (std::vector<std::string>{"left", "right"}));
  EXPECT_DOUBLE_EQ(stereo.camera.intrinsics.fx, 320.0);
  EXPECT_DOUBLE_EQ(stereo.rate_hz, 20.0);
  const Eigen::Isometry3d X_WB(Eigen::Translation3d(1.0, 2.0, -3.0) *
                               Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 0.3, 1.0).normalized()));
  const auto X_WC = CameraPoses_W(stereo, X_WB);
  ASSERT_EQ(X_WC.size(), 2u);
  // left eye 6 cm to the body's left (−y_B), right eye 6 cm to its right, both looking along x_B
  EXPECT_TRUE(X_WC[0].translation().isApprox(X_WB * Eigen::Vector3d(0.198, -0.06, 0.0), 1e-12));
  EXPECT_TRUE(X_WC[1].translation().isApprox(X_WB * Eigen::Vector3d(0.198, 0.06, 0.0), 1e-12));
  for (const auto& X : X_WC) {
    EXPECT_TRUE((X.linear() * Eigen::Vector3d::UnitZ()).isApprox(X_WB.linear() * Eigen::Vector3d::UnitX()));
    EXPECT_TRUE((X.linear() * Eigen::Vector3d::UnitY()).isApprox(X_WB.linear() * Eigen::Vector3d::UnitZ()));
  }
}

TEST(CameraRig, ChaseCameraLooksAtItsBodyAndWorldCameraStays) {
  const auto cameras = Read(R"(
cameras:
  - {name: chase, mount: chase, body: iap/platform, chase: {distance_m: 4, height_m: 1.5}, fx: 500, fy: 500,
     cx: 320, cy: 240}
  - {name: tower, mount: world, position_m: [-10, 0, -5], rpy_deg: [0, -20, 0]}
)");
  ASSERT_EQ(cameras.size(), 2u);
  const Eigen::Isometry3d X_WB(Eigen::Translation3d(3.0, -1.0, -2.0) *
                               Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()));
  const Eigen::Isometry3d X_WC = CameraPoses_W(cameras[0], X_WB).at(0);
  // the body is on the optical axis, 4 m behind along its heading and 1.5 m above
  const Eigen::Vector3d p_CB = X_WC.inverse() * X_WB.translation();
  EXPECT_NEAR(p_CB.x(), 0.0, 1e-12);
  EXPECT_NEAR(p_CB.y(), 0.0, 1e-12);
  EXPECT_NEAR(p_CB.z(), std::hypot(4.0, 1.5), 1e-12);
  EXPECT_NEAR(X_WC.translation().z(), -3.5, 1e-12);
  // upright: the image's x axis is horizontal
  EXPECT_NEAR((X_WC.linear() * Eigen::Vector3d::UnitX()).z(), 0.0, 1e-12);
  const Eigen::Isometry3d tower = CameraPoses_W(cameras[1], X_WB).at(0);
  EXPECT_TRUE(tower.translation().isApprox(Eigen::Vector3d(-10.0, 0.0, -5.0)));
  // pitch −20° (FRD: positive pitch raises the nose) looks 20° down, toward +z of NED
  EXPECT_NEAR((tower.linear() * Eigen::Vector3d::UnitZ()).z(), std::sin(20.0 * M_PI / 180.0), 1e-12);
}

TEST(CameraRig, BadCameraKeysNameTheLine) {
  const auto error = [](const std::string& yaml) {
    try {
      Read(yaml);
    } catch (const bridge::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("cameras:\n  - {name: a, body: b, hfov_deg: 60, fx: 300}\n").find("test.yaml:2:"),
            std::string::npos);
  EXPECT_NE(error("cameras:\n  - {name: a}\n").find("body: is required"), std::string::npos);
  EXPECT_NE(error("cameras:\n  - {name: a, body: b}\n  - {name: a, body: b}\n").find("a second camera"),
            std::string::npos);
  EXPECT_NE(error("cameras:\n  - {name: a, body: b, rate_hz: 0}\n").find("rate_hz"), std::string::npos);
}

// The three-star IAP seen from above: sub-aircraft 1's frame is where its body pose puts it, and moves with
// it.
TEST(VehicleVisual, SubAircraftAreDrawnOnTheirBodies) {
  const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  Scene scene;
  scene.sun.shadows = false;
  AddVehicle(&scene, vehicle, "iap");
  EXPECT_EQ(scene.Bodies(), (std::vector<std::string>{"iap/platform", "iap/sub1", "iap/sub2", "iap/sub3"}));
  std::unique_ptr<Renderer> renderer = MakeRenderer();
  renderer->SetScene(scene);
  const Eigen::Isometry3d X_WP(Eigen::Translation3d(0.0, 0.0, -2.0));
  renderer->SetBodyPose(renderer->BodyIndex("iap/platform"), X_WP);
  for (const model::SubAircraft& sub : vehicle.sub_aircraft) {
    renderer->SetBodyPose(renderer->BodyIndex(SubAircraftBody("iap", sub)),
                          X_WP * Eigen::Translation3d(sub.joint_P_m) *
                              Eigen::AngleAxisd(sub.initial_yaw_rad, Eigen::Vector3d::UnitZ()));
  }
  Camera camera;
  camera.intrinsics = CameraIntrinsics::FromHorizontalFov(128, 128, 60.0 * M_PI / 180.0);
  // 3 m above the platform looking straight down, image up = north
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // x_C east, y_C south, z_C down
  X_WC.translation() = Eigen::Vector3d(0.0, 0.0, -5.0);
  Image image;
  renderer->Render(camera, X_WC, &image, nullptr);
  const Eigen::Vector2d frame_uv =
      camera.intrinsics.Project(X_WC.inverse() * Eigen::Vector3d(0.48, 0.0, -2.0));
  const std::uint8_t* frame = image.Pixel(std::lround(frame_uv.x()), std::lround(frame_uv.y()));
  EXPECT_GT(frame[0], frame[2] + 80) << "sub1's frame is red (with the sun's highlight)";
  // move sub1 5 m away: the sky shows where it was
  renderer->SetBodyPose(renderer->BodyIndex("iap/sub1"),
                        Eigen::Isometry3d(Eigen::Translation3d(20.0, 0.0, -2.0)));
  renderer->Render(camera, X_WC, &image, nullptr);
  const std::uint8_t* sky = image.Pixel(std::lround(frame_uv.x()), std::lround(frame_uv.y()));
  EXPECT_GT(sky[2], sky[0]) << "the blue-grey sky where sub1 was";
}

}  // namespace
}  // namespace iapsim::render
