// The OSMesa renderer against geometry: where points appear, stereo disparity, metric depth, and the
// lighting features (shadow, fog, exposure) doing what they say. Small images keep each test quick.

#include "render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "render/testing/markers.h"

namespace iapsim::render {
namespace {

using iapsim::render::testing::Centroid;
using iapsim::render::testing::DiscMarkerScene;

Renderer& SharedRenderer() {
  static std::unique_ptr<Renderer> renderer = MakeRenderer();
  return *renderer;
}

Camera MakeCamera(int width, int height, double hfov_deg) {
  Camera camera;
  camera.intrinsics = CameraIntrinsics::FromHorizontalFov(width, height, hfov_deg * M_PI / 180.0);
  camera.near_m = 0.1;
  camera.far_m = 200.0;
  return camera;
}

// A camera at p_WC looking along `forward_W` with its image's down direction toward +z of W (NED down).
Eigen::Isometry3d LookAlong(const Eigen::Vector3d& p_WC, const Eigen::Vector3d& forward_W) {
  const Eigen::Vector3d z = forward_W.normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitZ().cross(z).normalized();  // right
  const Eigen::Vector3d y = z.cross(x);                                      // down
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear().col(0) = x;
  X_WC.linear().col(1) = y;
  X_WC.linear().col(2) = z;
  X_WC.translation() = p_WC;
  return X_WC;
}

// The disc marker at p_C, facing the camera.
Scene MarkerScene(const Eigen::Isometry3d& X_WC, const Eigen::Vector3d& p_C, double radius_m) {
  return DiscMarkerScene(X_WC * Eigen::Translation3d(p_C), radius_m);
}

TEST(Renderer, MarkerAppearsAtThePinholePixel) {
  Renderer& renderer = SharedRenderer();
  Camera camera = MakeCamera(640, 480, 60.0);
  // a principal point off the centre, so the test sees cx, cy used as given
  camera.intrinsics.cx = 331.25;
  camera.intrinsics.cy = 228.75;
  // the camera 2 m up in NED, looking north-east and slightly down
  const Eigen::Isometry3d X_WC = LookAlong(Eigen::Vector3d(1.0, -2.0, -2.0), Eigen::Vector3d(1.0, 0.6, 0.15));
  Image image;
  for (const Eigen::Vector3d& p_C : {Eigen::Vector3d(0.0, 0.0, 4.0), Eigen::Vector3d(1.3, -0.9, 5.0),
                                     Eigen::Vector3d(-2.1, 1.2, 6.5), Eigen::Vector3d(0.37, 0.81, 3.3)}) {
    // about 44 px across at any depth
    renderer.SetScene(MarkerScene(X_WC, p_C, 0.04 * p_C.z()));
    renderer.Render(camera, X_WC, &image, nullptr);
    const Eigen::Vector2d predicted = camera.intrinsics.Project(p_C);
    const Eigen::Vector2d seen = Centroid(image);
    EXPECT_LT((seen - predicted).norm(), 0.1) << "p_C " << p_C.transpose() << ": seen " << seen.transpose()
                                              << ", pinhole " << predicted.transpose();
  }
}

TEST(Renderer, StereoDisparityIsBaselineTimesFocalOverDepth) {
  Renderer& renderer = SharedRenderer();
  const Camera camera = MakeCamera(640, 480, 70.0);
  const double baseline_m = 0.12;  // seed §VI-G
  const Eigen::Isometry3d X_WL = LookAlong(Eigen::Vector3d(0.0, 0.0, -1.5), Eigen::Vector3d::UnitX());
  const Eigen::Isometry3d X_WR = X_WL * Eigen::Translation3d(baseline_m, 0.0, 0.0);
  Image left, right;
  for (const double depth_m : {1.5, 4.0, 9.0}) {
    const Eigen::Vector3d p_L(0.2, -0.1, depth_m);
    renderer.SetScene(MarkerScene(X_WL, p_L, 0.025 * depth_m));
    renderer.Render(camera, X_WL, &left, nullptr);
    renderer.Render(camera, X_WR, &right, nullptr);
    const Eigen::Vector2d u_left = Centroid(left), u_right = Centroid(right);
    const double expected_px = baseline_m * camera.intrinsics.fx / depth_m;
    EXPECT_NEAR(u_left.x() - u_right.x(), expected_px, 0.1)
        << "depth " << depth_m << " m: left " << u_left.transpose() << " (pinhole "
        << camera.intrinsics.Project(p_L).transpose() << "), right " << u_right.transpose() << " (pinhole "
        << camera.intrinsics.Project(p_L - Eigen::Vector3d(baseline_m, 0, 0)).transpose() << ")";
    EXPECT_NEAR(u_left.y(), u_right.y(), 0.05) << "rectified pair: same row";
  }
}

// The ground plane z_W = 0 seen from 2 m up, pitched down: each pixel's depth is where its ray meets the
// plane; pixels above the horizon see nothing (+inf).
TEST(Renderer, DepthImageMatchesThePlane) {
  Renderer& renderer = SharedRenderer();
  Scene scene;
  scene.sun.shadows = false;
  const int material = scene.AddMaterial(Material{});
  SceneObject ground;
  ground.name = "ground";
  ground.mesh = scene.AddMesh(MakePlane(400.0, 400.0, material));
  scene.AddObject(ground);
  renderer.SetScene(scene);
  const Camera camera = MakeCamera(160, 120, 90.0);
  const Eigen::Isometry3d X_WC = LookAlong(Eigen::Vector3d(0.0, 0.0, -2.0), Eigen::Vector3d(1.0, 0.0, 0.25));
  Image rgb;
  DepthImage depth;
  renderer.Render(camera, X_WC, &rgb, &depth);
  ASSERT_EQ(depth.width, 160);
  ASSERT_EQ(depth.height, 120);
  int on_plane = 0, sky = 0;
  double worst_relative = 0.0;
  const Eigen::Matrix3d K_inverse = camera.intrinsics.K().inverse();
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const Eigen::Vector3d ray_C = K_inverse * Eigen::Vector3d(u, v, 1.0);  // z_C = 1
      const Eigen::Vector3d ray_W = X_WC.linear() * ray_C;
      const double s = -X_WC.translation().z() / ray_W.z();  // ray meets z_W = 0 at depth s
      const float seen = depth.At(u, v);
      if (ray_W.z() > 1e-9 && s < 150.0) {
        ++on_plane;
        worst_relative = std::max(worst_relative, std::abs(seen - s) / s);
      } else if (ray_W.z() < -1e-3) {
        ++sky;
        EXPECT_TRUE(std::isinf(seen) && seen > 0.0f)
            << "pixel " << u << ", " << v << " above the horizon: " << seen;
      }
    }
  }
  EXPECT_GT(on_plane, 5000);
  EXPECT_GT(sky, 1000);
  // depth comes from z_C interpolated across a 400 m plane: float precision, not depth-buffer quantisation
  EXPECT_LT(worst_relative, 1e-4);
}

// Ground and a box 1 m above it, the sun straight down, a camera off to the side: the ground under the box
// is dark with shadows on, lit with them off; ground away from the box is the same either way.
// The box fixed in W, and on a body: the two shadow maps (and the fixed receivers the body's map reaches).
class BoxShadow : public ::testing::TestWithParam<bool> {};

TEST_P(BoxShadow, ShadowsTheGroundBelowIt) {
  const bool on_body = GetParam();
  Renderer& renderer = SharedRenderer();
  Scene scene;
  scene.sun.direction_W = Eigen::Vector3d::UnitZ();
  scene.sun.intensity = 1.0f;
  scene.ambient_intensity = 0.3f;
  scene.sun.shadow_radius_m = 10.0;
  const int grey = scene.AddMaterial(Material{});
  SceneObject ground;
  ground.name = "ground";
  ground.mesh = scene.AddMesh(MakePlane(40.0, 40.0, grey));
  scene.AddObject(ground);
  SceneObject box;
  box.name = "box";
  box.mesh = scene.AddMesh(MakeBox(Eigen::Vector3d(1.0, 1.0, 0.5), grey));
  box.X_BO.translation() = Eigen::Vector3d(0.0, 0.0, on_body ? 0.0 : -1.0);
  if (on_body) box.body = "vehicle/platform";
  scene.AddObject(box);
  const Camera camera = MakeCamera(160, 120, 60.0);
  const Eigen::Isometry3d X_WC = LookAlong(Eigen::Vector3d(-6.0, 0.0, -3.0), Eigen::Vector3d(6.0, 0.0, 3.0));
  const Eigen::Vector2d under_box = camera.intrinsics.Project(X_WC.inverse() * Eigen::Vector3d::Zero());
  const Eigen::Vector2d open_ground =
      camera.intrinsics.Project(X_WC.inverse() * Eigen::Vector3d(0.0, 2.5, 0.0));
  Image with, without;
  const auto render = [&](Image* image) {
    renderer.SetScene(scene);
    if (on_body) {
      renderer.SetBodyPose(renderer.BodyIndex("vehicle/platform"),
                           Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, -1.0)));
    }
    renderer.Render(camera, X_WC, image, nullptr);
  };
  render(&with);
  scene.sun.shadows = false;
  render(&without);
  const auto red = [](const Image& image, const Eigen::Vector2d& uv) {
    return static_cast<int>(image.Pixel(std::lround(uv.x()), std::lround(uv.y()))[0]);
  };
  // albedo 0.6 (linear): lit 0.6 (0.3 + 1) = 0.78, sRGB 229; in shadow 0.6 * 0.3 = 0.18, sRGB 118
  EXPECT_NEAR(red(with, under_box), 118, 6);
  EXPECT_NEAR(red(without, under_box), 229, 3);
  EXPECT_EQ(red(with, open_ground), red(without, open_ground));
}

INSTANTIATE_TEST_SUITE_P(Renderer, BoxShadow, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& param) {
                           return param.param ? "OnABody" : "FixedInTheWorld";
                         });

// A lit wall 50 m away: with fog of 0.05 /m only exp(-2.5) = 8% of its colour is left.
TEST(Renderer, FogTurnsDistantSurfacesToTheFogColour) {
  Renderer& renderer = SharedRenderer();
  Scene scene;
  scene.sun.shadows = false;
  Material red_paint;
  red_paint.color = Eigen::Vector3f(0.8f, 0.1f, 0.1f);
  const int material = scene.AddMaterial(red_paint);
  SceneObject wall;
  wall.name = "wall";
  wall.mesh = scene.AddMesh(MakeBox(Eigen::Vector3d(1.0, 200.0, 200.0), material));
  wall.X_BO.translation() = Eigen::Vector3d(50.5, 0.0, 0.0);
  scene.AddObject(wall);
  scene.fog.color = Eigen::Vector3f(0.7f, 0.7f, 0.75f);
  const Camera camera = MakeCamera(64, 48, 30.0);
  const Eigen::Isometry3d X_WC = LookAlong(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  Image clear, foggy;
  renderer.SetScene(scene);
  renderer.Render(camera, X_WC, &clear, nullptr);
  scene.fog.density_per_m = 0.05f;
  renderer.SetScene(scene);
  renderer.Render(camera, X_WC, &foggy, nullptr);
  const std::uint8_t* c = clear.Pixel(32, 24);
  const std::uint8_t* f = foggy.Pixel(32, 24);
  EXPECT_GT(c[0] - c[1], 100) << "red without fog";
  // 8% of the red wall over 92% fog: within a few levels of the fog's sRGB (179, 179, 191)
  EXPECT_NEAR(f[1], 175, 8);
  EXPECT_NEAR(f[2], 187, 8);
  EXPECT_LT(f[0] - f[1], 25);
}

double Linear(std::uint8_t srgb) {
  const double c = srgb / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

TEST(Renderer, OneStopOfExposureDoublesTheLight) {
  Renderer& renderer = SharedRenderer();
  Scene scene;
  scene.sun.shadows = false;
  scene.sky_color = Eigen::Vector3f::Constant(0.2f);
  Material grey;
  grey.color = Eigen::Vector3f::Constant(0.4f);
  grey.specular = 0.0f;
  SceneObject wall;
  wall.name = "wall";
  wall.mesh = scene.AddMesh(MakeBox(Eigen::Vector3d(0.1, 20.0, 20.0), scene.AddMaterial(grey)));
  wall.X_BO.translation() = Eigen::Vector3d(5.0, 0.0, 0.0);
  scene.AddObject(wall);
  renderer.SetScene(scene);
  Camera camera = MakeCamera(64, 48, 30.0);
  const Eigen::Isometry3d X_WC = LookAlong(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  Image normal, brighter;
  renderer.Render(camera, X_WC, &normal, nullptr);
  camera.exposure_ev = 1.0;
  renderer.Render(camera, X_WC, &brighter, nullptr);
  const double ratio = Linear(brighter.Pixel(32, 24)[0]) / Linear(normal.Pixel(32, 24)[0]);
  EXPECT_NEAR(ratio, 2.0, 0.05);
  EXPECT_GT(Linear(normal.Pixel(32, 24)[0]), 0.05);  // not black: the ratio means something
}

// Lockstep runs must give byte-identical images: the same scene and poses render the same bytes.
TEST(Renderer, SameStateRendersTheSameBytes) {
  Renderer& renderer = SharedRenderer();
  Scene scene;
  const int material = scene.AddMaterial(Material{});
  SceneObject ground, box;
  ground.name = "ground";
  ground.mesh = scene.AddMesh(MakePlane(40.0, 40.0, material));
  box.name = "box";
  box.body = "vehicle/platform";
  box.mesh = scene.AddMesh(MakeBox(Eigen::Vector3d(0.4, 0.4, 0.1), material));
  scene.AddObject(ground);
  scene.AddObject(box);
  renderer.SetScene(scene);
  const int body = renderer.BodyIndex("vehicle/platform");
  ASSERT_GE(body, 0);
  EXPECT_EQ(renderer.BodyIndex("vehicle/nothing"), -1);
  const Camera camera = MakeCamera(96, 72, 70.0);
  const Eigen::Isometry3d X_WC = LookAlong(Eigen::Vector3d(-3.0, 0.0, -2.0), Eigen::Vector3d(3.0, 0.0, 1.5));
  const Eigen::Isometry3d X_WB(Eigen::Translation3d(0.2, 0.1, -1.0) *
                               Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  Image first, second, moved;
  renderer.SetBodyPose(body, X_WB);
  renderer.Render(camera, X_WC, &first, nullptr);
  renderer.SetBodyPose(body, Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, -1.5)));
  renderer.Render(camera, X_WC, &moved, nullptr);
  renderer.SetBodyPose(body, X_WB);
  renderer.Render(camera, X_WC, &second, nullptr);
  EXPECT_EQ(first.rgb, second.rgb);
  EXPECT_NE(first.rgb, moved.rgb) << "the body's pose is drawn";
}

// Every backend this build has draws the same scene alike (OSMesa and Mesa's surfaceless EGL are the same
// llvmpipe here; a GPU may differ by a level where edges fall).
TEST(Renderer, BuiltBackendsDrawAlike) {
  Scene scene = MarkerScene(Eigen::Isometry3d::Identity(), Eigen::Vector3d(0.1, 0.0, 3.0), 0.2);
  const Camera camera = MakeCamera(64, 48, 60.0);
  std::vector<Image> images;
  for (const Backend backend : BuiltBackends()) {
    std::unique_ptr<Renderer> renderer;
    try {
      renderer = MakeRenderer({backend, 0});
    } catch (const std::runtime_error& e) {
      // a build with EGL on a machine without a usable EGL display
      std::cout << "skipping backend " << BackendName(backend) << ": " << e.what() << "\n";
      continue;
    }
    renderer->SetScene(scene);
    images.emplace_back();
    renderer->Render(camera, Eigen::Isometry3d::Identity(), &images.back(), nullptr);
  }
  ASSERT_GE(images.size(), 1u);
  for (std::size_t i = 1; i < images.size(); ++i) {
    int differing = 0;
    for (std::size_t k = 0; k < images[0].rgb.size(); ++k) differing += images[0].rgb[k] != images[i].rgb[k];
    EXPECT_LT(differing, 30) << "bytes that differ between backends 0 and " << i;
  }
  EXPECT_THROW(ParseBackend("vulkan"), std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::render
