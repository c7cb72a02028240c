// Intrinsics and the GL clip transform, without a GL context.

#include "render/camera.h"

#include <gtest/gtest.h>

#include <cmath>

namespace iapsim::render {
namespace {

TEST(CameraIntrinsics, FieldOfViewGivesFocalLengthAndCentredPrincipalPoint) {
  const CameraIntrinsics k = CameraIntrinsics::FromHorizontalFov(640, 480, M_PI / 2.0);
  EXPECT_DOUBLE_EQ(k.fx, 320.0);  // tan(45°) = 1: half the width
  EXPECT_DOUBLE_EQ(k.fy, 320.0);
  EXPECT_DOUBLE_EQ(k.cx, 319.5);
  EXPECT_DOUBLE_EQ(k.cy, 239.5);
  EXPECT_NEAR(k.HorizontalFov_rad(), M_PI / 2.0, 1e-12);
  EXPECT_NEAR(k.VerticalFov_rad(), 2.0 * std::atan(240.0 / 320.0), 1e-12);
  EXPECT_THROW(CameraIntrinsics::FromHorizontalFov(640, 480, M_PI), std::invalid_argument);
}

TEST(CameraIntrinsics, ProjectsThroughThePinhole) {
  CameraIntrinsics k;
  k.fx = 400.0, k.fy = 410.0, k.cx = 300.0, k.cy = 250.0;
  const Eigen::Vector2d uv = k.Project(Eigen::Vector3d(0.5, -0.25, 2.0));
  EXPECT_DOUBLE_EQ(uv.x(), 400.0 * 0.25 + 300.0);
  EXPECT_DOUBLE_EQ(uv.y(), 410.0 * -0.125 + 250.0);
}

// The clip transform puts a point's window coordinates at its pixel centre + 0.5 and its depth at the
// near and far planes' ends of [−1, 1].
TEST(ClipFromOptical, WindowCoordinatesArePixelCentres) {
  Camera camera;
  camera.intrinsics.width = 640, camera.intrinsics.height = 480;
  camera.intrinsics.fx = 500.0, camera.intrinsics.fy = 520.0, camera.intrinsics.cx = 310.2,
  camera.intrinsics.cy = 245.7;
  camera.near_m = 0.1, camera.far_m = 100.0;
  const Eigen::Matrix4d clip = ClipFromOptical(camera);
  for (const Eigen::Vector3d& p_C : {Eigen::Vector3d(0.3, -0.2, 3.0), Eigen::Vector3d(-1.0, 0.7, 7.5)}) {
    const Eigen::Vector4d q = clip * p_C.homogeneous();
    const Eigen::Vector2d window(0.5 * (q.x() / q.w() + 1.0) * 640, 0.5 * (q.y() / q.w() + 1.0) * 480);
    const Eigen::Vector2d uv = camera.intrinsics.Project(p_C);
    EXPECT_NEAR(window.x(), uv.x() + 0.5, 1e-9);
    EXPECT_NEAR(window.y(), uv.y() + 0.5, 1e-9);
  }
  const Eigen::Vector4d near = clip * Eigen::Vector4d(0.0, 0.0, 0.1, 1.0);
  const Eigen::Vector4d far = clip * Eigen::Vector4d(0.0, 0.0, 100.0, 1.0);
  EXPECT_NEAR(near.z() / near.w(), -1.0, 1e-12);
  EXPECT_NEAR(far.z() / far.w(), 1.0, 1e-12);
}

TEST(OpticalToForwardRightDown, LooksAlongTheBodyXAxisUpright) {
  const Eigen::Matrix3d R_FC = OpticalToForwardRightDown();
  EXPECT_TRUE((R_FC * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitX()));  // forward
  EXPECT_TRUE((R_FC * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY()));  // right
  EXPECT_TRUE((R_FC * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d::UnitZ()));  // down
  EXPECT_NEAR(R_FC.determinant(), 1.0, 1e-12);
}

}  // namespace
}  // namespace iapsim::render
