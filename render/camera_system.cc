#include "render/camera_system.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <future>
#include <stdexcept>

namespace iapsim::render {
namespace {

// An encoder runs at the lowest priority (nice 19; on Linux the nice value is per thread): llvmpipe's
// raster threads keep the cores and finish an image sooner, and the encoder takes the time they leave, while
// llvmpipe bins or reads back on one thread. Six images a frame on two cores: +5 % frames/s. Best effort: a
// thread whose priority cannot change encodes at its own.
void YieldCoresToTheRasterThreads() { setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 19); }

}  // namespace

CameraSystem::CameraSystem(const Scene& scene, std::vector<CameraConfig> cameras,
                           const CameraSystemOptions& options)
    : cameras_(std::move(cameras)), options_(options), renderer_(MakeRenderer(options.renderer)) {
  renderer_->SetScene(scene);
  for (const SceneObject& object : scene.objects) {
    if (!object.body.empty()) drawn_bodies_.emplace(object.body, renderer_->BodyIndex(object.body));
  }
}

CameraSystem::~CameraSystem() = default;

void CameraSystem::SetBodyPose(const std::string& body, const Eigen::Isometry3d& X_WB) {
  if (const auto drawn = drawn_bodies_.find(body); drawn != drawn_bodies_.end()) {
    renderer_->SetBodyPose(drawn->second, X_WB);
  }
  for (const CameraConfig& camera : cameras_) {
    if (camera.mount.body == body) mount_poses_W_[body] = X_WB;
  }
}

std::vector<std::string> CameraSystem::MissingMounts() const {
  std::vector<std::string> missing;
  for (const CameraConfig& camera : cameras_) {
    const std::string& body = camera.mount.body;
    if (camera.mount.kind != CameraMount::Kind::kWorld && !mount_poses_W_.count(body))
      missing.push_back(body);
  }
  return missing;
}

void CameraSystem::Render(const std::vector<int>& cameras, std::vector<EyeFrame>* frames) {
  std::size_t n = 0;
  for (const int c : cameras) n += cameras_.at(c).EyeNames().size();
  frames->resize(n);
  // PNG encoding (a third of an image's time) runs on a worker while the renderer draws the next eye
  std::vector<std::future<void>> encodes;
  std::size_t i = 0;
  for (const int c : cameras) {
    const CameraConfig& config = cameras_[c];
    Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
    if (config.mount.kind != CameraMount::Kind::kWorld) {
      const auto pose = mount_poses_W_.find(config.mount.body);
      if (pose == mount_poses_W_.end()) {
        throw std::logic_error("camera '" + config.name + "': body '" + config.mount.body + "' has no pose");
      }
      X_WB = pose->second;
    }
    const std::vector<Eigen::Isometry3d> eyes_W = CameraPoses_W(config, X_WB);
    for (std::size_t e = 0; e < eyes_W.size(); ++e, ++i) {
      EyeFrame& frame = (*frames)[i];
      frame.camera = c;
      frame.eye = static_cast<int>(e);
      renderer_->Render(config.camera, eyes_W[e], &frame.rgb, config.publish_depth ? &frame.depth : nullptr);
      if (!config.publish_depth) frame.depth = DepthImage();
      frame.png.clear();
      if (options_.encode_png) {
        encodes.push_back(std::async(std::launch::async, [&frame, level = options_.png_compression] {
          YieldCoresToTheRasterThreads();
          frame.png = EncodePng(frame.rgb, level);
        }));
      }
    }
  }
  for (auto& encode : encodes) encode.get();  // rethrows an encoder's exception
}

}  // namespace iapsim::render
