#include "model/urdf.h"

#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <queue>
#include <set>
#include <sstream>
#include <stdexcept>

namespace iapsim::model {
namespace {

// the shortest text that reads back as exactly the same double
std::string Num(double v) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof(text), v);
  return std::string(text, result.ptr);
}

std::string Vec(const Eigen::Vector3d& v) { return Num(v.x()) + " " + Num(v.y()) + " " + Num(v.z()); }

void AddOrigin(tinyxml2::XMLElement* parent, const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy) {
  auto* origin = parent->InsertNewChildElement("origin");
  origin->SetAttribute("xyz", Vec(xyz).c_str());
  origin->SetAttribute("rpy", Vec(rpy).c_str());
}

// cone_as_cylinder: for tools that know no <cone> (GenerateRosUrdf)
void AddGeometry(tinyxml2::XMLElement* parent, const Shape& shape, bool cone_as_cylinder = false) {
  auto* geometry = parent->InsertNewChildElement("geometry");
  switch (shape.kind) {
    case Shape::Kind::kBox:
      geometry->InsertNewChildElement("box")->SetAttribute("size", Vec(shape.box_size_m).c_str());
      break;
    case Shape::Kind::kCylinder:
    case Shape::Kind::kCone: {
      const bool cone = shape.kind == Shape::Kind::kCone && !cone_as_cylinder;
      auto* solid = geometry->InsertNewChildElement(cone ? "cone" : "cylinder");
      solid->SetAttribute("radius", Num(shape.radius_m).c_str());
      solid->SetAttribute("length", Num(shape.length_m).c_str());
      break;
    }
    case Shape::Kind::kSphere:
      geometry->InsertNewChildElement("sphere")->SetAttribute("radius", Num(shape.radius_m).c_str());
      break;
    case Shape::Kind::kMesh: {
      auto* mesh = geometry->InsertNewChildElement("mesh");
      mesh->SetAttribute("filename", shape.mesh_file.c_str());
      mesh->SetAttribute("scale", Vec(shape.mesh_scale).c_str());
      break;
    }
  }
}

// A link with its mass properties (none: massless), its collision shapes and its mesh as its visual (with
// `material`, when given); cone_as_cylinder for tools that know no <cone> (GenerateRosUrdf).
tinyxml2::XMLElement* AddLink(tinyxml2::XMLElement* robot, const std::string& name,
                              const MassProperties* mass, const std::vector<Shape>& shapes,
                              const std::string& mesh, bool cone_as_cylinder = false,
                              const char* material = nullptr) {
  auto* link = robot->InsertNewChildElement("link");
  link->SetAttribute("name", name.c_str());
  if (mass) {
    auto* inertial = link->InsertNewChildElement("inertial");
    AddOrigin(inertial, mass->com_B_m, Eigen::Vector3d::Zero());
    inertial->InsertNewChildElement("mass")->SetAttribute("value", Num(mass->mass_kg).c_str());
    auto* inertia = inertial->InsertNewChildElement("inertia");
    const Eigen::Matrix3d& I = mass->inertia_B_kgm2;
    inertia->SetAttribute("ixx", Num(I(0, 0)).c_str());
    inertia->SetAttribute("ixy", Num(I(0, 1)).c_str());
    inertia->SetAttribute("ixz", Num(I(0, 2)).c_str());
    inertia->SetAttribute("iyy", Num(I(1, 1)).c_str());
    inertia->SetAttribute("iyz", Num(I(1, 2)).c_str());
    inertia->SetAttribute("izz", Num(I(2, 2)).c_str());
  }
  for (const auto& shape : shapes) {
    auto* collision = link->InsertNewChildElement("collision");
    AddOrigin(collision, shape.origin_B_m, shape.rpy_B_rad);
    AddGeometry(collision, shape, cone_as_cylinder);
  }
  if (!mesh.empty()) {
    auto* visual = link->InsertNewChildElement("visual");
    AddOrigin(visual, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    visual->InsertNewChildElement("geometry")
        ->InsertNewChildElement("mesh")
        ->SetAttribute("filename", mesh.c_str());
    if (material) visual->InsertNewChildElement("material")->SetAttribute("name", material);
  }
  return link;
}

tinyxml2::XMLElement* AddJoint(tinyxml2::XMLElement* robot, const std::string& name, const char* type,
                               const std::string& parent, const std::string& child,
                               const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy) {
  auto* joint = robot->InsertNewChildElement("joint");
  joint->SetAttribute("name", name.c_str());
  joint->SetAttribute("type", type);
  joint->InsertNewChildElement("parent")->SetAttribute("link", parent.c_str());
  joint->InsertNewChildElement("child")->SetAttribute("link", child.c_str());
  AddOrigin(joint, xyz, rpy);
  return joint;
}

[[noreturn]] void Fail(const std::string& source, const std::string& what) {
  throw std::invalid_argument(source + ": " + what);
}

// A joint's friction as URDF's <dynamics damping friction>, where it has any.
void AddDynamics(tinyxml2::XMLElement* joint, const JointResistance& resistance) {
  if (resistance.viscous_Nms_per_rad > 0.0 || resistance.coulomb_Nm > 0.0) {
    auto* dynamics = joint->InsertNewChildElement("dynamics");
    dynamics->SetAttribute("damping", resistance.viscous_Nms_per_rad);
    dynamics->SetAttribute("friction", resistance.coulomb_Nm);
  }
}

void AddResistance(tinyxml2::XMLElement* joint, const JointResistance& resistance) {
  AddDynamics(joint, resistance);
  if (resistance.max_tilt_rad > 0.0)
    joint->InsertNewChildElement("limit")->SetAttribute("upper", resistance.max_tilt_rad);
}

// A spherical joint's <dynamics> and <limit>; removes the limit (urdfdom takes none on a floating joint).
JointResistance ReadResistance(tinyxml2::XMLElement* joint, const std::string& source) {
  JointResistance out;
  const std::string where =
      "line " + std::to_string(joint->GetLineNum()) + ": joint '" + joint->Attribute("name") + "': ";
  if (auto* dynamics = joint->FirstChildElement("dynamics")) {
    if (dynamics->QueryDoubleAttribute("damping", &out.viscous_Nms_per_rad) ==
            tinyxml2::XML_WRONG_ATTRIBUTE_TYPE ||
        dynamics->QueryDoubleAttribute("friction", &out.coulomb_Nm) == tinyxml2::XML_WRONG_ATTRIBUTE_TYPE ||
        !(out.viscous_Nms_per_rad >= 0.0 && out.coulomb_Nm >= 0.0 && std::isfinite(out.viscous_Nms_per_rad) &&
          std::isfinite(out.coulomb_Nm))) {
      Fail(source, where + "<dynamics> expects damping (N·m·s/rad) and friction (N·m), each >= 0");
    }
  }
  if (auto* limit = joint->FirstChildElement("limit")) {
    if (limit->QueryDoubleAttribute("upper", &out.max_tilt_rad) != tinyxml2::XML_SUCCESS ||
        !(out.max_tilt_rad > 0.0 && out.max_tilt_rad < M_PI)) {
      Fail(source, where + "<limit upper> of a spherical joint is its largest tilt, expected in (0, pi) rad");
    }
    joint->DeleteChild(limit);
  }
  return out;
}

Eigen::Vector3d ToEigen(const urdf::Vector3& v) { return Eigen::Vector3d(v.x, v.y, v.z); }

Eigen::Vector3d RpyOf(const urdf::Rotation& rotation) {
  double roll, pitch, yaw;
  rotation.getRPY(roll, pitch, yaw);
  return Eigen::Vector3d(roll, pitch, yaw);
}

// A mesh's file name as a path: file:// URIs are paths; ROS package:// URIs need a package path iapsim does
// not have.
std::string MeshPath(const std::string& filename, const std::string& link, const std::string& source) {
  const std::string file_scheme = "file://";
  if (filename.rfind(file_scheme, 0) == 0) return filename.substr(file_scheme.size());
  if (filename.find("://") != std::string::npos) {
    Fail(source, "link '" + link + "': mesh '" + filename +
                     "': only file paths are supported (relative to the URDF file, or absolute)");
  }
  return filename;
}

// the collision cones the pre-parse renamed to cylinders: (link name, index of the <collision> in the link)
using ConeSet = std::set<std::pair<std::string, size_t>>;

LinkDescription ConvertLink(const urdf::Link& link, const ConeSet& cones, const std::string& source) {
  LinkDescription out;
  out.name = link.name;
  if (!link.inertial || link.inertial->mass <= 0.0) {
    Fail(source, "link '" + link.name + "' needs an <inertial> with a positive mass");
  }
  const auto& in = *link.inertial;
  if (RpyOf(in.origin.rotation).norm() > 1e-12) {
    Fail(source, "link '" + link.name +
                     "': a rotated <inertial> origin is not supported; give the inertia in link axes");
  }
  out.mass.mass_kg = in.mass;
  out.mass.com_B_m = ToEigen(in.origin.position);
  out.mass.inertia_B_kgm2 << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  for (size_t c = 0; c < link.collision_array.size(); ++c) {
    const auto& collision = link.collision_array[c];
    if (!collision || !collision->geometry) continue;
    Shape shape;
    shape.origin_B_m = ToEigen(collision->origin.position);
    shape.rpy_B_rad = RpyOf(collision->origin.rotation);
    switch (collision->geometry->type) {
      case urdf::Geometry::BOX: {
        const auto& box = static_cast<const urdf::Box&>(*collision->geometry);
        shape.kind = Shape::Kind::kBox;
        shape.box_size_m = ToEigen(box.dim);
        break;
      }
      case urdf::Geometry::CYLINDER: {
        const auto& cylinder = static_cast<const urdf::Cylinder&>(*collision->geometry);
        shape.kind = cones.count({link.name, c}) ? Shape::Kind::kCone : Shape::Kind::kCylinder;
        shape.radius_m = cylinder.radius;
        shape.length_m = cylinder.length;
        break;
      }
      case urdf::Geometry::SPHERE:
        shape.kind = Shape::Kind::kSphere;
        shape.radius_m = static_cast<const urdf::Sphere&>(*collision->geometry).radius;
        break;
      case urdf::Geometry::MESH: {  // a vehicle's links move: its meshes collide as convex parts
        const auto& mesh = static_cast<const urdf::Mesh&>(*collision->geometry);
        shape.kind = Shape::Kind::kMesh;
        shape.mesh_file = MeshPath(mesh.filename, link.name, source);
        shape.mesh_scale = ToEigen(mesh.scale);
        break;
      }
    }
    out.collision.push_back(shape);
  }
  if (link.visual && link.visual->geometry && link.visual->geometry->type == urdf::Geometry::MESH) {
    out.mesh = static_cast<const urdf::Mesh&>(*link.visual->geometry).filename;
  }
  return out;
}

// --- GenerateRosUrdf's visuals: drawing sizes, not physics ---
constexpr double kArmRadius_m = 0.008;
constexpr double kPropellerThickness_m = 0.004;
constexpr double kSubAircraftHub_m[3] = {0.12, 0.12, 0.05};

void AddVisualShape(tinyxml2::XMLElement* link, const Shape& shape, const char* material) {
  auto* visual = link->InsertNewChildElement("visual");
  AddOrigin(visual, shape.origin_B_m, shape.rpy_B_rad);
  AddGeometry(visual, shape, /*cone_as_cylinder=*/true);
  visual->InsertNewChildElement("material")->SetAttribute("name", material);
}

// A cylinder of `radius` from `from` to `to` (URDF's cylinder runs along z), for a visual.
void AddRod(tinyxml2::XMLElement* link, const Eigen::Vector3d& from, const Eigen::Vector3d& to, double radius,
            const char* material) {
  const Eigen::Vector3d along = to - from;
  const Eigen::Matrix3d R =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), along).toRotationMatrix();
  const Eigen::Vector3d ypr = R.eulerAngles(2, 1, 0);  // R = Rz(yaw) Ry(pitch) Rx(roll): URDF's rpy
  Shape rod;
  rod.kind = Shape::Kind::kCylinder;
  rod.radius_m = radius;
  rod.length_m = along.norm();
  rod.origin_B_m = 0.5 * (from + to);
  rod.rpy_B_rad = Eigen::Vector3d(ypr.z(), ypr.y(), ypr.x());
  AddVisualShape(link, rod, material);
}

// A link for display: AddLink's, and where it has no mesh, its shapes as its visuals (with a material).
tinyxml2::XMLElement* AddRosLink(tinyxml2::XMLElement* robot, const std::string& name,
                                 const MassProperties* mass, const std::vector<Shape>& shapes,
                                 const std::string& mesh, const char* material) {
  auto* link = AddLink(robot, name, mass, shapes, mesh, /*cone_as_cylinder=*/true, material);
  if (mesh.empty() && material) {
    for (const auto& shape : shapes) AddVisualShape(link, shape, material);
  }
  return link;
}

}  // namespace

std::string GenerateRosUrdf(const Vehicle& vehicle) {
  tinyxml2::XMLDocument doc;
  doc.InsertEndChild(doc.NewDeclaration());
  doc.InsertEndChild(
      doc.NewComment((" generated by `iapsim urdf --ros " + vehicle.source_file +
                      "`: for ROS tools (display), not for simulation; each spherical joint is "
                      "roll, pitch and yaw joints through massless links ")
                         .c_str()));
  auto* robot = doc.NewElement("robot");
  doc.InsertEndChild(robot);
  robot->SetAttribute("name", vehicle.name.c_str());
  for (const auto& [name, rgba] :
       {std::pair{"platform", "0.55 0.57 0.6 1"}, std::pair{"frame", "0.15 0.15 0.17 1"},
        std::pair{"propeller", "0.2 0.5 0.9 0.5"}, std::pair{"tool", "0.85 0.6 0.2 1"}}) {
    auto* material = robot->InsertNewChildElement("material");
    material->SetAttribute("name", name);
    material->InsertNewChildElement("color")->SetAttribute("rgba", rgba);
  }
  AddRosLink(robot, "base_link", nullptr, {}, "", nullptr);
  AddRosLink(robot, "platform", &vehicle.platform, vehicle.platform_collision, vehicle.platform_mesh,
             "platform");
  AddJoint(robot, "base_link_platform", "fixed", "base_link", "platform", Eigen::Vector3d::Zero(),
           Eigen::Vector3d::Zero());
  for (const auto& tool : vehicle.tools) {
    AddRosLink(robot, tool.name, &tool.mass, tool.collision, tool.mesh, "tool");
    AddJoint(robot, tool.name + "_mount", "fixed", "platform", tool.name, tool.origin_P_m, tool.rpy_P_rad);
  }
  for (const auto& sub : vehicle.sub_aircraft) {
    // the span box of a quadrotor would hide it: drawn as a hub, its arms and its propeller discs instead
    auto* link = AddRosLink(robot, sub.name, &sub.mass, sub.collision, sub.mesh, nullptr);
    if (sub.mesh.empty()) {
      Shape hub;
      hub.kind = Shape::Kind::kBox;
      hub.box_size_m = Eigen::Vector3d(kSubAircraftHub_m[0], kSubAircraftHub_m[1], kSubAircraftHub_m[2]);
      AddVisualShape(link, hub, "frame");
      for (const Eigen::Vector3d& hub_S_m : sub.rotors.hub_S_m) {
        AddRod(link, Eigen::Vector3d::Zero(), hub_S_m, kArmRadius_m, "frame");
        if (sub.rotors.radius_m <= 0.0) continue;
        Shape disc;
        disc.kind = Shape::Kind::kCylinder;
        disc.radius_m = sub.rotors.radius_m;
        disc.length_m = kPropellerThickness_m;
        disc.origin_B_m = hub_S_m;
        AddVisualShape(link, disc, "propeller");
      }
    }
    const Eigen::Vector3d yaw(0.0, 0.0, sub.initial_yaw_rad);
    if (sub.joint != JointType::kSpherical) {
      AddJoint(robot, sub.name + "_joint", "fixed", "platform", sub.name, sub.joint_P_m, yaw);
      continue;
    }
    const double tilt = sub.joint_resistance.max_tilt_rad;
    struct Axis {
      const char* name;
      Eigen::Vector3d axis;
      bool limited;
    };
    const Axis axes[3] = {{"roll", Eigen::Vector3d::UnitX(), tilt > 0.0},
                          {"pitch", Eigen::Vector3d::UnitY(), tilt > 0.0},
                          {"yaw", Eigen::Vector3d::UnitZ(), false}};
    std::string parent = "platform";
    for (int a = 0; a < 3; ++a) {
      const std::string child = a == 2 ? sub.name : sub.name + "_" + axes[a].name + "_link";
      if (a < 2) AddRosLink(robot, child, nullptr, {}, "", nullptr);
      auto* joint = AddJoint(
          robot, sub.name + "_" + axes[a].name, axes[a].limited ? "revolute" : "continuous", parent, child,
          a == 0 ? sub.joint_P_m : Eigen::Vector3d::Zero(), a == 0 ? yaw : Eigen::Vector3d::Zero());
      joint->InsertNewChildElement("axis")->SetAttribute("xyz", Vec(axes[a].axis).c_str());
      if (axes[a].limited) {  // a passive joint: no effort, no velocity of its own
        auto* limit = joint->InsertNewChildElement("limit");
        limit->SetAttribute("lower", Num(-tilt).c_str());
        limit->SetAttribute("upper", Num(tilt).c_str());
        limit->SetAttribute("effort", "0");
        limit->SetAttribute("velocity", "0");
      }
      AddDynamics(joint, sub.joint_resistance);
      parent = child;
    }
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

std::string GenerateUrdf(const Vehicle& vehicle) {
  tinyxml2::XMLDocument doc;
  doc.InsertEndChild(doc.NewDeclaration());
  doc.InsertEndChild(doc.NewComment((" generated by `iapsim urdf " + vehicle.source_file +
                                     "`; type=\"spherical\" follows RaiSim's convention ")
                                        .c_str()));
  auto* robot = doc.NewElement("robot");
  doc.InsertEndChild(robot);
  robot->SetAttribute("name", vehicle.name.c_str());
  AddLink(robot, "platform", &vehicle.platform, vehicle.platform_collision, vehicle.platform_mesh);
  for (const auto& tool : vehicle.tools) {
    AddLink(robot, tool.name, &tool.mass, tool.collision, tool.mesh);
    AddJoint(robot, tool.name + "_mount", "fixed", "platform", tool.name, tool.origin_P_m, tool.rpy_P_rad);
  }
  for (const auto& sub : vehicle.sub_aircraft) {
    AddLink(robot, sub.name, &sub.mass, sub.collision, sub.mesh);
    auto* joint =
        AddJoint(robot, sub.name + "_joint", sub.joint == JointType::kSpherical ? "spherical" : "fixed",
                 "platform", sub.name, sub.joint_P_m, Eigen::Vector3d(0.0, 0.0, sub.initial_yaw_rad));
    if (sub.joint == JointType::kSpherical) AddResistance(joint, sub.joint_resistance);
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

MultibodyDescription ParseUrdf(const std::string& xml, const std::string& source) {
  // pre-parse: spherical -> floating, remembering which joints were spherical
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) {
    Fail(source, std::string("not well-formed XML: ") + doc.ErrorStr());
  }
  auto* robot = doc.FirstChildElement("robot");
  if (!robot) Fail(source, "no <robot> element");
  std::map<std::string, JointResistance> spherical;
  for (auto* joint = robot->FirstChildElement("joint"); joint; joint = joint->NextSiblingElement("joint")) {
    const char* name = joint->Attribute("name");
    const char* type = joint->Attribute("type");
    if (!name || !type)
      Fail(source, "line " + std::to_string(joint->GetLineNum()) + ": <joint> needs name and type");
    if (std::string(type) == "spherical") {
      spherical[name] = ReadResistance(joint, source);
      joint->SetAttribute("type", "floating");
    } else if (std::string(type) == "floating") {
      Fail(source, "line " + std::to_string(joint->GetLineNum()) + ": joint '" + name +
                       "' is floating; a vehicle has one free base and spherical or fixed joints");
    }
  }
  // pre-parse: <cone> -> <cylinder> of the same radius and length, remembering the collision cones
  ConeSet cones;
  for (auto* link = robot->FirstChildElement("link"); link; link = link->NextSiblingElement("link")) {
    const char* name = link->Attribute("name");
    for (const char* kind : {"collision", "visual"}) {
      size_t index = 0;
      for (auto* element = link->FirstChildElement(kind); element;
           element = element->NextSiblingElement(kind)) {
        auto* geometry = element->FirstChildElement("geometry");
        auto* cone = geometry ? geometry->FirstChildElement("cone") : nullptr;
        if (cone) {
          cone->SetName("cylinder");
          if (name && std::string(kind) == "collision") cones.insert({name, index});
        }
        ++index;
      }
    }
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(printer.CStr());
  if (!model) Fail(source, "urdfdom rejected the URDF (its reason is printed above)");

  MultibodyDescription out;
  out.name = model->getName();
  const urdf::LinkConstSharedPtr root = model->getRoot();
  out.links.push_back(ConvertLink(*root, cones, source));
  // breadth-first: a joint's parent is always converted before its child
  std::queue<std::pair<urdf::LinkConstSharedPtr, int>> pending;
  pending.push({root, 0});
  while (!pending.empty()) {
    const auto [link, index] = pending.front();
    pending.pop();
    for (const auto& joint : link->child_joints) {
      JointDescription j;
      j.name = joint->name;
      if (joint->type == urdf::Joint::FLOATING && spherical.count(joint->name)) {
        j.type = JointType::kSpherical;
        j.resistance = spherical.at(joint->name);
      } else if (joint->type == urdf::Joint::FIXED) {
        j.type = JointType::kFixed;
      } else {
        Fail(source, "joint '" + joint->name + "': iapsim simulates spherical and fixed joints only");
      }
      j.parent = index;
      j.child = static_cast<int>(out.links.size());
      j.origin_parent_m = ToEigen(joint->parent_to_joint_origin_transform.position);
      j.rpy_parent_rad = RpyOf(joint->parent_to_joint_origin_transform.rotation);
      const urdf::LinkConstSharedPtr child = model->getLink(joint->child_link_name);
      out.links.push_back(ConvertLink(*child, cones, source));
      out.joints.push_back(j);
      pending.push({child, j.child});
    }
  }
  return out;
}

MultibodyDescription LoadUrdfFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open the file");
  std::stringstream text;
  text << in.rdbuf();
  MultibodyDescription description = ParseUrdf(text.str(), path);
  // mesh files are relative to the URDF file
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  for (auto& link : description.links) {
    for (auto& shape : link.collision) {
      if (shape.kind == Shape::Kind::kMesh && std::filesystem::path(shape.mesh_file).is_relative()) {
        shape.mesh_file = (folder / shape.mesh_file).string();
      }
    }
  }
  return description;
}

MultibodyDescription SolidCylinder(const std::string& name, double mass_kg, double radius_m,
                                   double length_m) {
  LinkDescription link;
  link.name = name;
  link.mass.mass_kg = mass_kg;
  const double across_kgm2 = mass_kg * (3.0 * radius_m * radius_m + length_m * length_m) / 12.0;
  link.mass.inertia_B_kgm2 =
      Eigen::Vector3d(across_kgm2, across_kgm2, 0.5 * mass_kg * radius_m * radius_m).asDiagonal();
  Shape cylinder;
  cylinder.kind = Shape::Kind::kCylinder;
  cylinder.radius_m = radius_m;
  cylinder.length_m = length_m;
  link.collision = {cylinder};
  MultibodyDescription body;
  body.name = name;
  body.links = {link};
  return body;
}

}  // namespace iapsim::model
