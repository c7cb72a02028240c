// The OpenGL renderer (every backend) and the factory. GL entry points come from internal::GlFunctions.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

#include "render/internal/gl_context.h"
#include "render/internal/gl_functions.h"
#include "render/renderer.h"

namespace iapsim::render {
namespace {

using internal::GlContext;
using internal::GlFunctions;

// Object space O -> world W -> optical frame C -> clip. Lighting in linear light, sRGB written out.
// The shadow map of the objects on bodies: over a vehicle's few metres, 1024 texels give millimetre texels.
constexpr int kBodyShadowResolution = 1024;

// The scene shaders are compiled per combination of the features a draw needs (ShaderFeature): llvmpipe
// runs both sides of every branch under a mask, so a uniform that switches a shadow tap or a texture off
// saves nothing, and only leaving the code out does. Each source is prefixed with its #defines.
enum ShaderFeature : unsigned {
  kTextured = 1u << 0,
  kLit = 1u << 1,           // not unlit: the sun, ambient light and fog apply
  kSpecular = 1u << 2,      // a highlight (specular > 0)
  kFog = 1u << 3,           // fog density > 0
  kFixedShadows = 1u << 4,  // receives the shadows of the objects fixed in W
  kBodyShadows = 1u << 5,   // receives the shadows of the objects on bodies
};

constexpr char kSceneVertexShader[] = R"(
layout(location = 0) in vec3 position_O;
layout(location = 1) in vec3 normal_O;
layout(location = 2) in vec2 uv_in;
uniform mat4 X_WO;        // scale included
uniform mat3 normal_W_O;  // inverse transpose of X_WO's linear part
uniform mat4 X_CW;
uniform mat4 clip_C;
uniform vec3 eye_W;
uniform mat4 light_clip_W;
uniform float shadow_texel_m;
uniform mat4 body_light_clip_W;
uniform float body_shadow_texel_m;
out vec3 p_W;
out vec3 n_W;
out vec2 uv;
out float z_C;
out vec3 shadow_uvz;       // the point in the shadow maps' texture coordinates and depth
out vec3 body_shadow_uvz;

// Offset along the normal by a texel and a half (no self-shadow acne at grazing sun), toward the eye's
// side (two-sided lighting). Both maps are orthographic, so these are affine in the position and exact
// per vertex on a flat face: the fragments interpolate them instead of transforming per pixel.
vec3 ShadowUvz(mat4 light_clip, float texel_m, vec3 n_toward_eye) {
  return (light_clip * vec4(p_W + n_toward_eye * (1.5 * texel_m), 1.0)).xyz * 0.5 + 0.5;
}

void main() {
  vec4 p = X_WO * vec4(position_O, 1.0);
  p_W = p.xyz;
  n_W = normal_W_O * normal_O;
  uv = uv_in;
  vec4 p_C = X_CW * p;
  z_C = p_C.z;
  gl_Position = clip_C * p_C;
  vec3 n = normalize(n_W);
  if (dot(n, eye_W - p_W) < 0.0) n = -n;
#ifdef FIXED_SHADOWS
  shadow_uvz = ShadowUvz(light_clip_W, shadow_texel_m, n);
#endif
#ifdef BODY_SHADOWS
  body_shadow_uvz = ShadowUvz(body_light_clip_W, body_shadow_texel_m, n);
#endif
}
)";

constexpr char kSceneFragmentShader[] = R"(
in vec3 p_W;
in vec3 n_W;
in vec2 uv;
in float z_C;
in vec3 shadow_uvz;
in vec3 body_shadow_uvz;
uniform vec3 albedo;         // linear
uniform sampler2D albedo_texture;  // sRGB texels, decoded to linear by the sampler
uniform float specular;
uniform float shininess;
uniform vec3 to_sun_W;
uniform vec3 sun;            // linear irradiance
uniform vec3 ambient;        // linear irradiance
uniform sampler2DShadow shadow_map;       // of the objects fixed in W (drawn once per scene)
uniform sampler2DShadow body_shadow_map;  // of the objects on moving bodies (drawn every frame they move)
uniform vec3 eye_W;
uniform float fog_density;
uniform vec3 fog_color;      // linear
uniform float exposure;
layout(location = 0) out vec4 color_out;
layout(location = 1) out float depth_out;

vec3 EncodeSrgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

// the fraction of the sun reaching the point: one tap of the hardware's 2x2 filtered compare per map
// (outside a map its border, depth 1, leaves the point lit)
float SunVisible() {
  float visible = 1.0;
#ifdef FIXED_SHADOWS
  visible = texture(shadow_map, vec3(shadow_uvz.xy, min(shadow_uvz.z, 1.0)));
#endif
#ifdef BODY_SHADOWS
  visible = min(visible, texture(body_shadow_map, vec3(body_shadow_uvz.xy, min(body_shadow_uvz.z, 1.0))));
#endif
  return visible;
}

void main() {
  vec3 radiance = albedo;
#ifdef TEXTURED
  radiance *= texture(albedo_texture, uv).rgb;
#endif
#ifdef LIT
  vec3 to_eye = normalize(eye_W - p_W);
  vec3 n = normalize(n_W);
  if (dot(n, to_eye) < 0.0) n = -n;  // two-sided: meshes of either winding
  float n_dot_l = dot(n, to_sun_W);
  float lit = n_dot_l > 0.0 ? SunVisible() * n_dot_l : 0.0;
  radiance *= ambient + lit * sun;
#ifdef SPECULAR
  float highlight = specular * pow(max(dot(n, normalize(to_sun_W + to_eye)), 0.0), shininess);
  radiance += (lit > 0.0 ? highlight : 0.0) * sun;
#endif
#ifdef FOG
  radiance = mix(radiance, fog_color, 1.0 - exp(-fog_density * length(eye_W - p_W)));
#endif
#endif
  color_out = vec4(EncodeSrgb(radiance * exposure), 1.0);
  depth_out = z_C;
}
)";

constexpr char kShadowVertexShader[] = R"(
layout(location = 0) in vec3 position_O;
uniform mat4 light_clip_O;
void main() { gl_Position = light_clip_O * vec4(position_O, 1.0); }
)";

constexpr char kShadowFragmentShader[] = R"(
void main() {}
)";

double SrgbToLinear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }
double LinearToSrgb(double c) {
  c = std::clamp(c, 0.0, 1.0);
  return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}
Eigen::Vector3f Linear(const Eigen::Vector3f& srgb) {
  return Eigen::Vector3f(SrgbToLinear(srgb.x()), SrgbToLinear(srgb.y()), SrgbToLinear(srgb.z()));
}

// A linked program and the locations of its uniforms (−1 for one the compiler dropped). `defines` go
// between the #version line and each source.
class Program {
 public:
  Program(const GlFunctions& gl, const char* vertex, const char* fragment, const std::string& defines,
          const char* name)
      : gl_(gl) {
    const std::string prefix = "#version 330 core\n" + defines;
    const GLuint vs = Compile(GL_VERTEX_SHADER, prefix, vertex, name);
    const GLuint fs = Compile(GL_FRAGMENT_SHADER, prefix, fragment, name);
    id_ = gl_.CreateProgram();
    gl_.AttachShader(id_, vs);
    gl_.AttachShader(id_, fs);
    gl_.LinkProgram(id_);
    gl_.DeleteShader(vs);
    gl_.DeleteShader(fs);
    ThrowUnless(gl_.GetProgramiv, gl_.GetProgramInfoLog, id_, GL_LINK_STATUS,
                std::string("the ") + name + " program does not link");
  }
  ~Program() { gl_.DeleteProgram(id_); }
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;

  GLuint id() const { return id_; }
  GLint Location(const char* uniform) {
    auto it = locations_.find(uniform);
    if (it == locations_.end()) it = locations_.emplace(uniform, gl_.GetUniformLocation(id_, uniform)).first;
    return it->second;
  }
  void Set(const char* uniform, const Eigen::Matrix4f& m) {
    gl_.UniformMatrix4fv(Location(uniform), 1, GL_FALSE, m.data());
  }
  void Set(const char* uniform, const Eigen::Matrix3f& m) {
    gl_.UniformMatrix3fv(Location(uniform), 1, GL_FALSE, m.data());
  }
  void Set(const char* uniform, const Eigen::Vector3f& v) {
    gl_.Uniform3f(Location(uniform), v.x(), v.y(), v.z());
  }
  void Set(const char* uniform, float value) { gl_.Uniform1f(Location(uniform), value); }
  void Set(const char* uniform, int value) { gl_.Uniform1i(Location(uniform), value); }

 private:
  GLuint Compile(GLenum stage, const std::string& prefix, const char* source, const char* name) {
    const GLuint shader = gl_.CreateShader(stage);
    const char* sources[] = {prefix.c_str(), source};
    gl_.ShaderSource(shader, 2, sources, nullptr);
    gl_.CompileShader(shader);
    ThrowUnless(gl_.GetShaderiv, gl_.GetShaderInfoLog, shader, GL_COMPILE_STATUS,
                std::string("a ") + name + " shader does not compile");
    return shader;
  }

  // a shader's compile or a program's link status, with the driver's log in the exception
  template <class GetIv, class GetLog>
  static void ThrowUnless(GetIv get_iv, GetLog get_log, GLuint id, GLenum status, const std::string& what) {
    GLint ok = 0;
    get_iv(id, status, &ok);
    if (ok) return;
    char log[2048] = {};
    get_log(id, sizeof(log), nullptr, log);
    throw std::runtime_error("OpenGL: " + what + ": " + log);
  }

  const GlFunctions& gl_;
  GLuint id_ = 0;
  std::map<std::string, GLint> locations_;
};

class GlRenderer final : public Renderer {
 public:
  explicit GlRenderer(std::unique_ptr<GlContext> context) : context_(std::move(context)) {
    context_->MakeCurrent();
    gl_.Load([this](const char* name) { return context_->GetProcAddress(name); });
    GLint major = 0, minor = 0;
    gl_.GetIntegerv(GL_MAJOR_VERSION, &major);
    gl_.GetIntegerv(GL_MINOR_VERSION, &minor);
    if (major * 10 + minor < 33) {
      throw std::runtime_error("OpenGL: " + context_->BackendName() + " gave version " +
                               std::to_string(major) + "." + std::to_string(minor) + ", 3.3 core is needed");
    }
    description_ = context_->BackendName() + ": " + String(GL_RENDERER) + ", OpenGL " + String(GL_VERSION);
    shadow_program_ =
        std::make_unique<Program>(gl_, kShadowVertexShader, kShadowFragmentShader, "", "shadow");
    CheckError("setting up");
  }

  ~GlRenderer() override {
    context_->MakeCurrent();
    ReleaseScene();
    ReleaseTargets();
    scene_programs_.clear();
    shadow_program_.reset();
  }

  void SetScene(const Scene& scene) override {
    scene.Validate();
    context_->MakeCurrent();
    ReleaseScene();
    scene_ = scene;
    // geometry: one interleaved buffer per part (position, normal, uv)
    for (const Mesh& mesh : scene_.meshes) {
      std::vector<GpuPart> parts;
      for (const MeshPart& part : mesh.parts) parts.push_back(Upload(part));
      meshes_.push_back(std::move(parts));
    }
    for (const TextureImage& texture : scene_.textures) textures_.push_back(Upload(texture));
    body_names_ = scene_.Bodies();
    X_WB_.assign(body_names_.size(), Eigen::Isometry3d::Identity());
    object_body_.clear();
    object_radius_m_.clear();
    for (const SceneObject& object : scene_.objects) {
      object_body_.push_back(BodyIndex(object.body));
      double radius_m = 0.0;
      for (const MeshPart& part : scene_.meshes[object.mesh].parts) {
        for (const Eigen::Vector3f& p : part.positions_O_m) {
          radius_m = std::max(radius_m, (p.cast<double>().cwiseProduct(object.scale)).norm());
        }
      }
      object_radius_m_.push_back(radius_m);
    }
    fixed_shadow_dirty_ = body_shadow_dirty_ = true;
    CheckError("uploading the scene");
  }

  int BodyIndex(const std::string& body) const override {
    for (std::size_t i = 0; i < body_names_.size(); ++i) {
      if (body_names_[i] == body) return static_cast<int>(i);
    }
    return -1;
  }

  void SetBodyPose(int body, const Eigen::Isometry3d& X_WB) override {
    if (body < 0 || body >= static_cast<int>(X_WB_.size())) {
      throw std::out_of_range("renderer: no body " + std::to_string(body));
    }
    if (X_WB.matrix() != X_WB_[body].matrix()) body_shadow_dirty_ = true;
    X_WB_[body] = X_WB;
  }

  void Render(const Camera& camera, const Eigen::Isometry3d& X_WC, Image* rgb, DepthImage* depth) override {
    const CameraIntrinsics& k = camera.intrinsics;
    if (!k.IsValid() || !(camera.near_m > 0.0 && camera.far_m > camera.near_m)) {
      throw std::invalid_argument("renderer: invalid camera (size, focal lengths or near/far)");
    }
    context_->MakeCurrent();
    const bool body_shadows = scene_.sun.shadows && HasBodyCasters();
    if (scene_.sun.shadows && fixed_shadow_dirty_) RenderFixedShadowMap();
    if (body_shadows && body_shadow_dirty_) RenderBodyShadowMap();
    const Target& target = TargetFor(k.width, k.height);
    gl_.BindFramebuffer(GL_FRAMEBUFFER, target.framebuffer);
    const GLenum buffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    gl_.DrawBuffers(depth ? 2 : 1, buffers);
    gl_.Viewport(0, 0, k.width, k.height);
    gl_.Enable(GL_DEPTH_TEST);
    gl_.DepthFunc(GL_LESS);
    gl_.Disable(GL_CULL_FACE);  // meshes of either winding; the shader lights both sides

    // the sky, exposed like everything else
    const float exposure = static_cast<float>(std::exp2(camera.exposure_ev));
    const Eigen::Vector3f sky = Linear(scene_.sky_color) * exposure;
    const float sky_srgb[4] = {static_cast<float>(LinearToSrgb(sky.x())),
                               static_cast<float>(LinearToSrgb(sky.y())),
                               static_cast<float>(LinearToSrgb(sky.z())), 1.0f};
    gl_.ClearBufferfv(GL_COLOR, 0, sky_srgb);
    if (depth) {
      const float far[4] = {std::numeric_limits<float>::infinity(), 0.0f, 0.0f, 0.0f};
      gl_.ClearBufferfv(GL_COLOR, 1, far);
    }
    gl_.Clear(GL_DEPTH_BUFFER_BIT);

    // what every program drawing this image needs; each program takes them at its first draw (UseProgram)
    ++image_serial_;
    ImageUniforms& u = image_uniforms_;
    u.X_CW = X_WC.inverse().matrix().cast<float>();
    u.clip_C = ClipFromOptical(camera).cast<float>();
    u.eye_W = X_WC.translation().cast<float>();
    u.exposure = exposure;
    if (scene_.sun.shadows) {
      gl_.ActiveTexture(GL_TEXTURE1);
      gl_.BindTexture(GL_TEXTURE_2D, fixed_shadow_.texture);
    }
    if (body_shadows) {
      gl_.ActiveTexture(GL_TEXTURE2);
      gl_.BindTexture(GL_TEXTURE_2D, body_shadow_.texture);
    }
    for (const std::size_t o : FrontToBack(X_WC.translation())) DrawObject(o, body_shadows);
    ReadBack(k.width, k.height, rgb, depth);
    CheckError("rendering");
  }

  std::string Description() const override { return description_; }

 private:
  struct GpuPart {
    GLuint vertex_array = 0, vertex_buffer = 0, index_buffer = 0;
    GLsizei index_count = 0;
    int material = 0;
  };
  struct Target {
    GLuint framebuffer = 0, color = 0, depth_m = 0, depth_test = 0;
  };
  // A depth map seen from the sun: an orthographic view along its travel.
  struct ShadowMap {
    GLuint framebuffer = 0, texture = 0;
    int resolution = 0;
    Eigen::Matrix4d light_clip_W = Eigen::Matrix4d::Identity();
    double texel_m = 0.0;
  };
  struct SceneProgram {
    std::unique_ptr<Program> program;
    std::uint64_t image = 0;  // the image whose uniforms it holds (image_serial_)
  };
  struct ImageUniforms {
    Eigen::Matrix4f X_CW, clip_C;
    Eigen::Vector3f eye_W;
    float exposure = 1.0f;
  };
  // where the objects on bodies can cast shadows (ReceivesBodyShadows), set with their shadow map
  struct BodyShadowReach {
    Eigen::Vector3d center_W = Eigen::Vector3d::Zero();
    double radius_m = 0.0, beyond_m = 0.0;
  };

  std::string String(GLenum name) const {
    const GLubyte* s = gl_.GetString(name);
    return s ? reinterpret_cast<const char*>(s) : "?";
  }

  void CheckError(const std::string& what) const {
    const GLenum error = gl_.GetError();
    if (error != GL_NO_ERROR)
      throw std::runtime_error("OpenGL error " + std::to_string(error) + " while " + what);
  }

  GpuPart Upload(const MeshPart& part) {
    GpuPart gpu;
    gpu.material = part.material;
    gpu.index_count = static_cast<GLsizei>(part.indices.size());
    std::vector<float> interleaved;
    interleaved.reserve(part.positions_O_m.size() * 8);
    for (std::size_t i = 0; i < part.positions_O_m.size(); ++i) {
      const Eigen::Vector3f& p = part.positions_O_m[i];
      const Eigen::Vector3f& n = part.normals_O[i];
      interleaved.insert(interleaved.end(),
                         {p.x(), p.y(), p.z(), n.x(), n.y(), n.z(), part.uv[i].x(), part.uv[i].y()});
    }
    gl_.GenVertexArrays(1, &gpu.vertex_array);
    gl_.BindVertexArray(gpu.vertex_array);
    gl_.GenBuffers(1, &gpu.vertex_buffer);
    gl_.BindBuffer(GL_ARRAY_BUFFER, gpu.vertex_buffer);
    gl_.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)),
                   interleaved.data(), GL_STATIC_DRAW);
    gl_.GenBuffers(1, &gpu.index_buffer);
    gl_.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, gpu.index_buffer);
    gl_.BufferData(GL_ELEMENT_ARRAY_BUFFER,
                   static_cast<GLsizeiptr>(part.indices.size() * sizeof(std::uint32_t)), part.indices.data(),
                   GL_STATIC_DRAW);
    const GLsizei stride = 8 * sizeof(float);
    gl_.EnableVertexAttribArray(0);
    gl_.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(0));
    gl_.EnableVertexAttribArray(1);
    gl_.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(3 * sizeof(float)));
    gl_.EnableVertexAttribArray(2);
    gl_.VertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(6 * sizeof(float)));
    gl_.BindVertexArray(0);
    return gpu;
  }

  GLuint Upload(const TextureImage& texture) {
    GLuint id = 0;
    gl_.GenTextures(1, &id);
    gl_.BindTexture(GL_TEXTURE_2D, id);
    gl_.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
    gl_.TexImage2D(GL_TEXTURE_2D, 0, GL_SRGB8, texture.width, texture.height, 0, GL_RGB, GL_UNSIGNED_BYTE,
                   texture.rgb.data());
    gl_.GenerateMipmap(GL_TEXTURE_2D);
    // trilinear: a tiled ground seen at a grazing angle stays a texture, not noise
    gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    return id;
  }

  void ReleaseScene() {
    for (const auto& parts : meshes_) {
      for (const GpuPart& part : parts) {
        gl_.DeleteVertexArrays(1, &part.vertex_array);
        gl_.DeleteBuffers(1, &part.vertex_buffer);
        gl_.DeleteBuffers(1, &part.index_buffer);
      }
    }
    meshes_.clear();
    if (!textures_.empty()) gl_.DeleteTextures(static_cast<GLsizei>(textures_.size()), textures_.data());
    textures_.clear();
  }

  void ReleaseTargets() {
    for (const auto& [size, target] : targets_) {
      gl_.DeleteFramebuffers(1, &target.framebuffer);
      const GLuint buffers[] = {target.color, target.depth_m, target.depth_test};
      gl_.DeleteRenderbuffers(3, buffers);
    }
    targets_.clear();
    ReleaseShadowMap(&fixed_shadow_);
    ReleaseShadowMap(&body_shadow_);
  }

  void ReleaseShadowMap(ShadowMap* map) {
    if (map->framebuffer) gl_.DeleteFramebuffers(1, &map->framebuffer);
    if (map->texture) gl_.DeleteTextures(1, &map->texture);
    *map = ShadowMap();
  }

  // colour (RGBA8), metric depth (R32F) and the depth test's buffer, one set per image size
  const Target& TargetFor(int width, int height) {
    const auto key = std::make_pair(width, height);
    auto it = targets_.find(key);
    if (it != targets_.end()) return it->second;
    Target t;
    gl_.GenFramebuffers(1, &t.framebuffer);
    gl_.BindFramebuffer(GL_FRAMEBUFFER, t.framebuffer);
    const auto add = [&](GLuint* id, GLenum format, GLenum attachment) {
      gl_.GenRenderbuffers(1, id);
      gl_.BindRenderbuffer(GL_RENDERBUFFER, *id);
      gl_.RenderbufferStorage(GL_RENDERBUFFER, format, width, height);
      gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, attachment, GL_RENDERBUFFER, *id);
    };
    add(&t.color, GL_RGBA8, GL_COLOR_ATTACHMENT0);
    add(&t.depth_m, GL_R32F, GL_COLOR_ATTACHMENT1);
    add(&t.depth_test, GL_DEPTH_COMPONENT24, GL_DEPTH_ATTACHMENT);
    if (gl_.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw std::runtime_error("OpenGL: the " + std::to_string(width) + "x" + std::to_string(height) +
                               " framebuffer is incomplete");
    }
    return targets_.emplace(key, t).first->second;
  }

  // X_WO with its scale, for the object's body pose now
  Eigen::Matrix4d ObjectToWorld(std::size_t o) const {
    const SceneObject& object = scene_.objects[o];
    const int body = object_body_[o];
    const Eigen::Isometry3d X_WB = body < 0 ? Eigen::Isometry3d::Identity() : X_WB_[body];
    Eigen::Matrix4d X_WO = (X_WB * object.X_BO).matrix();
    X_WO.block<3, 3>(0, 0) *= object.scale.asDiagonal();
    return X_WO;
  }

  // Objects by the distance of their farthest extent from the eye: what lies wholly near comes first, so the
  // depth test rejects the pixels it hides before they are shaded (llvmpipe tests depth ahead of the shader);
  // the ground, reaching far away, comes last.
  const std::vector<std::size_t>& FrontToBack(const Eigen::Vector3d& eye_W) {
    draw_keys_.clear();
    for (std::size_t o = 0; o < scene_.objects.size(); ++o) {
      const Eigen::Vector3d origin_W = ObjectToWorld(o).block<3, 1>(0, 3);
      draw_keys_.emplace_back((origin_W - eye_W).norm() + object_radius_m_[o], o);
    }
    std::sort(draw_keys_.begin(), draw_keys_.end());
    draw_order_.clear();
    for (const auto& key : draw_keys_) draw_order_.push_back(key.second);
    return draw_order_;
  }

  bool HasBodyCasters() const {
    for (std::size_t o = 0; o < scene_.objects.size(); ++o) {
      if (object_body_[o] >= 0 && scene_.objects[o].casts_shadow) return true;
    }
    return false;
  }

  // Shadows come from two maps so that a flight redraws only what moves: the objects fixed in W, drawn when
  // the scene is set, over the sun's configured sphere (casters up to 3 radii toward the sun); and the
  // objects on bodies, drawn whenever a body moved, over the smallest sphere around them at a finer texel.
  void RenderFixedShadowMap() {
    const Sun& sun = scene_.sun;
    const double r = sun.shadow_radius_m;
    RenderShadowMap(&fixed_shadow_, sun.shadow_resolution, sun.shadow_center_W_m, r, 3.0 * r, r, false);
    fixed_shadow_dirty_ = false;
  }

  void RenderBodyShadowMap() {
    Eigen::AlignedBox3d casters_W;
    for (std::size_t o = 0; o < scene_.objects.size(); ++o) {
      if (object_body_[o] < 0 || !scene_.objects[o].casts_shadow) continue;
      const Eigen::Vector3d center_W = ObjectToWorld(o).block<3, 1>(0, 3);
      casters_W.extend(center_W - Eigen::Vector3d::Constant(object_radius_m_[o]));
      casters_W.extend(center_W + Eigen::Vector3d::Constant(object_radius_m_[o]));
    }
    const double r = std::max(0.5 * casters_W.diagonal().norm(), 1e-3);
    // the receivers: anything below the casters within the fixed map's reach
    const double beyond_m = r + 4.0 * scene_.sun.shadow_radius_m;
    RenderShadowMap(&body_shadow_, kBodyShadowResolution, casters_W.center(), r, r, beyond_m, true);
    body_shadow_reach_ = {casters_W.center(), r, beyond_m};
    body_shadow_dirty_ = false;
  }

  // Draws the casters fixed in W (bodies false) or on bodies (true) into `map`: an orthographic view along
  // the sun's travel of the disc of `radius_m` around center_W, depths from `toward_sun_m` before the centre
  // to `beyond_m` past it.
  void RenderShadowMap(ShadowMap* map, int resolution, const Eigen::Vector3d& center_W, double radius_m,
                       double toward_sun_m, double beyond_m, bool bodies) {
    if (map->framebuffer && map->resolution != resolution) ReleaseShadowMap(map);
    if (!map->framebuffer) {
      gl_.GenTextures(1, &map->texture);
      gl_.BindTexture(GL_TEXTURE_2D, map->texture);
      gl_.TexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, resolution, resolution, 0, GL_DEPTH_COMPONENT,
                     GL_FLOAT, nullptr);
      gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      // beyond the map the border's depth 1 passes the compare: lit
      gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_BORDER);
      gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_BORDER);
      const float farthest[4] = {1.0f, 1.0f, 1.0f, 1.0f};
      gl_.TexParameterfv(GL_TEXTURE_2D, GL_TEXTURE_BORDER_COLOR, farthest);
      gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
      gl_.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
      gl_.GenFramebuffers(1, &map->framebuffer);
      gl_.BindFramebuffer(GL_FRAMEBUFFER, map->framebuffer);
      gl_.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, map->texture, 0);
      const GLenum none = GL_NONE;
      gl_.DrawBuffers(1, &none);
      if (gl_.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        throw std::runtime_error("OpenGL: the shadow-map framebuffer is incomplete");
      }
      map->resolution = resolution;
    }
    // light frame L: z_L along the sun's travel, x_L and y_L across it
    const Eigen::Vector3d z_L = scene_.sun.direction_W.normalized();
    const Eigen::Vector3d helper =
        std::abs(z_L.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d x_L = helper.cross(z_L).normalized();
    const Eigen::Vector3d y_L = z_L.cross(x_L);
    Eigen::Matrix4d X_LW = Eigen::Matrix4d::Identity();
    X_LW.block<1, 3>(0, 0) = x_L.transpose();
    X_LW.block<1, 3>(1, 0) = y_L.transpose();
    X_LW.block<1, 3>(2, 0) = z_L.transpose();
    X_LW.block<3, 1>(0, 3) = -X_LW.block<3, 3>(0, 0) * center_W;
    const double z_near = -toward_sun_m, z_far = beyond_m;
    Eigen::Matrix4d ortho = Eigen::Matrix4d::Identity();
    ortho(0, 0) = 1.0 / radius_m;
    ortho(1, 1) = 1.0 / radius_m;
    ortho(2, 2) = 2.0 / (z_far - z_near);
    ortho(2, 3) = -(z_far + z_near) / (z_far - z_near);
    map->light_clip_W = ortho * X_LW;
    map->texel_m = 2.0 * radius_m / resolution;

    gl_.BindFramebuffer(GL_FRAMEBUFFER, map->framebuffer);
    gl_.Viewport(0, 0, resolution, resolution);
    gl_.Enable(GL_DEPTH_TEST);
    gl_.DepthFunc(GL_LESS);
    gl_.Clear(GL_DEPTH_BUFFER_BIT);
    gl_.Enable(GL_POLYGON_OFFSET_FILL);
    gl_.PolygonOffset(1.5f, 2.0f);
    Program& p = *shadow_program_;
    gl_.UseProgram(p.id());
    for (std::size_t o = 0; o < scene_.objects.size(); ++o) {
      if (!scene_.objects[o].casts_shadow || (object_body_[o] >= 0) != bodies) continue;
      p.Set("light_clip_O", Eigen::Matrix4f((map->light_clip_W * ObjectToWorld(o)).cast<float>()));
      for (const GpuPart& part : meshes_[scene_.objects[o].mesh]) {
        gl_.BindVertexArray(part.vertex_array);
        gl_.DrawElements(GL_TRIANGLES, part.index_count, GL_UNSIGNED_INT, nullptr);
      }
    }
    gl_.Disable(GL_POLYGON_OFFSET_FILL);
  }

  const Material& MaterialOf(const SceneObject& object, int part_material) const {
    return scene_.materials[object.material >= 0 ? object.material : part_material];
  }

  // Whether the objects on bodies can shade object o: objects on bodies always can (a vehicle shades
  // itself); a fixed object only if its bounding sphere reaches the cylinder their shadows fill, from the
  // casters' sphere along the sun's travel to the body map's far end.
  bool ReceivesBodyShadows(std::size_t o) const {
    if (object_body_[o] >= 0) return true;
    const Eigen::Vector3d v = ObjectToWorld(o).block<3, 1>(0, 3) - body_shadow_reach_.center_W;
    const double along_m = v.dot(scene_.sun.direction_W.normalized());
    const double across_m = (v - along_m * scene_.sun.direction_W.normalized()).norm();
    const double object_m = object_radius_m_[o], casters_m = body_shadow_reach_.radius_m;
    return across_m <= casters_m + object_m && along_m >= -casters_m - object_m &&
           along_m <= body_shadow_reach_.beyond_m + object_m;
  }

  unsigned Features(std::size_t o, const Material& material, bool body_shadows) const {
    unsigned features = material.texture >= 0 ? kTextured : 0u;
    if (material.unlit) return features;
    features |= kLit;
    if (material.specular > 0.0f) features |= kSpecular;
    if (scene_.fog.density_per_m > 0.0f) features |= kFog;
    if (scene_.sun.shadows) features |= kFixedShadows;
    if (body_shadows && ReceivesBodyShadows(o)) features |= kBodyShadows;
    return features;
  }

  // The scene program with these features, compiled at first use, made current and given this image's
  // uniforms if it does not hold them yet.
  Program& UseSceneProgram(unsigned features) {
    SceneProgram& entry = scene_programs_[features];
    if (!entry.program) {
      std::string defines;
      const std::pair<ShaderFeature, const char*> names[] = {
          {kTextured, "TEXTURED"},          {kLit, "LIT"},
          {kSpecular, "SPECULAR"},          {kFog, "FOG"},
          {kFixedShadows, "FIXED_SHADOWS"}, {kBodyShadows, "BODY_SHADOWS"}};
      for (const auto& [feature, name] : names) {
        if (features & feature) defines += std::string("#define ") + name + "\n";
      }
      entry.program =
          std::make_unique<Program>(gl_, kSceneVertexShader, kSceneFragmentShader, defines, "scene");
      Program& p = *entry.program;
      gl_.UseProgram(p.id());
      p.Set("albedo_texture", 0);
      p.Set("shadow_map", 1);
      p.Set("body_shadow_map", 2);
    }
    Program& p = *entry.program;
    gl_.UseProgram(p.id());
    if (entry.image == image_serial_) return p;
    entry.image = image_serial_;
    const ImageUniforms& u = image_uniforms_;
    p.Set("X_CW", u.X_CW);
    p.Set("clip_C", u.clip_C);
    p.Set("eye_W", u.eye_W);
    p.Set("exposure", u.exposure);
    p.Set("to_sun_W", Eigen::Vector3f((-scene_.sun.direction_W.normalized()).cast<float>()));
    p.Set("sun", Eigen::Vector3f(Linear(scene_.sun.color) * scene_.sun.intensity));
    p.Set("ambient", Eigen::Vector3f(Linear(scene_.ambient_color) * scene_.ambient_intensity));
    p.Set("fog_density", scene_.fog.density_per_m);
    p.Set("fog_color", Linear(scene_.fog.color));
    p.Set("light_clip_W", Eigen::Matrix4f(fixed_shadow_.light_clip_W.cast<float>()));
    p.Set("shadow_texel_m", static_cast<float>(fixed_shadow_.texel_m));
    p.Set("body_light_clip_W", Eigen::Matrix4f(body_shadow_.light_clip_W.cast<float>()));
    p.Set("body_shadow_texel_m", static_cast<float>(body_shadow_.texel_m));
    return p;
  }

  void DrawObject(std::size_t o, bool body_shadows) {
    const SceneObject& object = scene_.objects[o];
    const Eigen::Matrix4d X_WO = ObjectToWorld(o);
    const Eigen::Matrix4f X_WO_f = X_WO.cast<float>();
    const Eigen::Matrix3f normal_W_O = X_WO.block<3, 3>(0, 0).inverse().transpose().cast<float>();
    for (const GpuPart& part : meshes_[object.mesh]) {
      const Material& material = MaterialOf(object, part.material);
      Program& p = UseSceneProgram(Features(o, material, body_shadows));
      p.Set("X_WO", X_WO_f);
      p.Set("normal_W_O", normal_W_O);
      p.Set("albedo", Linear(material.color));
      if (material.texture >= 0) {
        gl_.ActiveTexture(GL_TEXTURE0);
        gl_.BindTexture(GL_TEXTURE_2D, textures_[material.texture]);
      }
      p.Set("specular", material.specular);
      p.Set("shininess", material.shininess);
      gl_.BindVertexArray(part.vertex_array);
      gl_.DrawElements(GL_TRIANGLES, part.index_count, GL_UNSIGNED_INT, nullptr);
    }
  }

  void ReadBack(int width, int height, Image* rgb, DepthImage* depth) {
    rgb->width = width;
    rgb->height = height;
    rgb->rgb.resize(static_cast<std::size_t>(width) * height * 3);
    gl_.PixelStorei(GL_PACK_ALIGNMENT, 1);
    gl_.ReadBuffer(GL_COLOR_ATTACHMENT0);
    gl_.ReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, rgb->rgb.data());
    if (depth) {
      depth->width = width;
      depth->height = height;
      depth->depth_m.resize(static_cast<std::size_t>(width) * height);
      gl_.ReadBuffer(GL_COLOR_ATTACHMENT1);
      gl_.ReadPixels(0, 0, width, height, GL_RED, GL_FLOAT, depth->depth_m.data());
    }
  }

  std::unique_ptr<GlContext> context_;
  GlFunctions gl_;
  std::string description_;
  std::map<unsigned, SceneProgram> scene_programs_;  // by ShaderFeature bits
  std::uint64_t image_serial_ = 0;
  ImageUniforms image_uniforms_;
  BodyShadowReach body_shadow_reach_;
  std::unique_ptr<Program> shadow_program_;
  Scene scene_;
  std::vector<std::vector<GpuPart>> meshes_;  // per scene mesh
  std::vector<GLuint> textures_;
  std::vector<std::string> body_names_;
  std::vector<Eigen::Isometry3d> X_WB_;
  std::vector<int> object_body_;         // body index per object, −1: fixed in W
  std::vector<double> object_radius_m_;  // per object: its mesh's farthest vertex from O, scaled
  std::vector<std::pair<double, std::size_t>> draw_keys_;  // FrontToBack's scratch
  std::vector<std::size_t> draw_order_;
  std::map<std::pair<int, int>, Target> targets_;
  ShadowMap fixed_shadow_, body_shadow_;
  bool fixed_shadow_dirty_ = true, body_shadow_dirty_ = true;
};

}  // namespace

Backend ParseBackend(const std::string& name) {
  if (name == "osmesa") return Backend::kOsMesa;
  if (name == "egl") return Backend::kEgl;
  throw std::invalid_argument("unknown render backend '" + name + "' (osmesa or egl)");
}

std::string BackendName(Backend backend) { return backend == Backend::kOsMesa ? "osmesa" : "egl"; }

std::vector<Backend> BuiltBackends() {
#ifdef IAPSIM_RENDER_EGL
  return {Backend::kOsMesa, Backend::kEgl};
#else
  return {Backend::kOsMesa};
#endif
}

std::unique_ptr<Renderer> MakeRenderer(const RendererOptions& options) {
  if (options.backend == Backend::kEgl) {
#ifdef IAPSIM_RENDER_EGL
    return std::make_unique<GlRenderer>(internal::MakeEglContext());
#else
    throw std::runtime_error("render backend egl was not built (configure with -DIAPSIM_RENDER_EGL=ON)");
#endif
  }
  return std::make_unique<GlRenderer>(internal::MakeOsMesaContext(options.threads));
}

}  // namespace iapsim::render
