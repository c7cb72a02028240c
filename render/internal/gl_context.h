#pragma once
// A GL context of one backend, free of GL and window-system headers so each backend's .cc can include its
// own (osmesa.h pulls in gl.h, which clashes with glcorearb.h). Internal: include only from render/*.cc.

#include <memory>
#include <string>

namespace iapsim::render::internal {

/// An OpenGL 3.3+ core context made current on the calling thread, with nothing bound to draw into: the
/// renderer draws into its own framebuffers. One per backend (osmesa_context.cc, egl_context.cc).
class GlContext {
 public:
  virtual ~GlContext() = default;
  virtual void* GetProcAddress(const char* name) const = 0;
  /// Makes the context current on the calling thread (the renderer calls it before every use, so a renderer
  /// may move between threads, one at a time).
  virtual void MakeCurrent() = 0;
  virtual std::string BackendName() const = 0;
};

/// OSMesa (llvmpipe, software). `threads` > 0 sets LP_NUM_THREADS, which Mesa reads once per process when
/// the first context is made. Throws std::runtime_error when no 3.3 core context can be made.
std::unique_ptr<GlContext> MakeOsMesaContext(int threads);
/// EGL without a window: the first EGL device (a GPU), else Mesa's surfaceless platform. Throws
/// std::runtime_error when no context can be made. Built only with IAPSIM_RENDER_EGL.
std::unique_ptr<GlContext> MakeEglContext();

}  // namespace iapsim::render::internal
