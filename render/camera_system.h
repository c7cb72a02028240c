#pragma once
// A scenario's cameras over one renderer (seed §V-B): body poses in, images out. Each call draws the eyes of
// the cameras asked for at the poses last set and PNG-encodes every image on a worker thread while the next
// eye draws. No bus and no clock here: the render process stamps and publishes what comes back, and a
// benchmark or a learning loop calls it directly.

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "render/camera_rig.h"
#include "render/image.h"
#include "render/renderer.h"
#include "render/scene.h"

namespace iapsim::render {

/// One eye's images from one call of CameraSystem::Render.
struct EyeFrame {
  int camera = 0;  ///< index into CameraSystem::cameras()
  int eye = 0;     ///< index into that camera's EyeNames()
  Image rgb;
  DepthImage depth;               ///< filled when the camera publishes depth
  std::vector<std::uint8_t> png;  ///< the PNG of rgb when encoding is on
};

struct CameraSystemOptions {
  RendererOptions renderer;
  bool encode_png = true;
  int png_compression = 1;  ///< deflate level 0..9; 1 is the knee of size against time for rendered images
};

class CameraSystem {
 public:
  /// Makes the renderer and uploads the scene. Throws std::invalid_argument when the scene is inconsistent
  /// and std::runtime_error when no renderer can be made.
  CameraSystem(const Scene& scene, std::vector<CameraConfig> cameras, const CameraSystemOptions& options);
  ~CameraSystem();

  const std::vector<CameraConfig>& cameras() const { return cameras_; }
  const Renderer& renderer() const { return *renderer_; }

  /// X_WB of a body (physics name, e.g. "iap/sub1") for the next renders: moves the objects drawn on it and
  /// the cameras mounted on it. Other bodies are ignored.
  void SetBodyPose(const std::string& body, const Eigen::Isometry3d& X_WB);
  /// The bodies cameras are mounted on that have had no pose yet (such a camera cannot be drawn).
  std::vector<std::string> MissingMounts() const;

  /// Draws every eye of `cameras` (indices into cameras()) into `frames`, in order, reusing its storage.
  /// Throws std::logic_error when a camera's mount has had no pose.
  void Render(const std::vector<int>& cameras, std::vector<EyeFrame>* frames);

 private:
  std::vector<CameraConfig> cameras_;
  CameraSystemOptions options_;
  std::unique_ptr<Renderer> renderer_;
  std::map<std::string, int> drawn_bodies_;                 // body name -> renderer index
  std::map<std::string, Eigen::Isometry3d> mount_poses_W_;  // X_WB of each body a camera is mounted on
};

}  // namespace iapsim::render
