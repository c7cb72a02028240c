#pragma once
// Pinhole cameras. Frame convention of every camera C here: the optical frame of ROS (REP 103/104) and
// OpenCV: x_C right, y_C down, z_C forward along the optical axis. Pixel (u, v) = (0, 0) is the centre of the
// top-left pixel, u to the right, v down; image rows are stored top row first. The world W is NED.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace iapsim::render {

/// Pinhole intrinsics without distortion, in pixels.
struct CameraIntrinsics {
  int width = 640;
  int height = 480;
  double fx = 0.0;  ///< focal length along u, px
  double fy = 0.0;  ///< focal length along v, px
  double cx = 0.0;  ///< principal point, px (pixel-centre convention above)
  double cy = 0.0;

  /// Square pixels with the principal point at the image centre ((width − 1)/2, (height − 1)/2) and the
  /// given horizontal field of view (0, π) rad.
  static CameraIntrinsics FromHorizontalFov(int width, int height, double hfov_rad);

  double HorizontalFov_rad() const;
  double VerticalFov_rad() const;
  /// K = [fx 0 cx; 0 fy cy; 0 0 1].
  Eigen::Matrix3d K() const;
  /// The pixel where a point in front of the camera (p_C.z() > 0) appears, in the convention above.
  Eigen::Vector2d Project(const Eigen::Vector3d& p_C) const;
  /// True when the values describe an image (positive size, positive focal lengths).
  bool IsValid() const;
};

/// What a render of one camera needs besides its pose.
struct Camera {
  CameraIntrinsics intrinsics;
  double near_m = 0.05;      ///< nearest depth drawn, along z_C
  double far_m = 1000.0;     ///< farthest depth drawn, along z_C
  double exposure_ev = 0.0;  ///< exposure compensation in stops: radiance is scaled by 2^exposure_ev
};

/// The rotation from a camera's optical frame C to an FRD "camera body" frame (x forward, y right, z down):
/// R_FC maps z_C (forward) to x_F, x_C (right) to y_F, y_C (down) to z_F. A camera mounted with roll, pitch
/// and yaw zero on an FRD body looks along the body's x axis with the image upright.
Eigen::Matrix3d OpticalToForwardRightDown();

/// The 4x4 OpenGL clip transform of `camera` for eye coordinates equal to C (x right, y down, z forward):
/// a point's window position is its pixel in the convention above, window row 0 being the image's top row.
/// Depth maps [near_m, far_m] to [−1, 1].
Eigen::Matrix4d ClipFromOptical(const Camera& camera);

}  // namespace iapsim::render
