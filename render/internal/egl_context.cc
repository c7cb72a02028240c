#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "render/internal/gl_context.h"

namespace iapsim::render::internal {
namespace {

template <class F>
F Extension(const char* name) {
  return reinterpret_cast<F>(eglGetProcAddress(name));
}

// The first EGL device (a GPU through its vendor's EGL) if there is one, else Mesa's surfaceless platform.
EGLDisplay OpenDisplay() {
  const auto get_platform_display = Extension<PFNEGLGETPLATFORMDISPLAYEXTPROC>("eglGetPlatformDisplayEXT");
  const auto query_devices = Extension<PFNEGLQUERYDEVICESEXTPROC>("eglQueryDevicesEXT");
  if (!get_platform_display) return eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (query_devices) {
    std::vector<EGLDeviceEXT> devices(16);
    EGLint count = 0;
    if (query_devices(static_cast<EGLint>(devices.size()), devices.data(), &count) && count > 0) {
      for (EGLint i = 0; i < count; ++i) {
        EGLDisplay display = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (display != EGL_NO_DISPLAY && eglInitialize(display, nullptr, nullptr)) return display;
      }
    }
  }
  EGLDisplay display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (display != EGL_NO_DISPLAY) return display;
  return eglGetDisplay(EGL_DEFAULT_DISPLAY);
}

class EglContext final : public GlContext {
 public:
  EglContext() {
    display_ = OpenDisplay();
    if (display_ == EGL_NO_DISPLAY || !eglInitialize(display_, nullptr, nullptr)) {
      throw std::runtime_error("EGL: no display (no device and no surfaceless platform)");
    }
    if (!eglBindAPI(EGL_OPENGL_API)) throw std::runtime_error("EGL: the display has no desktop OpenGL");
    // the default surface type (window) has no config on a surfaceless display: ask for pbuffers, else
    // make the context without a config (EGL_KHR_no_config_context)
    const EGLint config_attributes[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                                        EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = EGL_NO_CONFIG_KHR;
    EGLint count = 0;
    if (!eglChooseConfig(display_, config_attributes, &config, 1, &count) || count == 0) {
      config = EGL_NO_CONFIG_KHR;
    }
    const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                                         3,
                                         EGL_CONTEXT_MINOR_VERSION,
                                         3,
                                         EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                         EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                         EGL_NONE};
    context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, context_attributes);
    if (context_ == EGL_NO_CONTEXT) throw std::runtime_error("EGL: cannot create an OpenGL 3.3 core context");
    MakeCurrent();
  }
  ~EglContext() override {
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
    eglTerminate(display_);
  }

  void* GetProcAddress(const char* name) const override {
    return reinterpret_cast<void*>(eglGetProcAddress(name));
  }

  void MakeCurrent() override {
    if (eglGetCurrentContext() == context_) return;
    // surfaceless (EGL_KHR_surfaceless_context): the renderer draws into its own framebuffers
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
      throw std::runtime_error("EGL: cannot make the context current without a surface");
    }
  }

  std::string BackendName() const override { return "egl"; }

 private:
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
};

}  // namespace

std::unique_ptr<GlContext> MakeEglContext() { return std::make_unique<EglContext>(); }

}  // namespace iapsim::render::internal
