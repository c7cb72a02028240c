#pragma once
// What the renderer draws: meshes (triangles with normals and texture coordinates), materials, textures,
// objects placing meshes in the world or on a moving body, a sun with shadows, ambient light, distance fog
// and a sky colour. Plain values: a scene is built in code or read from YAML (scene_config.h), then handed
// to Renderer::SetScene. Frames: W is the world (NED, z down), B a body (FRD), O an object's mesh frame.
// Colours are sRGB in [0, 1] as a colour picker shows them; lighting is computed in linear light.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace iapsim::render {

/// An 8-bit sRGB image used as a texture (rows top first, 3 bytes a pixel).
struct TextureImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;
  std::string source;  ///< the file it came from, or the procedural recipe (for messages)
};

struct Material {
  Eigen::Vector3f color = Eigen::Vector3f::Constant(0.8f);  ///< sRGB; multiplies the texture
  int texture = -1;                                         ///< index into Scene::textures, −1: none
  float specular = 0.1f;                                    ///< strength of the sun's highlight, 0..1
  float shininess = 32.0f;                                  ///< Blinn-Phong exponent
  bool unlit = false;  ///< drawn in its colour alone (markers, lamps): no light, shadow or fog
};

/// Triangles sharing one material. Positions in metres in the mesh frame O; uv in texture repeats.
struct MeshPart {
  std::vector<Eigen::Vector3f> positions_O_m;
  std::vector<Eigen::Vector3f> normals_O;  ///< unit, one per position
  std::vector<Eigen::Vector2f> uv;         ///< one per position (zeros where the file has none)
  std::vector<std::uint32_t> indices;      ///< three per triangle
  int material = 0;                        ///< index into Scene::materials
};

struct Mesh {
  std::vector<MeshPart> parts;
  std::string source;  ///< file or primitive, for messages
};

/// One mesh placed in the scene: X_WO = X_WB · X_BO · diag(scale), B being `body`'s pose (set every frame
/// with Renderer::SetBodyPose) or W itself when `body` is empty.
struct SceneObject {
  std::string name;
  int mesh = 0;  ///< index into Scene::meshes
  std::string body;
  Eigen::Isometry3d X_BO = Eigen::Isometry3d::Identity();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  int material = -1;  ///< overrides every part's material when ≥ 0
  bool casts_shadow = true;
};

/// The sun: parallel light travelling along `direction_W` (NED: +z shines straight down).
struct Sun {
  Eigen::Vector3d direction_W = Eigen::Vector3d(0.3, 0.2, 1.0).normalized();
  Eigen::Vector3f color = Eigen::Vector3f::Ones();  ///< sRGB
  float intensity = 2.5f;                           ///< irradiance on a surface facing it, times color
  bool shadows = true;
  int shadow_resolution = 2048;  ///< texels along each side of the shadow map
  /// The shadow map covers the sphere of this radius around shadow_center_W_m (objects outside it cast no
  /// shadow and are lit).
  double shadow_radius_m = 30.0;
  Eigen::Vector3d shadow_center_W_m = Eigen::Vector3d::Zero();
};

/// Exponential distance fog: a surface at distance d keeps exp(−density·d) of its colour, the rest is fog.
struct Fog {
  float density_per_m = 0.0f;  ///< 0: no fog
  Eigen::Vector3f color = Eigen::Vector3f::Constant(0.75f);
};

struct Scene {
  std::string name;
  std::vector<TextureImage> textures;
  std::vector<Material> materials;
  std::vector<Mesh> meshes;
  std::vector<SceneObject> objects;
  Sun sun;
  Eigen::Vector3f ambient_color = Eigen::Vector3f::Ones();  ///< sRGB light arriving from every side
  float ambient_intensity = 0.35f;
  Eigen::Vector3f sky_color = Eigen::Vector3f(0.55f, 0.7f, 0.9f);  ///< sRGB, where nothing is drawn
  Fog fog;

  int AddTexture(TextureImage texture);
  int AddMaterial(const Material& material);
  int AddMesh(Mesh mesh);
  /// Adds an object; returns its index.
  int AddObject(const SceneObject& object);
  /// The bodies that objects name (sorted, without duplicates).
  std::vector<std::string> Bodies() const;
  /// Throws std::invalid_argument naming the object, mesh or material whose index or data is bad.
  void Validate() const;
};

/// Primitives in their own frame O, with texture coordinates in metres (a material's texture repeats once a
/// metre; scale uv with ScaleUv). The plane lies in O's x-y plane facing −z (up in NED), centred on O.
Mesh MakeBox(const Eigen::Vector3d& size_m, int material);
Mesh MakePlane(double size_x_m, double size_y_m, int material);
Mesh MakeSphere(double radius_m, int material, int segments = 24);
/// Along O's z axis, centred on half the length (as model::Shape).
Mesh MakeCylinder(double radius_m, double length_m, int material, int segments = 24);
/// Apex along +z, base circle at −length/2 (as model::Shape).
Mesh MakeCone(double radius_m, double length_m, int material, int segments = 24);
/// Multiplies every texture coordinate by `repeats_per_unit`.
void ScaleUv(Mesh* mesh, float repeats_per_unit);

}  // namespace iapsim::render
