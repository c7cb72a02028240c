#include "model/mesh.h"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <array>
#include <assimp/Importer.hpp>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <stdexcept>

namespace iapsim::model {

Eigen::Vector3d TriangleMesh::MinCorner_m() const {
  Eigen::Vector3d corner = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  for (const auto& v : vertices_m) corner = corner.cwiseMin(v);
  return corner;
}

Eigen::Vector3d TriangleMesh::MaxCorner_m() const {
  Eigen::Vector3d corner = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  for (const auto& v : vertices_m) corner = corner.cwiseMax(v);
  return corner;
}

TriangleMesh LoadTriangleMesh(const std::string& path, const Eigen::Vector3d& scale) {
  const auto fail = [&](const std::string& what) { throw std::invalid_argument(path + ": " + what); };
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) fail("no such mesh file");
  Assimp::Importer importer;
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);  // keep a DAE's own axes
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  if (!scene || !scene->mRootNode) fail(std::string("assimp cannot read it: ") + importer.GetErrorString());
  if (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) fail("assimp read an incomplete scene");

  // Importers give each face corner its own vertex (STL always, OBJ wherever normals or texture
  // coordinates differ): merge equal positions so hulls and counts see the shape's real vertices.
  TriangleMesh mesh;
  std::map<std::array<double, 3>, int> index_of;
  const auto vertex_index = [&](const aiVector3D& v) {
    const Eigen::Vector3d p_m = scale.cwiseProduct(Eigen::Vector3d(v.x, v.y, v.z));
    if (!p_m.allFinite()) fail("a vertex is not finite");
    const auto [it, added] =
        index_of.try_emplace({p_m.x(), p_m.y(), p_m.z()}, static_cast<int>(mesh.vertices_m.size()));
    if (added) mesh.vertices_m.push_back(p_m);
    return it->second;
  };
  // every mesh each node places, with the node's transform in the file's root frame (a DAE's unit is in it)
  const std::function<void(const aiNode&, const aiMatrix4x4&)> add_node = [&](const aiNode& node,
                                                                              const aiMatrix4x4& parent) {
    const aiMatrix4x4 transform = parent * node.mTransformation;
    for (unsigned m = 0; m < node.mNumMeshes; ++m) {
      const aiMesh& part = *scene->mMeshes[node.mMeshes[m]];
      TriangleMesh::Part range{static_cast<int>(mesh.triangles.size()), 0};
      for (unsigned f = 0; f < part.mNumFaces; ++f) {
        const aiFace& face = part.mFaces[f];
        if (face.mNumIndices != 3) continue;  // a point or a line
        const Eigen::Vector3i triangle(vertex_index(transform * part.mVertices[face.mIndices[0]]),
                                       vertex_index(transform * part.mVertices[face.mIndices[1]]),
                                       vertex_index(transform * part.mVertices[face.mIndices[2]]));
        // a triangle whose corners merged has no area
        if (triangle(0) != triangle(1) && triangle(1) != triangle(2) && triangle(0) != triangle(2)) {
          mesh.triangles.push_back(triangle);
          ++range.triangle_count;
        }
      }
      if (range.triangle_count > 0) mesh.parts.push_back(range);
    }
    for (unsigned c = 0; c < node.mNumChildren; ++c) add_node(*node.mChildren[c], transform);
  };
  add_node(*scene->mRootNode, aiMatrix4x4());
  if (mesh.triangles.empty()) fail("the mesh has no triangles");
  return mesh;
}

}  // namespace iapsim::model
