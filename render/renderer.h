#pragma once
// The renderer: OpenGL 3.3 core behind a factory, so no GL, OSMesa or EGL type reaches a caller. A process
// makes one, hands it the scene once, then every frame sets the poses of the bodies it drew from the latest
// physics state and renders each camera. One renderer is used by one thread at a time.

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "render/camera.h"
#include "render/image.h"
#include "render/scene.h"

namespace iapsim::render {

enum class Backend {
  kOsMesa,  ///< Mesa's llvmpipe on the CPU, no display or GPU needed
  kEgl,     ///< EGL without a window: a GPU's driver, or Mesa's surfaceless platform (IAPSIM_RENDER_EGL)
};

struct RendererOptions {
  Backend backend = Backend::kOsMesa;
  /// OSMesa: llvmpipe's raster threads (LP_NUM_THREADS). Mesa reads it once per process, when the first
  /// context is made, so it applies to every OSMesa renderer of the process. 0: Mesa's default (one per
  /// core).
  int threads = 0;
};

/// "osmesa" | "egl" <-> Backend; throws std::invalid_argument for another name.
Backend ParseBackend(const std::string& name);
std::string BackendName(Backend backend);
/// The backends this build has (OSMesa always, EGL with IAPSIM_RENDER_EGL=ON).
std::vector<Backend> BuiltBackends();

class Renderer {
 public:
  virtual ~Renderer() = default;

  /// Uploads the scene's meshes and textures (replacing any previous scene) and puts every body at the
  /// identity. Throws std::invalid_argument when the scene is inconsistent (Scene::Validate).
  virtual void SetScene(const Scene& scene) = 0;
  /// The index of a body that the scene's objects name, or −1.
  virtual int BodyIndex(const std::string& body) const = 0;
  /// X_WB of a body for the next renders (B FRD, W NED, metres).
  virtual void SetBodyPose(int body, const Eigen::Isometry3d& X_WB) = 0;

  /// Draws the scene as seen by `camera` at X_WC (C the optical frame of camera.h) into `rgb` and, when not
  /// null, the metric depth along z_C into `depth`. Reuses the images' storage.
  virtual void Render(const Camera& camera, const Eigen::Isometry3d& X_WC, Image* rgb, DepthImage* depth) = 0;

  /// The GL renderer's name (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)") and version.
  virtual std::string Description() const = 0;
};

/// Makes a renderer with its own GL context. Throws std::runtime_error when the backend is not built or no
/// context can be made (the message says which).
std::unique_ptr<Renderer> MakeRenderer(const RendererOptions& options = {});

}  // namespace iapsim::render
