#include "render/mesh_loader.h"

#include <assimp/config.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <filesystem>
#include <functional>
#include <map>
#include <stdexcept>

#include "render/image.h"

namespace iapsim::render {
namespace {

// the material's diffuse texture: an embedded one ("*0" or by name) or a file relative to the mesh
int AddTexture(Scene* scene, const aiScene& file, const aiString& name, const std::string& mesh_path,
               std::map<std::string, int>* loaded) {
  const std::string key = name.C_Str();
  if (auto it = loaded->find(key); it != loaded->end()) return it->second;
  TextureImage texture;
  if (const aiTexture* embedded = file.GetEmbeddedTexture(name.C_Str())) {
    const std::string what = mesh_path + ": embedded texture " + key;
    if (embedded->mHeight == 0) {
      // compressed (PNG, JPEG) bytes
      const auto* bytes = reinterpret_cast<const std::uint8_t*>(embedded->pcData);
      const Image image = DecodeImage({bytes, bytes + embedded->mWidth}, what);
      texture = {image.width, image.height, image.rgb, what};
    } else {
      texture.width = static_cast<int>(embedded->mWidth);
      texture.height = static_cast<int>(embedded->mHeight);
      texture.source = what;
      for (unsigned i = 0; i < embedded->mWidth * embedded->mHeight; ++i) {
        const aiTexel& t = embedded->pcData[i];
        texture.rgb.insert(texture.rgb.end(), {t.r, t.g, t.b});
      }
    }
  } else {
    const std::filesystem::path file_path = std::filesystem::path(mesh_path).parent_path() / key;
    try {
      const Image image = ReadImageFile(file_path.lexically_normal().string());
      texture = {image.width, image.height, image.rgb, file_path.string()};
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string(e.what()) + " (a texture of mesh " + mesh_path + ")");
    }
  }
  const int index = scene->AddTexture(std::move(texture));
  loaded->emplace(key, index);
  return index;
}

Material ReadMaterial(Scene* scene, const aiScene& file, const aiMaterial& source, const std::string& path,
                      std::map<std::string, int>* textures) {
  Material material;
  aiColor4D diffuse;
  // glTF's base colour first, then the classic diffuse colour
  if (source.Get(AI_MATKEY_BASE_COLOR, diffuse) == aiReturn_SUCCESS ||
      source.Get(AI_MATKEY_COLOR_DIFFUSE, diffuse) == aiReturn_SUCCESS) {
    material.color = Eigen::Vector3f(diffuse.r, diffuse.g, diffuse.b);
  }
  float shininess = 0.0f;
  if (source.Get(AI_MATKEY_SHININESS, shininess) == aiReturn_SUCCESS && shininess > 1.0f) {
    material.shininess = shininess;
  }
  aiString texture;
  if (source.GetTexture(aiTextureType_BASE_COLOR, 0, &texture) == aiReturn_SUCCESS ||
      source.GetTexture(aiTextureType_DIFFUSE, 0, &texture) == aiReturn_SUCCESS) {
    material.texture = AddTexture(scene, file, texture, path, textures);
  }
  return material;
}

}  // namespace

int AddMeshFile(Scene* scene, const std::string& path) {
  const auto fail = [&](const std::string& what) { throw std::invalid_argument(path + ": " + what); };
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) fail("no such mesh file");
  Assimp::Importer importer;
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension.empty() || !importer.IsExtensionSupported(extension)) {
    fail("unsupported mesh format '" + extension + "' (assimp reads OBJ, STL, glTF/GLB, DAE, PLY, FBX, ...)");
  }
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);  // as model/mesh.h
  importer.SetPropertyFloat(AI_CONFIG_PP_GSN_MAX_SMOOTHING_ANGLE, 60.0f);
  const aiScene* file = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_GenSmoothNormals |
                                                    aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
  if (!file || !file->mRootNode) fail(std::string("assimp cannot read it: ") + importer.GetErrorString());
  if (file->mFlags & AI_SCENE_FLAGS_INCOMPLETE) fail("assimp read an incomplete scene");

  // the file's materials become scene materials
  std::map<std::string, int> textures;
  std::vector<int> material_index;
  for (unsigned m = 0; m < file->mNumMaterials; ++m) {
    material_index.push_back(
        scene->AddMaterial(ReadMaterial(scene, *file, *file->mMaterials[m], path, &textures)));
  }
  if (material_index.empty()) material_index.push_back(scene->AddMaterial(Material{}));

  Mesh mesh;
  mesh.source = path;
  const std::function<void(const aiNode&, const aiMatrix4x4&)> add_node = [&](const aiNode& node,
                                                                              const aiMatrix4x4& parent) {
    const aiMatrix4x4 transform = parent * node.mTransformation;
    aiMatrix3x3 normal_transform(transform);
    normal_transform.Inverse().Transpose();
    for (unsigned m = 0; m < node.mNumMeshes; ++m) {
      const aiMesh& source = *file->mMeshes[node.mMeshes[m]];
      if (!(source.mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;  // points, lines
      MeshPart part;
      part.material = material_index[std::min<unsigned>(source.mMaterialIndex, material_index.size() - 1)];
      for (unsigned v = 0; v < source.mNumVertices; ++v) {
        const aiVector3D p = transform * source.mVertices[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) fail("a vertex is not finite");
        part.positions_O_m.emplace_back(p.x, p.y, p.z);
        aiVector3D n = source.mNormals ? normal_transform * source.mNormals[v] : aiVector3D(0, 0, 1);
        n.Normalize();
        part.normals_O.emplace_back(n.x, n.y, n.z);
        const aiVector3D uv = source.HasTextureCoords(0) ? source.mTextureCoords[0][v] : aiVector3D();
        // images are stored top row first: flip v (assimp gives OpenGL's bottom-up v, glTF's included)
        part.uv.emplace_back(uv.x, 1.0f - uv.y);
      }
      for (unsigned f = 0; f < source.mNumFaces; ++f) {
        const aiFace& face = source.mFaces[f];
        if (face.mNumIndices != 3) continue;
        for (int k = 0; k < 3; ++k) part.indices.push_back(face.mIndices[k]);
      }
      if (!part.indices.empty()) mesh.parts.push_back(std::move(part));
    }
    for (unsigned c = 0; c < node.mNumChildren; ++c) add_node(*node.mChildren[c], transform);
  };
  add_node(*file->mRootNode, aiMatrix4x4());
  if (mesh.parts.empty()) fail("the mesh has no triangles");
  return scene->AddMesh(std::move(mesh));
}

}  // namespace iapsim::render
