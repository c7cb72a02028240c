// Mesh files (OBJ + MTL + texture, STL, glTF with an embedded buffer) and the errors for bad ones, and the
// scene YAML's errors: each names the file at fault.

#include "render/mesh_loader.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "bridge/config.h"
#include "render/renderer.h"
#include "render/scene_config.h"
#include "tests/support/test_folder.h"

namespace iapsim::render {
namespace {

namespace fs = std::filesystem;

// a fresh folder per test in the program's own temporary folder, removed with it when the program exits
std::string Folder(const std::string& name) {
  static const test_support::TestFolder root("iapsim_mesh");
  const fs::path dir = root.path() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::string Write(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// A 2 x 1 m quad in the file's x-y plane, textured with `texture` through quad.mtl.
std::string WriteTexturedObj(const std::string& dir, const std::string& texture) {
  Write(dir, "quad.mtl", "newmtl painted\nKd 1 1 1\nmap_Kd " + texture + "\n");
  return Write(dir, "quad.obj",
               "mtllib quad.mtl\n"
               "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\n"
               "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
               "usemtl painted\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
}

SceneObject Object(const std::string& name, int mesh) {
  SceneObject object;
  object.name = name;
  object.mesh = mesh;
  return object;
}

// the exception message of `f`, or "" when it throws nothing
template <class F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(MeshFile, ObjWithMaterialAndTextureIsDrawnTextured) {
  const std::string dir = Folder("obj");
  // a 16 x 16 texture: top half red, bottom half green
  Image texture{16, 16, {}};
  for (int v = 0; v < 16; ++v) {
    for (int u = 0; u < 16; ++u)
      texture.rgb.insert(texture.rgb.end(),
                         {std::uint8_t(v < 8 ? 255 : 0), std::uint8_t(v < 8 ? 0 : 255), 0});
  }
  WritePng(texture, dir + "/paint.png");
  Scene scene;
  const int mesh = AddMeshFile(&scene, WriteTexturedObj(dir, "paint.png"));
  ASSERT_EQ(scene.meshes[mesh].parts.size(), 1u);
  const MeshPart& part = scene.meshes[mesh].parts[0];
  EXPECT_EQ(part.indices.size(), 6u);
  const Material& material = scene.materials[part.material];
  ASSERT_GE(material.texture, 0);
  EXPECT_EQ(scene.textures[material.texture].width, 16);
  // the file's normal is computed: the quad faces ±z
  EXPECT_NEAR(std::abs(part.normals_O[0].z()), 1.0f, 1e-6f);

  // seen from 2 m along its normal, lit by ambient light only: v = 1 (the file's top) shows the top row
  scene.sun.intensity = 0.0f;
  scene.ambient_intensity = 1.0f;
  scene.sun.shadows = false;
  scene.AddObject(Object("quad", mesh));
  std::unique_ptr<Renderer> renderer = MakeRenderer();
  renderer->SetScene(scene);
  Camera camera;
  camera.intrinsics = CameraIntrinsics::FromHorizontalFov(64, 48, 1.2);
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.translation() = Eigen::Vector3d(1.0, 0.5, -2.0);  // z_C along +z_O, looking at the quad's centre
  Image image;
  renderer->Render(camera, X_WC, &image, nullptr);
  const Eigen::Vector2d top_uv = camera.intrinsics.Project(X_WC.inverse() * Eigen::Vector3d(1.0, 0.75, 0.0));
  const Eigen::Vector2d bottom_uv =
      camera.intrinsics.Project(X_WC.inverse() * Eigen::Vector3d(1.0, 0.25, 0.0));
  const std::uint8_t* top = image.Pixel(std::lround(top_uv.x()), std::lround(top_uv.y()));
  const std::uint8_t* bottom = image.Pixel(std::lround(bottom_uv.x()), std::lround(bottom_uv.y()));
  EXPECT_GT(top[0], 200);
  EXPECT_LT(top[1], 60);
  EXPECT_GT(bottom[1], 200);
  EXPECT_LT(bottom[0], 60);
}

TEST(MeshFile, StlAndGltfLoad) {
  const std::string dir = Folder("formats");
  Scene scene;
  const int stl =
      AddMeshFile(&scene, Write(dir, "tri.stl",
                                "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n"));
  EXPECT_EQ(scene.meshes[stl].parts.at(0).indices.size(), 3u);
  // one triangle, positions (0,0,0) (1,0,0) (0,1,0) as 36 bytes of little-endian floats, base64
  const std::string gltf =
      R"({"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}]})";
  const int triangle = AddMeshFile(&scene, Write(dir, "tri.gltf", gltf));
  const MeshPart& part = scene.meshes[triangle].parts.at(0);
  ASSERT_EQ(part.positions_O_m.size(), 3u);
  EXPECT_TRUE(part.positions_O_m[1].isApprox(Eigen::Vector3f(1, 0, 0)));
  scene.AddObject(Object("stl", stl));
  scene.AddObject(Object("gltf", triangle));
  EXPECT_NO_THROW(scene.Validate());
}

TEST(MeshFile, BadFilesAreNamedInTheError) {
  const std::string dir = Folder("bad");
  Scene scene;
  const std::string missing = dir + "/nothing.obj";
  std::string error = ErrorOf([&] { AddMeshFile(&scene, missing); });
  EXPECT_NE(error.find(missing), std::string::npos) << error;
  EXPECT_NE(error.find("no such mesh file"), std::string::npos) << error;

  const std::string unknown = Write(dir, "part.xyz", "1 2 3\n");
  error = ErrorOf([&] { AddMeshFile(&scene, unknown); });
  EXPECT_NE(error.find(unknown), std::string::npos) << error;
  EXPECT_NE(error.find("unsupported mesh format '.xyz'"), std::string::npos) << error;

  const std::string broken =
      Write(dir, "broken.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n");
  error = ErrorOf([&] { AddMeshFile(&scene, broken); });
  EXPECT_NE(error.find(broken), std::string::npos) << error;

  // a texture that is not there, and one that is not an image: both named, with the mesh naming them
  const std::string obj = WriteTexturedObj(dir, "missing.png");
  error = ErrorOf([&] { AddMeshFile(&scene, obj); });
  EXPECT_NE(error.find(dir + "/missing.png"), std::string::npos) << error;
  EXPECT_NE(error.find("no such image file"), std::string::npos) << error;
  EXPECT_NE(error.find(obj), std::string::npos) << error;
  Write(dir, "garbage.png", "this is not a PNG");
  const std::string obj2 = WriteTexturedObj(dir, "garbage.png");
  error = ErrorOf([&] { AddMeshFile(&scene, obj2); });
  EXPECT_NE(error.find(dir + "/garbage.png"), std::string::npos) << error;
  EXPECT_NE(error.find("not an image"), std::string::npos) << error;
}

// The scene YAML reports the YAML file, line and key, and the mesh or texture file behind it.
TEST(SceneFile, ErrorsNameTheYamlLineAndTheFile) {
  const std::string dir = Folder("scene");
  // LoadScene of `yaml` fails naming the file and `line`, and says every one of `says`
  const auto expect_error = [&](const std::string& name, const std::string& yaml, int line,
                                std::initializer_list<const char*> says) {
    const std::string path = Write(dir, name, yaml);
    const std::string error = ErrorOf([&] { LoadScene(path); });
    EXPECT_NE(error.find(path + ":" + std::to_string(line) + ":"), std::string::npos) << error;
    for (const char* text : says) EXPECT_NE(error.find(text), std::string::npos) << error;
  };
  expect_error("a.yaml",
               "name: a\n"
               "objects:\n"
               "  - {name: part, mesh: {file: parts/none.stl}}\n",
               3, {"objects[0]", "parts/none.stl"});
  Write(dir, "photo.png", "not an image");
  expect_error("b.yaml",
               "textures:\n"
               "  photo: {file: photo.png}\n",
               2, {"photo.png: not an image"});
  expect_error("c.yaml",
               "materials:\n"
               "  red: {colour: [1, 0, 0]}\n",
               2, {"did you mean 'color'"});
  expect_error("d.yaml",
               "materials:\n"
               "  red: {color: [1, 0, 0], texture: paint}\n",
               2, {"no texture 'paint' in `textures`"});
  expect_error("e.yaml",
               "objects:\n"
               "  - {name: x, box: [1, 1, 1], material: red}\n",
               2, {"no material 'red' in `materials`"});
  expect_error("f.yaml",
               "objects:\n"
               "  - {name: x, box: [1, 1, 1], sphere: {radius_m: 1}}\n",
               2, {"exactly one of"});
  EXPECT_THROW(LoadScene(dir + "/f.yaml"), bridge::ConfigError);  // a configuration error, like every key's
}

// Every shipped scene loads (configs/scenes).
TEST(SceneFile, ShippedScenesLoad) {
  const fs::path scenes = fs::path(IAPSIM_SOURCE_DIR) / "configs" / "scenes";
  int count = 0;
  for (const auto& entry : fs::directory_iterator(scenes)) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    const Scene scene = LoadScene(entry.path().string());
    EXPECT_NO_THROW(scene.Validate());
    EXPECT_FALSE(scene.objects.empty());
    ++count;
  }
  EXPECT_GE(count, 1);
}

}  // namespace
}  // namespace iapsim::render
