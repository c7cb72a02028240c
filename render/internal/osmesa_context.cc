#include <GL/osmesa.h>

#include <array>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "render/internal/gl_context.h"

namespace iapsim::render::internal {
namespace {

class OsMesaContext final : public GlContext {
 public:
  explicit OsMesaContext(int threads) {
    // llvmpipe reads its thread count when the first context of the process is made
    if (threads > 0) setenv("LP_NUM_THREADS", std::to_string(threads).c_str(), 1);
    const int attributes[] = {OSMESA_FORMAT,
                              OSMESA_RGBA,
                              OSMESA_DEPTH_BITS,
                              24,
                              OSMESA_STENCIL_BITS,
                              0,
                              OSMESA_ACCUM_BITS,
                              0,
                              OSMESA_PROFILE,
                              OSMESA_CORE_PROFILE,
                              OSMESA_CONTEXT_MAJOR_VERSION,
                              3,
                              OSMESA_CONTEXT_MINOR_VERSION,
                              3,
                              0};
    context_ = OSMesaCreateContextAttribs(attributes, nullptr);
    if (!context_) throw std::runtime_error("OSMesa: cannot create an OpenGL 3.3 core-profile context");
    MakeCurrent();
  }
  ~OsMesaContext() override { OSMesaDestroyContext(context_); }

  void* GetProcAddress(const char* name) const override {
    return reinterpret_cast<void*>(OSMesaGetProcAddress(name));
  }

  void MakeCurrent() override {
    if (OSMesaGetCurrentContext() == context_) return;
    // the renderer draws into its own framebuffers: the context's buffer is a single pixel
    if (!OSMesaMakeCurrent(context_, pixel_.data(), GL_UNSIGNED_BYTE, 1, 1)) {
      throw std::runtime_error("OSMesa: cannot make the context current");
    }
  }

  std::string BackendName() const override { return "osmesa"; }

 private:
  OSMesaContext context_ = nullptr;
  std::array<unsigned char, 4> pixel_{};
};

}  // namespace

std::unique_ptr<GlContext> MakeOsMesaContext(int threads) { return std::make_unique<OsMesaContext>(threads); }

}  // namespace iapsim::render::internal
