// The OSMesa renderer against geometry: where points appear, stereo disparity, metric depth, and the
// lighting features (shadow, fog, exposure) doing what they say. Small images keep each test quick.

#include "render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>

namespace iapsim::render {
namespace {

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

// Black sky, no light: an unlit white disc at p_C facing the camera is the only thing drawn. A disc parallel
// to the image plane images as a circle centred on its centre's projection (a sphere's outline would be an
// ellipse pushed outward from it).
Scene MarkerScene(const Eigen::Isometry3d& X_WC, const Eigen::Vector3d& p_C, double radius_m) {
  Scene scene;
  scene.sky_color.setZero();
  scene.sun.shadows = false;
  Material white;
  white.color.setOnes();
  white.unlit = true;
  const int material = scene.AddMaterial(white);
  SceneObject marker;
  marker.name = "marker";
  marker.mesh = scene.AddMesh(MakeCylinder(radius_m, 1e-4, material, 64));
  marker.X_BO = X_WC * Eigen::Translation3d(p_C);  // the cylinder's axis along z_C
  scene.AddObject(marker);
  return scene;
}

// Intensity-weighted centroid of the image's red channel, pixel-centre convention.
Eigen::Vector2d Centroid(const Image& image) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const double w = image.Pixel(u, v)[0];
      sum += w * Eigen::Vector2d(u, v);
      total += w;
    }
  }
  EXPECT_GT(total, 0.0) << "the marker is not in the image";
  return sum / total;
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

}  // namespace
}  // namespace iapsim::render
