#include "render/camera_rig.h"

#include <cctype>
#include <cmath>
#include <set>

#include "model/vehicle.h"

namespace iapsim::render {
namespace {

using bridge::YamlMap;

CameraConfig ReadCamera(YamlMap& map) {
  CameraConfig config;
  map.Required("name", &config.name);
  // the name becomes part of topic and frame names
  if (config.name.empty() || std::isdigit(static_cast<unsigned char>(config.name[0])) ||
      config.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_") !=
          std::string::npos) {
    map.Fail("name", "expected letters, digits and '_' (not first a digit), got '" + config.name + "'");
  }
  std::string mount = "body";
  map.OptionalChoice("mount", &mount, {"body", "world", "chase"});
  config.mount.kind = mount == "world"   ? CameraMount::Kind::kWorld
                      : mount == "chase" ? CameraMount::Kind::kChase
                                         : CameraMount::Kind::kBody;
  if (config.mount.kind == CameraMount::Kind::kWorld) {
    map.Optional("body", &config.mount.body);
    if (!config.mount.body.empty()) map.Fail("body", "a world-fixed camera has no body");
  } else {
    map.Required("body", &config.mount.body);
  }
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero(), rpy_rad = Eigen::Vector3d::Zero();
  model::OptionalVector3(map, "position_m", &position_m);
  model::OptionalVector3(map, "rpy_deg", &rpy_rad, M_PI / 180.0);
  config.mount.X_PF.translation() = position_m;
  config.mount.X_PF.linear() = model::RotationFromRpy(rpy_rad);
  {
    YamlMap chase = map.Map("chase");
    chase.OptionalInRange("distance_m", &config.mount.chase_distance_m, 0.0, 1e4);
    chase.OptionalInRange("height_m", &config.mount.chase_height_m, -1e4, 1e4);
    chase.Finish();
  }

  CameraIntrinsics& k = config.camera.intrinsics;
  map.OptionalInRange("width", &k.width, 1, 16384);
  map.OptionalInRange("height", &k.height, 1, 16384);
  const bool focal = map.Has("fx") || map.Has("fy") || map.Has("cx") || map.Has("cy");
  if (focal && map.Has("hfov_deg")) map.Fail("hfov_deg", "give hfov_deg or fx, fy, cx, cy, not both");
  if (focal) {
    map.Required("fx", &k.fx);
    map.Required("fy", &k.fy);
    map.Required("cx", &k.cx);
    map.Required("cy", &k.cy);
    if (!(k.fx > 0.0 && k.fy > 0.0)) map.Fail("fx", "focal lengths must be positive");
  } else {
    double hfov_deg = 90.0;
    map.OptionalInRange("hfov_deg", &hfov_deg, 1.0, 179.0);
    const int width = k.width, height = k.height;
    k = CameraIntrinsics::FromHorizontalFov(width, height, hfov_deg * M_PI / 180.0);
  }
  map.OptionalInRange("near_m", &config.camera.near_m, 1e-4, 1e3);
  map.OptionalInRange("far_m", &config.camera.far_m, 1e-3, 1e6);
  if (config.camera.far_m <= config.camera.near_m) map.Fail("far_m", "must be beyond near_m");
  map.OptionalInRange("exposure_ev", &config.camera.exposure_ev, -20.0, 20.0);
  map.OptionalInRange("rate_hz", &config.rate_hz, 1e-3, 1e4);
  map.OptionalInRange("baseline_m", &config.baseline_m, 0.0, 100.0);
  map.Optional("raw", &config.publish_raw);
  map.Optional("depth", &config.publish_depth);
  return config;
}

// looking from p_WC at p_W_target with the image's down direction toward +z of W
Eigen::Isometry3d LookAt(const Eigen::Vector3d& p_WC, const Eigen::Vector3d& p_W_target) {
  const Eigen::Vector3d z = (p_W_target - p_WC).normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitZ().cross(z);
  if (x.norm() < 1e-9) x = Eigen::Vector3d::UnitY();  // straight down or up
  x.normalize();
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() << x, z.cross(x), z;
  X_WC.translation() = p_WC;
  return X_WC;
}

}  // namespace

std::vector<std::string> CameraConfig::EyeNames() const {
  if (baseline_m > 0.0) return {"left", "right"};
  return {""};
}

std::string CameraConfig::TopicNamespace(int eye) const {
  const std::string eye_name = EyeNames().at(eye);
  return "/" + (mount.kind == CameraMount::Kind::kWorld ? "" : mount.body + "/") + name +
         (eye_name.empty() ? "" : "/" + eye_name);
}

std::string CameraConfig::OpticalFrameId(int eye) const { return TopicNamespace(eye).substr(1) + "_optical"; }

std::vector<Eigen::Isometry3d> CameraPoses_W(const CameraConfig& config, const Eigen::Isometry3d& X_WB) {
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  const CameraMount& mount = config.mount;
  Eigen::Isometry3d R_FC = Eigen::Isometry3d::Identity();
  R_FC.linear() = OpticalToForwardRightDown();
  switch (mount.kind) {
    case CameraMount::Kind::kWorld:
      X_WC = mount.X_PF * R_FC;
      break;
    case CameraMount::Kind::kBody:
      X_WC = X_WB * mount.X_PF * R_FC;
      break;
    case CameraMount::Kind::kChase: {
      // behind along the body's heading (its x axis projected on the horizontal plane)
      Eigen::Vector3d heading_W = X_WB.linear().col(0);
      heading_W.z() = 0.0;
      if (heading_W.norm() < 1e-6) heading_W = Eigen::Vector3d::UnitX();  // pointing straight up or down
      heading_W.normalize();
      const Eigen::Vector3d p_WB = X_WB.translation();
      const Eigen::Vector3d p_WC =
          p_WB - mount.chase_distance_m * heading_W - mount.chase_height_m * Eigen::Vector3d::UnitZ();
      X_WC = LookAt(p_WC, p_WB);
      break;
    }
  }
  if (config.baseline_m <= 0.0) return {X_WC};
  const double half = 0.5 * config.baseline_m;
  return {X_WC * Eigen::Translation3d(-half, 0.0, 0.0), X_WC * Eigen::Translation3d(half, 0.0, 0.0)};
}

std::vector<CameraConfig> ReadCameras(YamlMap& map, const std::string& key) {
  std::vector<CameraConfig> cameras;
  if (!map.Has(key)) return cameras;
  const YAML::Node list = map.Raw(key);
  if (!list.IsSequence()) map.Fail(key, "expected a list of cameras");
  std::set<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    YamlMap item(list[i], map.file(), map.PathOf(key) + "[" + std::to_string(i) + "]");
    cameras.push_back(ReadCamera(item));
    if (!names.insert(cameras.back().mount.body + "/" + cameras.back().name).second) {
      item.Fail("name", "a second camera '" + cameras.back().name + "' on the same body");
    }
    item.Finish();
  }
  return cameras;
}

}  // namespace iapsim::render
