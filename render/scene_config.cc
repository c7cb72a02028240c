#include "render/scene_config.h"

#include <cmath>
#include <map>

#include "model/vehicle.h"
#include "render/image.h"
#include "render/mesh_loader.h"
#include "render/texture.h"

namespace iapsim::render {
namespace {

using bridge::YamlMap;

// an sRGB colour [r, g, b] in [0, 1]
void OptionalColor(YamlMap& map, const std::string& key, Eigen::Vector3f* color) {
  Eigen::Vector3d value = color->cast<double>();
  model::OptionalVector3(map, key, &value);
  if ((value.array() < 0.0).any() || (value.array() > 1.0).any())
    map.Fail(key, "colour components must be in [0, 1] (sRGB)");
  *color = value.cast<float>();
}

// a list read item by item, each as a YamlMap with its path for messages
template <class F>
void ForEachItem(YamlMap& map, const std::string& key, F read) {
  if (!map.Has(key)) return;
  const YAML::Node list = map.Raw(key);
  if (!list.IsSequence()) map.Fail(key, "expected a list");
  for (std::size_t i = 0; i < list.size(); ++i) {
    YamlMap item(list[i], map.file(), map.PathOf(key) + "[" + std::to_string(i) + "]");
    read(item);
    item.Finish();
  }
}

TextureImage ReadTexture(YamlMap& map) {
  if (map.Has("file")) {
    const std::string path = bridge::ReadFilePath(map, "file", map.file());
    try {
      const Image image = ReadImageFile(path);
      return {image.width, image.height, image.rgb, path};
    } catch (const std::invalid_argument& e) {
      map.Fail("file", e.what());
    }
  }
  ProceduralTexture recipe;
  std::string pattern = "noise";
  map.OptionalChoice("pattern", &pattern, {"checker", "noise", "bricks", "tiles", "facade"});
  recipe.pattern = ParsePattern(pattern);
  OptionalColor(map, "color_a", &recipe.color_a);
  OptionalColor(map, "color_b", &recipe.color_b);
  OptionalColor(map, "color_c", &recipe.color_c);
  map.OptionalInRange("size_px", &recipe.size_px, 16, 4096);
  map.OptionalInRange("cells", &recipe.cells, 1, 256);
  map.Optional("seed", &recipe.seed);
  return MakeProceduralTexture(recipe);
}

// The index of the entry that `key` names in one of the scene's sections (`textures`, `materials`); −1 when
// the key is absent or empty.
int ReadReference(YamlMap& map, const char* key, const std::map<std::string, int>& entries,
                  const char* section) {
  std::string name;
  map.Optional(key, &name);
  if (name.empty()) return -1;
  const auto it = entries.find(name);
  if (it == entries.end()) map.Fail(key, "no " + std::string(key) + " '" + name + "' in `" + section + "`");
  return it->second;
}

Material ReadMaterial(YamlMap& map, const std::map<std::string, int>& textures) {
  Material material;
  OptionalColor(map, "color", &material.color);
  material.texture = ReadReference(map, "texture", textures, "textures");
  map.OptionalInRange("specular", &material.specular, 0.0f, 1.0f);
  map.OptionalInRange("shininess", &material.shininess, 1.0f, 1000.0f);
  map.Optional("unlit", &material.unlit);
  return material;
}

// A shape key (box, plane, sphere, cylinder, cone or mesh) as a mesh added to the scene; returns its index.
int ReadShapeMesh(YamlMap& map, Scene* scene, int material, float repeats_per_m) {
  int kinds = 0;
  int mesh = -1;
  const auto add = [&](Mesh m) {
    ScaleUv(&m, repeats_per_m);
    mesh = scene->AddMesh(std::move(m));
    ++kinds;
  };
  const auto positive = [&](const std::string& key, const Eigen::VectorXd& v) {
    if (!(v.minCoeff() > 0.0)) map.Fail(key, "sizes must be positive");
  };
  if (map.Has("box")) {
    Eigen::Vector3d size = Eigen::Vector3d::Ones();
    model::OptionalVector3(map, "box", &size);
    positive("box", size);
    add(MakeBox(size, material));
  }
  if (map.Has("plane")) {
    const std::vector<double> numbers = bridge::ReadNumberList(map, "plane", {2});  // [size_x_m, size_y_m]
    const Eigen::Vector2d size(numbers[0], numbers[1]);
    positive("plane", size);
    add(MakePlane(size.x(), size.y(), material));
  }
  if (map.Has("sphere")) {
    YamlMap sphere = map.Map("sphere");
    double radius_m = 0.0;
    sphere.Required("radius_m", &radius_m);
    positive("sphere", Eigen::VectorXd::Constant(1, radius_m));
    sphere.Finish();
    add(MakeSphere(radius_m, material));
  }
  for (const std::string key : {"cylinder", "cone"}) {
    if (!map.Has(key)) continue;
    YamlMap solid = map.Map(key);
    double radius_m = 0.0, length_m = 0.0;
    solid.Required("radius_m", &radius_m);
    solid.Required("length_m", &length_m);
    positive(key, Eigen::Vector2d(radius_m, length_m));
    solid.Finish();
    add(key == "cylinder" ? MakeCylinder(radius_m, length_m, material)
                          : MakeCone(radius_m, length_m, material));
  }
  if (map.Has("mesh")) {
    YamlMap file = map.Map("mesh");
    const std::string path = bridge::ReadFilePath(file, "file", map.file());
    file.Finish();
    try {
      mesh = AddMeshFile(scene, path);
    } catch (const std::invalid_argument& e) {
      map.Fail("mesh", e.what());
    }
    ++kinds;
  }
  if (kinds != 1)
    map.Fail("shape", "an object needs exactly one of box, plane, sphere, cylinder, cone, mesh");
  return mesh;
}

void ReadObject(YamlMap& map, Scene* scene, const std::map<std::string, int>& materials) {
  SceneObject object;
  map.Required("name", &object.name);
  object.material = ReadReference(map, "material", materials, "materials");
  // primitives take the object's material (a default grey without one); a mesh keeps its own unless given
  const int primitive_material = object.material >= 0 ? object.material : scene->AddMaterial(Material{});
  double texture_scale_m = 1.0;
  map.OptionalInRange("texture_scale_m", &texture_scale_m, 1e-3, 1e4);
  object.mesh = ReadShapeMesh(map, scene, primitive_material, static_cast<float>(1.0 / texture_scale_m));
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero(), rpy_rad = Eigen::Vector3d::Zero();
  model::OptionalVector3(map, "position_m", &position_m);
  model::OptionalVector3(map, "rpy_deg", &rpy_rad, M_PI / 180.0);
  object.X_BO.translation() = position_m;
  object.X_BO.linear() = model::RotationFromRpy(rpy_rad);
  if (map.Has("scale") && map.Raw("scale").IsScalar()) {
    double uniform = 1.0;
    map.Optional("scale", &uniform);
    object.scale.setConstant(uniform);
  } else {
    model::OptionalVector3(map, "scale", &object.scale);
  }
  if (!(object.scale.minCoeff() > 0.0)) map.Fail("scale", "must be positive (a number or [x, y, z])");
  map.Optional("body", &object.body);
  map.Optional("casts_shadow", &object.casts_shadow);
  scene->AddObject(object);
}

// named entries of a map section, in file order
template <class F>
void ForEachNamed(YamlMap& map, const std::string& key, F read) {
  YamlMap section = map.Map(key);
  for (const std::string& name : section.Keys()) {
    YamlMap entry = section.Map(name);
    read(name, entry);
    entry.Finish();
  }
  section.Finish();
}

}  // namespace

Scene ReadScene(YamlMap& map) {
  Scene scene;
  map.Optional("name", &scene.name);
  OptionalColor(map, "sky_color", &scene.sky_color);
  {
    YamlMap ambient = map.Map("ambient");
    OptionalColor(ambient, "color", &scene.ambient_color);
    ambient.OptionalInRange("intensity", &scene.ambient_intensity, 0.0f, 100.0f);
    ambient.Finish();
  }
  {
    YamlMap sun = map.Map("sun");
    model::OptionalVector3(sun, "direction", &scene.sun.direction_W);
    if (!(scene.sun.direction_W.norm() > 1e-9)) sun.Fail("direction", "must not be zero");
    scene.sun.direction_W.normalize();
    OptionalColor(sun, "color", &scene.sun.color);
    sun.OptionalInRange("intensity", &scene.sun.intensity, 0.0f, 100.0f);
    sun.Optional("shadows", &scene.sun.shadows);
    sun.OptionalInRange("shadow_resolution", &scene.sun.shadow_resolution, 64, 8192);
    sun.OptionalInRange("shadow_radius_m", &scene.sun.shadow_radius_m, 0.1, 1e5);
    model::OptionalVector3(sun, "shadow_center_m", &scene.sun.shadow_center_W_m);
    sun.Finish();
  }
  {
    YamlMap fog = map.Map("fog");
    fog.OptionalInRange("density_per_m", &scene.fog.density_per_m, 0.0f, 10.0f);
    OptionalColor(fog, "color", &scene.fog.color);
    fog.Finish();
  }
  std::map<std::string, int> textures, materials;
  ForEachNamed(map, "textures", [&](const std::string& name, YamlMap& entry) {
    textures[name] = scene.AddTexture(ReadTexture(entry));
  });
  ForEachNamed(map, "materials", [&](const std::string& name, YamlMap& entry) {
    materials[name] = scene.AddMaterial(ReadMaterial(entry, textures));
  });
  ForEachItem(map, "objects", [&](YamlMap& item) { ReadObject(item, &scene, materials); });
  return scene;
}

Scene LoadScene(const std::string& path) {
  YamlMap root(bridge::LoadYamlFile(path), path);
  Scene scene = ReadScene(root);
  root.Finish();
  return scene;
}

}  // namespace iapsim::render
