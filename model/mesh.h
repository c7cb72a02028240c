#pragma once
// Triangle meshes read from files (assimp: OBJ, STL, glTF/GLB, DAE, and whatever else it reads), free of any
// engine: the physics makes colliders of them, the renderer can draw them.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace iapsim::model {

/// The triangles of a mesh file, in the file's own axes (glTF's are y-up: rotate with the shape's rpy_deg),
/// lengths in metres: a file's unit (a DAE <unit>) applied, then the scale per axis. Vertices are shared
/// between triangles wherever they coincide.
struct TriangleMesh {
  /// A run of triangles that the file keeps apart: an OBJ object or group, a glTF mesh, a DAE geometry (one
  /// per material within it). A convex decomposition (V-HACD's output, configs/meshes/funnel.obj) has one
  /// part per convex piece.
  struct Part {
    int first_triangle = 0;
    int triangle_count = 0;
  };
  std::vector<Eigen::Vector3d> vertices_m;
  std::vector<Eigen::Vector3i> triangles;  // vertex indices, in the file's winding
  std::vector<Part> parts;                 // in file order, covering `triangles`

  Eigen::Vector3d MinCorner_m() const;
  Eigen::Vector3d MaxCorner_m() const;
};

/// Reads every mesh of the file, each placed by its node's transform; points and lines are dropped. Throws
/// std::invalid_argument naming the file when assimp cannot read it, or when it holds no triangle or a
/// non-finite vertex.
TriangleMesh LoadTriangleMesh(const std::string& path,
                              const Eigen::Vector3d& scale = Eigen::Vector3d::Ones());

}  // namespace iapsim::model
