#pragma once
// Cameras as a scenario places them (seed §V-B): fixed in the world, rigidly on a body with an offset, or
// chasing a body; mono or a rectified stereo pair; each with its intrinsics, exposure and rate. The render
// process reads them with ReadCameras and asks CameraPoses_W for the optical frames at each drawn state.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "bridge/config.h"
#include "render/camera.h"

namespace iapsim::render {

struct CameraMount {
  enum class Kind {
    kWorld,  ///< fixed: X_WF
    kBody,   ///< rigidly on `body`: X_BF
    kChase,  ///< behind and above `body` along its heading, looking at it, image upright
  };
  Kind kind = Kind::kWorld;
  std::string body;  ///< kBody, kChase: the body's name as the scene's objects give it ("iap/sub1")
  /// The rig's FRD frame F (x forward, y right, z down; the optical frame C is F turned by
  /// OpticalToForwardRightDown) in B for kBody, in W for kWorld. Identity looks along the body's x axis.
  Eigen::Isometry3d X_PF = Eigen::Isometry3d::Identity();
  double chase_distance_m = 3.0;  ///< kChase: behind the body, horizontally
  double chase_height_m = 1.0;    ///< kChase: above the body (against +z of NED)
};

struct CameraConfig {
  std::string name;
  CameraMount mount;
  Camera camera;
  double rate_hz = 20.0;
  /// > 0: a rectified stereo pair, optical centres at ∓baseline/2 along x_C of the rig (left, right) with
  /// parallel axes; 0: one camera at the rig.
  double baseline_m = 0.0;
  bool publish_raw = false;    ///< also the uncompressed image
  bool publish_depth = false;  ///< also the metric depth image

  /// "" for a mono camera; "left" and "right" for a stereo pair.
  std::vector<std::string> EyeNames() const;
  /// The topic namespace of an eye: "/<body>/<name>[/<eye>]" ("/iap/sub1/stereo/left"), "/<name>[/<eye>]"
  /// for a world-fixed camera. Its images go to <namespace>/image_raw[/compressed], <namespace>/camera_info
  /// and <namespace>/depth/image_raw.
  std::string TopicNamespace(int eye) const;
  /// The optical frame's name in message headers: the namespace without the leading '/' + "_optical".
  std::string OpticalFrameId(int eye) const;
};

/// X_WC of each eye (EyeNames order). X_WB is the mount's body pose (ignored for kWorld).
std::vector<Eigen::Isometry3d> CameraPoses_W(const CameraConfig& config, const Eigen::Isometry3d& X_WB);

/// The list of cameras under `key` (absent: none). Each: name, mount (body | world | chase), body, position_m
/// and rpy_deg (of F), width, height and either hfov_deg or fx, fy, cx, cy, near_m, far_m, exposure_ev,
/// rate_hz, baseline_m, raw, depth, chase {distance_m, height_m}. Throws bridge::ConfigError with the line.
std::vector<CameraConfig> ReadCameras(bridge::YamlMap& map, const std::string& key);

}  // namespace iapsim::render
