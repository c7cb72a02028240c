#pragma once
// Mesh files for drawing, through assimp: OBJ (+ MTL), STL, glTF/GLB, DAE and whatever else it reads, with
// normals, texture coordinates and materials (diffuse colour and diffuse texture, file or embedded).

#include <string>

#include "render/scene.h"

namespace iapsim::render {

/// Reads a mesh file into `scene`: adds its materials and textures and the mesh (every node's meshes in the
/// file's root frame, positions in the file's units, glTF's y-up axes kept), returning the mesh's index.
/// Missing normals are computed, smoothed below 60°. Throws std::invalid_argument naming the file when it is
/// missing, of a format assimp does not read, unreadable or without triangles, and naming the texture file
/// and the mesh file when a texture is missing or not an image.
int AddMeshFile(Scene* scene, const std::string& path);

}  // namespace iapsim::render
