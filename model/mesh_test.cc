// Mesh files (assimp) and mesh shapes: counts and bounds per format, units and scale, errors that name the
// file, and mesh collision shapes through YAML and URDF.
#include "model/mesh.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "bridge/config.h"
#include "model/urdf.h"
#include "model/vehicle.h"
#include "tests/support/test_folder.h"

namespace iapsim::model {
namespace {

namespace fs = std::filesystem;

// A file in this test's own folder (so a YAML file can name it relative to itself).
std::string WriteFile(const std::string& name, const std::string& text) {
  static const test_support::TestFolder folder("mesh_test");
  return folder.Write(name, text);
}

// A unit cube centred on the origin: quads with per-corner texture coordinates and normals, so the
// importer's corners differ while their positions repeat.
constexpr char kCubeObj[] = R"(# unit cube
v -0.5 -0.5 -0.5
v 0.5 -0.5 -0.5
v -0.5 0.5 -0.5
v 0.5 0.5 -0.5
v -0.5 -0.5 0.5
v 0.5 -0.5 0.5
v -0.5 0.5 0.5
v 0.5 0.5 0.5
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 -1
vn 0 0 1
vn 0 -1 0
vn 0 1 0
vn -1 0 0
vn 1 0 0
f 1/1/1 3/2/1 4/3/1 2/4/1
f 5/1/2 6/2/2 8/3/2 7/4/2
f 1/1/3 2/2/3 6/3/3 5/4/3
f 3/1/4 7/2/4 8/3/4 4/4/4
f 1/1/5 5/2/5 7/3/5 3/4/5
f 2/1/6 4/2/6 8/3/6 6/4/6
)";

// A tetrahedron with corners at the origin and on each axis, one facet normal per triangle.
constexpr char kTetrahedronStl[] = R"(solid tetra
facet normal 0 0 -1
 outer loop
  vertex 0 0 0
  vertex 0 1 0
  vertex 1 0 0
 endloop
endfacet
facet normal 0 -1 0
 outer loop
  vertex 0 0 0
  vertex 1 0 0
  vertex 0 0 1
 endloop
endfacet
facet normal -1 0 0
 outer loop
  vertex 0 0 0
  vertex 0 0 1
  vertex 0 1 0
 endloop
endfacet
facet normal 0.577 0.577 0.577
 outer loop
  vertex 1 0 0
  vertex 0 1 0
  vertex 0 0 1
 endloop
endfacet
endsolid tetra
)";

// One triangle in millimetres, z up: the unit is applied, the axes are kept.
constexpr char kTriangleDae[] = R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="millimeter" meter="0.001"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries>
    <geometry id="tri">
      <mesh>
        <source id="tri-pos">
          <float_array id="tri-pos-array" count="9">0 0 0 1000 0 0 0 2000 500</float_array>
          <technique_common>
            <accessor source="#tri-pos-array" count="3" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="tri-vtx"><input semantic="POSITION" source="#tri-pos"/></vertices>
        <triangles count="1"><input semantic="VERTEX" source="#tri-vtx" offset="0"/><p>0 1 2</p></triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene"><node id="n"><instance_geometry url="#tri"/></node></visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
)";

// One triangle (0,0,0), (1,0,0), (0,1,0): float positions and 16-bit indices in a base64 buffer.
constexpr char kTriangleGltf[] = R"({
  "asset": {"version": "2.0"},
  "buffers": [{"byteLength": 44,
               "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "nodes": [{"mesh": 0}],
  "scenes": [{"nodes": [0]}],
  "scene": 0
}
)";

TEST(Mesh, ReadsEachFormatWithSharedVerticesInMetres) {
  struct Case {
    std::string name, text;
    size_t vertices, triangles;
    Eigen::Vector3d min_m, max_m;
  };
  const std::vector<Case> cases = {
      {"cube.obj", kCubeObj, 8, 12, Eigen::Vector3d::Constant(-0.5), Eigen::Vector3d::Constant(0.5)},
      {"tetrahedron.stl", kTetrahedronStl, 4, 4, Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()},
      {"triangle.dae", kTriangleDae, 3, 1, Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 2.0, 0.5)},
      {"triangle.gltf", kTriangleGltf, 3, 1, Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 1.0, 0.0)},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const TriangleMesh mesh = LoadTriangleMesh(WriteFile(c.name, c.text));
    EXPECT_EQ(mesh.vertices_m.size(), c.vertices);
    EXPECT_EQ(mesh.triangles.size(), c.triangles);
    EXPECT_LT((mesh.MinCorner_m() - c.min_m).norm(), 1e-6);
    EXPECT_LT((mesh.MaxCorner_m() - c.max_m).norm(), 1e-6);
    for (const Eigen::Vector3i& triangle : mesh.triangles) {
      EXPECT_GE(triangle.minCoeff(), 0);
      EXPECT_LT(triangle.maxCoeff(), static_cast<int>(mesh.vertices_m.size()));
    }
  }
}

TEST(Mesh, ScalesPerAxis) {
  const TriangleMesh mesh = LoadTriangleMesh(WriteFile("cube.obj", kCubeObj), Eigen::Vector3d(2.0, 0.1, 0.5));
  EXPECT_EQ(mesh.MinCorner_m(), Eigen::Vector3d(-1.0, -0.05, -0.25));
  EXPECT_EQ(mesh.MaxCorner_m(), Eigen::Vector3d(1.0, 0.05, 0.25));
}

TEST(Mesh, ABadOrMissingFileIsAnErrorNamingIt) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {WriteFile("garbage.stl", "solid x\nfacet normal 0 0 1\n outer loop\n  vertex 0 0\n"),
       "assimp cannot read"},
      {WriteFile("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\np 1 2 3\n"), "no triangles"},
      {WriteFile("mesh.unknownformat", "hello\n"), "assimp cannot read"},
      {::testing::TempDir() + "/no/such/mesh.obj", "no such mesh file"},
  };
  for (const auto& [path, expected] : cases) {
    SCOPED_TRACE(path);
    try {
      LoadTriangleMesh(path);
      ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(path + ": "), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
}

std::string F450() { return std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/parts/f450.yaml"; }

// A free quadrotor whose tool collides as a mesh: `tool_collision` is the tool's list of shapes.
std::string ProbeVehicle(const std::string& tool_collision) {
  return "name: probe\n"
         "platform: {mass_kg: 0.2, inertia_kgm2: [0.001, 0.001, 0.001]}\n"
         "tools:\n"
         "  - {name: block, mass_kg: 0.1, inertia_kgm2: [0.0001, 0.0001, 0.0001], origin_m: [0, 0.3, 0],\n"
         "     collision: " +
         tool_collision +
         "}\n"
         "sub_aircraft_defaults: {base: " +
         F450() +
         ", joint: fixed}\n"
         "sub_aircraft:\n  - {name: quad, joint_m: [0, 0, 0]}\n";
}

// The mesh's file resolves next to the vehicle file, and URDF keeps it: <mesh filename scale/>.
TEST(Mesh, AVehicleMeshShapeRoundTripsThroughUrdf) {
  const std::string cube = fs::canonical(WriteFile("cube.obj", kCubeObj)).string();
  const std::string yaml = WriteFile(
      "probe.yaml", ProbeVehicle("[{mesh: {file: cube.obj, scale: [0.1, 0.2, 0.3]}, origin_m: [0, 0.05, 0],"
                                 " rpy_deg: [90, 0, 0]}]"));
  const Vehicle vehicle = LoadVehicle(yaml);
  ASSERT_EQ(vehicle.tools.size(), 1u);
  ASSERT_EQ(vehicle.tools[0].collision.size(), 1u);
  const Shape& shape = vehicle.tools[0].collision[0];
  EXPECT_EQ(shape.kind, Shape::Kind::kMesh);
  EXPECT_EQ(shape.mesh_file, cube);
  EXPECT_EQ(shape.mesh_scale, Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_TRUE(shape.mesh_convex);

  const std::string urdf = GenerateUrdf(vehicle);
  EXPECT_NE(urdf.find("<mesh filename=\"" + cube + "\" scale=\"0.1 0.2 0.3\"/>"), std::string::npos) << urdf;
  const MultibodyDescription description = ParseUrdf(urdf, "probe.urdf");
  for (const LinkDescription& link : description.links) {
    if (link.name != "block") continue;
    ASSERT_EQ(link.collision.size(), 1u);
    const Shape& back = link.collision[0];
    EXPECT_EQ(back.kind, Shape::Kind::kMesh);
    EXPECT_EQ(back.mesh_file, cube);
    EXPECT_EQ(back.mesh_scale, shape.mesh_scale);  // exact: 17 digits
    EXPECT_TRUE(back.mesh_convex);
    EXPECT_EQ(back.origin_B_m, shape.origin_B_m);
    EXPECT_NEAR(back.rpy_B_rad.x(), M_PI / 2, 1e-12);
  }

  // a hand-written URDF's relative mesh file is relative to the URDF; a scalar scale is uniform
  const std::string relative_yaml =
      WriteFile("probe_uniform.yaml", ProbeVehicle("[{mesh: {file: cube.obj, scale: 0.25}}]"));
  EXPECT_EQ(LoadVehicle(relative_yaml).tools[0].collision[0].mesh_scale, Eigen::Vector3d::Constant(0.25));
  std::string relative_urdf = urdf;
  relative_urdf.replace(relative_urdf.find(cube), cube.size(), "cube.obj");
  const std::string urdf_path = WriteFile("probe.urdf", relative_urdf);
  for (const LinkDescription& link : LoadUrdfFile(urdf_path).links) {
    if (link.name != "block") continue;
    EXPECT_EQ(link.collision[0].mesh_file, (fs::path(urdf_path).parent_path() / "cube.obj").string());
  }
  relative_urdf.replace(relative_urdf.find("cube.obj"), 8, "package://probe/cube.obj");
  try {
    ParseUrdf(relative_urdf, "probe.urdf");
    ADD_FAILURE() << "accepted a package:// mesh";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("probe.urdf: link 'block': mesh 'package://probe/cube.obj'"),
              std::string::npos)
        << e.what();
  }
}

TEST(Mesh, BadMeshShapesGiveTheFileLineAndKey) {
  WriteFile("cube.obj", kCubeObj);
  const std::string garbage = fs::canonical(WriteFile("garbage.obj", "f 1 2 3\n")).string();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"[{mesh: {file: missing.obj}}]", "collision[0].mesh.file: no file 'missing.obj'"},
      {"[{mesh: {file: garbage.obj}}]", "collision[0].mesh.file: " + garbage + ": "},
      {"[{mesh: {file: cube.obj, scale: [1, 0, 1]}}]", "collision[0].mesh.scale: must be positive"},
      {"[{mesh: {file: cube.obj, convex: false}}]",
       "collision[0].mesh.convex: false (collide with the triangles)"
       " needs a static body"},
      {"[{mesh: {file: cube.obj, colour: red}}]", "collision[0].mesh.colour: unknown key"},
  };
  for (const auto& [collision, expected] : cases) {
    SCOPED_TRACE(collision);
    const std::string path = WriteFile("bad.yaml", ProbeVehicle(collision));
    try {
      LoadVehicle(path);
      ADD_FAILURE() << "accepted";
    } catch (const bridge::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(path + ":"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace iapsim::model
