#include "render/camera.h"

#include <cmath>
#include <stdexcept>

namespace iapsim::render {

CameraIntrinsics CameraIntrinsics::FromHorizontalFov(int width, int height, double hfov_rad) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("camera size must be positive");
  if (!(hfov_rad > 0.0 && hfov_rad < M_PI))
    throw std::invalid_argument("horizontal field of view must be in (0, pi)");
  CameraIntrinsics k;
  k.width = width;
  k.height = height;
  // the left edge of pixel 0 and the right edge of pixel width-1 are at ±hfov/2
  k.fx = 0.5 * width / std::tan(0.5 * hfov_rad);
  k.fy = k.fx;
  k.cx = 0.5 * (width - 1);
  k.cy = 0.5 * (height - 1);
  return k;
}

double CameraIntrinsics::HorizontalFov_rad() const { return 2.0 * std::atan(0.5 * width / fx); }
double CameraIntrinsics::VerticalFov_rad() const { return 2.0 * std::atan(0.5 * height / fy); }

Eigen::Matrix3d CameraIntrinsics::K() const {
  Eigen::Matrix3d k;
  k << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return k;
}

Eigen::Vector2d CameraIntrinsics::Project(const Eigen::Vector3d& p_C) const {
  return Eigen::Vector2d(fx * p_C.x() / p_C.z() + cx, fy * p_C.y() / p_C.z() + cy);
}

bool CameraIntrinsics::IsValid() const {
  return width > 0 && height > 0 && fx > 0.0 && fy > 0.0 && std::isfinite(cx) && std::isfinite(cy);
}

Eigen::Matrix3d OpticalToForwardRightDown() {
  Eigen::Matrix3d R_FC;
  // columns: x_C, y_C, z_C expressed in F
  R_FC << 0.0, 0.0, 1.0,  //
      1.0, 0.0, 0.0,      //
      0.0, 1.0, 0.0;
  return R_FC;
}

Eigen::Matrix4d ClipFromOptical(const Camera& camera) {
  const CameraIntrinsics& k = camera.intrinsics;
  const double n = camera.near_m;
  const double f = camera.far_m;
  // GL's window x of pixel u's centre is u + 0.5: x_ndc = 2 (u + 0.5) / W − 1 with u = fx x/z + cx, and
  // clip w = z; rows likewise with v (window row 0 = image row 0, so the image needs no flip on read-back)
  Eigen::Matrix4d clip = Eigen::Matrix4d::Zero();
  clip(0, 0) = 2.0 * k.fx / k.width;
  clip(0, 2) = 2.0 * (k.cx + 0.5) / k.width - 1.0;
  clip(1, 1) = 2.0 * k.fy / k.height;
  clip(1, 2) = 2.0 * (k.cy + 0.5) / k.height - 1.0;
  // z_ndc = (A z + B) / z, −1 at z = n and +1 at z = f
  clip(2, 2) = (f + n) / (f - n);
  clip(2, 3) = -2.0 * f * n / (f - n);
  clip(3, 2) = 1.0;
  return clip;
}

}  // namespace iapsim::render
