#include "render/scene.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

namespace iapsim::render {
namespace {

// Appends a quad p0 p1 p2 p3 (counter-clockwise seen from the side `normal` points to) with uv in metres.
void AddQuad(MeshPart* part, const Eigen::Vector3f& p0, const Eigen::Vector3f& p1, const Eigen::Vector3f& p2,
             const Eigen::Vector3f& p3, const Eigen::Vector3f& normal) {
  const auto base = static_cast<std::uint32_t>(part->positions_O_m.size());
  const Eigen::Vector3f u_axis = (p1 - p0).normalized();
  const Eigen::Vector3f v_axis = (p3 - p0).normalized();
  for (const Eigen::Vector3f& p : {p0, p1, p2, p3}) {
    part->positions_O_m.push_back(p);
    part->normals_O.push_back(normal);
    part->uv.emplace_back((p - p0).dot(u_axis), (p - p0).dot(v_axis));
  }
  for (const std::uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) part->indices.push_back(base + i);
}

// A surface of revolution about z: rings of (radius, z, normal_r, normal_z), closed by caps where asked.
Mesh Revolve(const std::vector<Eigen::Vector4f>& rings, int material, int segments,
             const std::string& source) {
  MeshPart part;
  part.material = material;
  const int columns = segments + 1;  // the seam repeats so uv wraps
  for (const Eigen::Vector4f& ring : rings) {
    for (int s = 0; s < columns; ++s) {
      const float angle = 2.0f * static_cast<float>(M_PI) * s / segments;
      const float c = std::cos(angle), sn = std::sin(angle);
      part.positions_O_m.emplace_back(ring(0) * c, ring(0) * sn, ring(1));
      part.normals_O.push_back(Eigen::Vector3f(ring(2) * c, ring(2) * sn, ring(3)).normalized());
      // u along the circumference and v along z, both in metres at the widest ring
      part.uv.emplace_back(angle * std::max(ring(0), 1e-3f), ring(1));
    }
  }
  for (std::size_t r = 0; r + 1 < rings.size(); ++r) {
    for (int s = 0; s < segments; ++s) {
      const auto a = static_cast<std::uint32_t>(r * columns + s);
      const auto b = static_cast<std::uint32_t>((r + 1) * columns + s);
      for (const std::uint32_t i : {a, b, b + 1, a, b + 1, a + 1}) part.indices.push_back(i);
    }
  }
  Mesh mesh;
  mesh.parts.push_back(std::move(part));
  mesh.source = source;
  return mesh;
}

// A flat disc at height z facing ±z, appended to the mesh's part.
void AddDisc(Mesh* mesh, float radius, float z, float normal_z, int segments) {
  MeshPart& part = mesh->parts.front();
  const auto centre = static_cast<std::uint32_t>(part.positions_O_m.size());
  part.positions_O_m.emplace_back(0.0f, 0.0f, z);
  part.normals_O.emplace_back(0.0f, 0.0f, normal_z);
  part.uv.emplace_back(0.0f, 0.0f);
  for (int s = 0; s <= segments; ++s) {
    const float angle = 2.0f * static_cast<float>(M_PI) * s / segments;
    part.positions_O_m.emplace_back(radius * std::cos(angle), radius * std::sin(angle), z);
    part.normals_O.emplace_back(0.0f, 0.0f, normal_z);
    part.uv.emplace_back(radius * std::cos(angle), radius * std::sin(angle));
  }
  for (int s = 0; s < segments; ++s) {
    for (const std::uint32_t i : {centre, centre + 1 + s, centre + 2 + s}) part.indices.push_back(i);
  }
}

}  // namespace

// appends and returns the new element's index
template <class T>
int Append(std::vector<T>* list, T value) {
  list->push_back(std::move(value));
  return static_cast<int>(list->size()) - 1;
}

int Scene::AddTexture(TextureImage texture) { return Append(&textures, std::move(texture)); }
int Scene::AddMaterial(const Material& material) { return Append(&materials, material); }
int Scene::AddMesh(Mesh mesh) { return Append(&meshes, std::move(mesh)); }
int Scene::AddObject(const SceneObject& object) { return Append(&objects, object); }

std::vector<std::string> Scene::Bodies() const {
  std::set<std::string> bodies;
  for (const SceneObject& object : objects) {
    if (!object.body.empty()) bodies.insert(object.body);
  }
  return {bodies.begin(), bodies.end()};
}

void Scene::Validate() const {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("scene: " + what); };
  const int n_textures = static_cast<int>(textures.size());
  const int n_materials = static_cast<int>(materials.size());
  for (const TextureImage& texture : textures) {
    if (texture.width <= 0 || texture.height <= 0 ||
        texture.rgb.size() != static_cast<std::size_t>(texture.width) * texture.height * 3) {
      fail("texture " + texture.source + " has no pixels or the wrong number of bytes");
    }
  }
  for (std::size_t m = 0; m < materials.size(); ++m) {
    if (materials[m].texture < -1 || materials[m].texture >= n_textures) {
      fail("material " + std::to_string(m) + " names texture " + std::to_string(materials[m].texture) +
           " of " + std::to_string(n_textures));
    }
  }
  for (const Mesh& mesh : meshes) {
    for (const MeshPart& part : mesh.parts) {
      const std::size_t n = part.positions_O_m.size();
      if (part.normals_O.size() != n || part.uv.size() != n)
        fail("mesh " + mesh.source + ": a part's normals or uv do not match its positions");
      if (part.indices.size() % 3 != 0) fail("mesh " + mesh.source + ": indices are not whole triangles");
      for (const std::uint32_t i : part.indices) {
        if (i >= n) fail("mesh " + mesh.source + ": an index is past its vertices");
      }
      if (part.material < 0 || part.material >= n_materials)
        fail("mesh " + mesh.source + ": a part's material does not exist");
    }
  }
  for (const SceneObject& object : objects) {
    if (object.mesh < 0 || object.mesh >= static_cast<int>(meshes.size()))
      fail("object " + object.name + ": no such mesh");
    if (object.material < -1 || object.material >= n_materials)
      fail("object " + object.name + ": no such material");
    if (!object.scale.allFinite() || (object.scale.array() <= 0.0).any())
      fail("object " + object.name + ": scale must be positive");
  }
}

Mesh MakeBox(const Eigen::Vector3d& size_m, int material) {
  const Eigen::Vector3f h = 0.5f * size_m.cast<float>();
  MeshPart part;
  part.material = material;
  // one quad per face, corners counter-clockwise seen from outside
  const auto corner = [&](float sx, float sy, float sz) {
    return Eigen::Vector3f(sx * h.x(), sy * h.y(), sz * h.z());
  };
  AddQuad(&part, corner(1, -1, -1), corner(1, 1, -1), corner(1, 1, 1), corner(1, -1, 1),
          Eigen::Vector3f::UnitX());
  AddQuad(&part, corner(-1, 1, -1), corner(-1, -1, -1), corner(-1, -1, 1), corner(-1, 1, 1),
          -Eigen::Vector3f::UnitX());
  AddQuad(&part, corner(1, 1, -1), corner(-1, 1, -1), corner(-1, 1, 1), corner(1, 1, 1),
          Eigen::Vector3f::UnitY());
  AddQuad(&part, corner(-1, -1, -1), corner(1, -1, -1), corner(1, -1, 1), corner(-1, -1, 1),
          -Eigen::Vector3f::UnitY());
  AddQuad(&part, corner(-1, -1, 1), corner(1, -1, 1), corner(1, 1, 1), corner(-1, 1, 1),
          Eigen::Vector3f::UnitZ());
  AddQuad(&part, corner(-1, 1, -1), corner(1, 1, -1), corner(1, -1, -1), corner(-1, -1, -1),
          -Eigen::Vector3f::UnitZ());
  Mesh mesh;
  mesh.parts.push_back(std::move(part));
  mesh.source = "box";
  return mesh;
}

Mesh MakePlane(double size_x_m, double size_y_m, int material) {
  const float hx = 0.5f * static_cast<float>(size_x_m), hy = 0.5f * static_cast<float>(size_y_m);
  MeshPart part;
  part.material = material;
  AddQuad(&part, {-hx, -hy, 0.0f}, {hx, -hy, 0.0f}, {hx, hy, 0.0f}, {-hx, hy, 0.0f},
          -Eigen::Vector3f::UnitZ());
  Mesh mesh;
  mesh.parts.push_back(std::move(part));
  mesh.source = "plane";
  return mesh;
}

Mesh MakeSphere(double radius_m, int material, int segments) {
  const float r = static_cast<float>(radius_m);
  std::vector<Eigen::Vector4f> rings;
  const int stacks = std::max(segments / 2, 2);
  for (int i = 0; i <= stacks; ++i) {
    const float polar = static_cast<float>(M_PI) * i / stacks;  // from −z to +z
    rings.emplace_back(r * std::sin(polar), -r * std::cos(polar), std::sin(polar), -std::cos(polar));
  }
  return Revolve(rings, material, segments, "sphere");
}

Mesh MakeCylinder(double radius_m, double length_m, int material, int segments) {
  const float r = static_cast<float>(radius_m), h = 0.5f * static_cast<float>(length_m);
  Mesh mesh = Revolve({{r, -h, 1.0f, 0.0f}, {r, h, 1.0f, 0.0f}}, material, segments, "cylinder");
  AddDisc(&mesh, r, -h, -1.0f, segments);
  AddDisc(&mesh, r, h, 1.0f, segments);
  return mesh;
}

Mesh MakeCone(double radius_m, double length_m, int material, int segments) {
  const float r = static_cast<float>(radius_m), h = 0.5f * static_cast<float>(length_m);
  // the side's normal leans toward the apex by the half-angle
  const float slant = std::hypot(r, 2.0f * h);
  const float n_r = 2.0f * h / slant, n_z = r / slant;
  Mesh mesh = Revolve({{r, -h, n_r, n_z}, {0.0f, h, n_r, n_z}}, material, segments, "cone");
  AddDisc(&mesh, r, -h, -1.0f, segments);
  return mesh;
}

void ScaleUv(Mesh* mesh, float repeats_per_unit) {
  for (MeshPart& part : mesh->parts) {
    for (Eigen::Vector2f& uv : part.uv) uv *= repeats_per_unit;
  }
}

}  // namespace iapsim::render
