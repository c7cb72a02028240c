#include "render/vehicle_visual.h"

#include <cmath>
#include <filesystem>

#include "render/mesh_loader.h"

namespace iapsim::render {
namespace {

Eigen::Isometry3d Pose(const Eigen::Vector3d& p_m, const Eigen::Matrix3d& R) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R;
  X.translation() = p_m;
  return X;
}

// a cylinder (or box) from a to b, in the body frame
Eigen::Isometry3d Segment(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d axis = (b - a).normalized();
  const Eigen::Matrix3d R =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis).toRotationMatrix();
  return Pose(0.5 * (a + b), R);
}

void AddPart(Scene* scene, const std::string& name, const std::string& body, Mesh mesh,
             const Eigen::Isometry3d& X_BO) {
  SceneObject object;
  object.name = name;
  object.body = body;
  object.mesh = scene->AddMesh(std::move(mesh));
  object.X_BO = X_BO;
  scene->AddObject(object);
}

// the vehicle's own shapes (collision shapes double as the default look)
void AddShapes(Scene* scene, const std::string& name, const std::string& body,
               const std::vector<model::Shape>& shapes, const Eigen::Isometry3d& X_BT, int material) {
  for (std::size_t i = 0; i < shapes.size(); ++i) {
    const model::Shape& shape = shapes[i];
    const Eigen::Isometry3d X_BO = X_BT * Pose(shape.origin_B_m, model::RotationFromRpy(shape.rpy_B_rad));
    const std::string part = name + "/shape" + std::to_string(i);
    switch (shape.kind) {
      case model::Shape::Kind::kBox:
        AddPart(scene, part, body, MakeBox(shape.box_size_m, material), X_BO);
        break;
      case model::Shape::Kind::kCylinder:
        AddPart(scene, part, body, MakeCylinder(shape.radius_m, shape.length_m, material), X_BO);
        break;
      case model::Shape::Kind::kSphere:
        AddPart(scene, part, body, MakeSphere(shape.radius_m, material), X_BO);
        break;
      case model::Shape::Kind::kCone:
        AddPart(scene, part, body, MakeCone(shape.radius_m, shape.length_m, material), X_BO);
        break;
      case model::Shape::Kind::kMesh: {
        SceneObject object;
        object.name = part;
        object.body = body;
        object.mesh = AddMeshFile(scene, shape.mesh_file);
        object.X_BO = X_BO;
        object.scale = shape.mesh_scale;
        object.material = material;
        scene->AddObject(object);
        break;
      }
    }
  }
}

// a vehicle file's mesh names are relative to the vehicle file, else to the working folder
std::string MeshPath(const model::Vehicle& vehicle, const std::string& file) {
  const std::filesystem::path path(file);
  if (path.is_absolute() || vehicle.source_file.empty()) return file;
  const std::filesystem::path near = std::filesystem::path(vehicle.source_file).parent_path() / path;
  std::error_code error;
  return std::filesystem::exists(near, error) ? near.string() : file;
}

void AddMeshObject(Scene* scene, const std::string& name, const std::string& body, const std::string& file,
                   const Eigen::Isometry3d& X_BO) {
  SceneObject object;
  object.name = name;
  object.body = body;
  object.mesh = AddMeshFile(scene, file);  // the file's own materials
  object.X_BO = X_BO;
  scene->AddObject(object);
}

// An F450-like quadrotor from its rotor set: a central frame, an arm to each hub, a motor and a propeller
// disc (10": 0.127 m radius, or 45% of the hub distance when arms are short) at each hub, in S (FRD).
void AddQuadrotor(Scene* scene, const std::string& name, const std::string& body,
                  const model::RotorSet& rotors, int frame, int arm, int propeller) {
  AddPart(scene, name + "/frame", body, MakeBox(Eigen::Vector3d(0.16, 0.16, 0.05), frame),
          Eigen::Isometry3d::Identity());
  for (std::size_t r = 0; r < rotors.hub_S_m.size(); ++r) {
    const Eigen::Vector3d hub = rotors.hub_S_m[r];
    const std::string rotor = name + "/rotor" + std::to_string(r + 1);
    const Eigen::Vector3d root(hub.x(), hub.y(), 0.0);
    AddPart(scene, rotor + "/arm", body, MakeCylinder(0.012, root.norm(), arm, 12),
            Segment(Eigen::Vector3d::Zero(), root));
    AddPart(scene, rotor + "/motor", body, MakeCylinder(0.018, 0.03, arm, 16),
            Pose(hub + Eigen::Vector3d(0.0, 0.0, -0.02), Eigen::Matrix3d::Identity()));
    const double radius_m = std::min(0.127, 0.45 * root.norm());
    AddPart(scene, rotor + "/propeller", body, MakeCylinder(radius_m, 0.004, propeller, 32),
            Pose(hub + Eigen::Vector3d(0.0, 0.0, -0.04), Eigen::Matrix3d::Identity()));
  }
}

}  // namespace

std::string PlatformBody(const std::string& vehicle) { return vehicle + "/platform"; }

std::string SubAircraftBody(const std::string& vehicle, const model::SubAircraft& sub) {
  return vehicle + "/" + sub.name;
}

void AddVehicle(Scene* scene, const model::Vehicle& description, const std::string& vehicle) {
  Material dark;
  dark.color = Eigen::Vector3f(0.18f, 0.18f, 0.2f);
  dark.specular = 0.3f;
  Material metal;
  metal.color = Eigen::Vector3f(0.7f, 0.7f, 0.72f);
  metal.specular = 0.5f;
  metal.shininess = 64.0f;
  Material propeller;
  propeller.color = Eigen::Vector3f(0.08f, 0.08f, 0.08f);
  const int platform_material = scene->AddMaterial(dark);
  const int metal_material = scene->AddMaterial(metal);
  const int propeller_material = scene->AddMaterial(propeller);
  // one frame colour per sub-aircraft, so each is told apart in an image (F450 arms come in colours)
  const Eigen::Vector3f frame_colors[] = {{0.85f, 0.15f, 0.1f}, {0.95f, 0.95f, 0.95f}, {0.15f, 0.35f, 0.85f},
                                          {0.95f, 0.75f, 0.1f}, {0.2f, 0.7f, 0.3f},    {0.6f, 0.3f, 0.7f}};

  const std::string platform = PlatformBody(vehicle);
  if (!description.platform_mesh.empty()) {
    AddMeshObject(scene, platform + "/mesh", platform, MeshPath(description, description.platform_mesh),
                  Eigen::Isometry3d::Identity());
  } else {
    AddShapes(scene, platform, platform, description.platform_collision, Eigen::Isometry3d::Identity(),
              platform_material);
    // the arms from the hub to each joint (seed Table I: d_h) and a ball where each joint is
    for (const model::SubAircraft& sub : description.sub_aircraft) {
      const Eigen::Vector3d joint = sub.joint_P_m;
      AddPart(scene, platform + "/arm_" + sub.name, platform,
              MakeCylinder(0.012, joint.norm(), metal_material, 12), Segment(Eigen::Vector3d::Zero(), joint));
      AddPart(scene, platform + "/joint_" + sub.name, platform, MakeSphere(0.025, metal_material, 16),
              Pose(joint, Eigen::Matrix3d::Identity()));
    }
  }
  for (const model::Tool& tool : description.tools) {
    const Eigen::Isometry3d X_PT = Pose(tool.origin_P_m, model::RotationFromRpy(tool.rpy_P_rad));
    if (!tool.mesh.empty()) {
      AddMeshObject(scene, platform + "/" + tool.name, platform, MeshPath(description, tool.mesh), X_PT);
    } else {
      AddShapes(scene, platform + "/" + tool.name, platform, tool.collision, X_PT, metal_material);
    }
  }
  for (std::size_t i = 0; i < description.sub_aircraft.size(); ++i) {
    const model::SubAircraft& sub = description.sub_aircraft[i];
    const std::string body = SubAircraftBody(vehicle, sub);
    if (!sub.mesh.empty()) {
      AddMeshObject(scene, body + "/mesh", body, MeshPath(description, sub.mesh),
                    Eigen::Isometry3d::Identity());
      continue;
    }
    Material frame;
    frame.color = frame_colors[i % std::size(frame_colors)];
    frame.specular = 0.3f;
    AddQuadrotor(scene, body, body, sub.rotors, scene->AddMaterial(frame), platform_material,
                 propeller_material);
  }
}

}  // namespace iapsim::render
