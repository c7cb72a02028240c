#include "render/internal/gl_functions.h"

#include <stdexcept>
#include <string>

namespace iapsim::render::internal {

void GlFunctions::Load(const std::function<void*(const char*)>& get_proc_address) {
#define IAPSIM_GL_LOAD(type, name)                             \
  name = reinterpret_cast<type>(get_proc_address("gl" #name)); \
  if (!name) throw std::runtime_error("OpenGL: the context has no gl" #name);
  IAPSIM_GL_FUNCTIONS(IAPSIM_GL_LOAD)
#undef IAPSIM_GL_LOAD
}

}  // namespace iapsim::render::internal
