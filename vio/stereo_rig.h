#pragma once
// The rectified stereo pair of one sub-aircraft as the estimator sees it (seed §VI-G: 640×480, 12 cm
// baseline, image planes 19.8 cm in front of the IMU, no distortion): both eyes share the pinhole intrinsics,
// the right eye sits `baseline_m` along x of the left optical frame L, and X_IL places L in the IMU frame I.
// Built from the run's own render configuration, so the estimator and the renderer cannot disagree.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>

#include "render/camera.h"
#include "render/camera_rig.h"

namespace iapsim::vio {

struct StereoRig {
  render::CameraIntrinsics intrinsics;
  double baseline_m = 0.0;
  Eigen::Isometry3d X_IL =
      Eigen::Isometry3d::Identity();  ///< left optical frame (x right, y down, z forward)

  /// The rig of a body-mounted stereo camera of the render configuration, for an IMU at X_BI on that body.
  /// Throws std::invalid_argument naming the camera when it is not a body-mounted pair.
  static StereoRig FromCamera(const render::CameraConfig& camera, const Eigen::Isometry3d& X_BI);

  /// The left-eye point of a left pixel and its disparity u_left − u_right (> 0), or nothing for a
  /// disparity at or below `min_disparity_px` (too far to range).
  std::optional<Eigen::Vector3d> Triangulate(const Eigen::Vector2d& uv_left, double disparity_px,
                                             double min_disparity_px = 0.5) const;
  /// The normalised image coordinates (x/z, y/z) of a pixel.
  Eigen::Vector2d Normalised(const Eigen::Vector2d& uv) const;
};

}  // namespace iapsim::vio
