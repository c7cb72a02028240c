#include "vio/stereo_rig.h"

#include <stdexcept>

namespace iapsim::vio {

StereoRig StereoRig::FromCamera(const render::CameraConfig& camera, const Eigen::Isometry3d& X_BI) {
  if (camera.mount.kind != render::CameraMount::Kind::kBody || !(camera.baseline_m > 0.0)) {
    throw std::invalid_argument("camera '" + camera.name + "'" +
                                (camera.mount.body.empty() ? "" : " on '" + camera.mount.body + "'") +
                                ": visual odometry needs a stereo pair (baseline_m > 0) mounted on a body");
  }
  StereoRig rig;
  rig.intrinsics = camera.camera.intrinsics;
  rig.baseline_m = camera.baseline_m;
  // The render rig's own placement of the eyes, with the body at the origin: X_BL.
  const Eigen::Isometry3d X_BL = render::CameraPoses_W(camera, Eigen::Isometry3d::Identity()).front();
  rig.X_IL = X_BI.inverse() * X_BL;
  return rig;
}

std::optional<Eigen::Vector3d> StereoRig::Triangulate(const Eigen::Vector2d& uv_left, double disparity_px,
                                                      double min_disparity_px) const {
  if (!(disparity_px > min_disparity_px)) return std::nullopt;
  const double depth_m = intrinsics.fx * baseline_m / disparity_px;
  const Eigen::Vector2d xy = Normalised(uv_left);
  return Eigen::Vector3d(xy.x() * depth_m, xy.y() * depth_m, depth_m);
}

Eigen::Vector2d StereoRig::Normalised(const Eigen::Vector2d& uv) const {
  return {(uv.x() - intrinsics.cx) / intrinsics.fx, (uv.y() - intrinsics.cy) / intrinsics.fy};
}

}  // namespace iapsim::vio
