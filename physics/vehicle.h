#pragma once
// Vehicle description: a central platform P carrying n sub-aircraft S1..Sn on spherical (or fixed) joints,
// seed paper §III. Loaded from configs/vehicles/*.yaml; frames are FRD bodies in a NED world.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace iapsim::physics {

/// A collision (and default visual) shape, placed in its body's frame.
struct Shape {
  enum class Kind { kBox, kCylinder, kSphere };
  Kind kind = Kind::kBox;
  Eigen::Vector3d box_size_m = Eigen::Vector3d::Zero();  // kBox: full extents along x, y, z
  double radius_m = 0.0;                                 // kCylinder, kSphere
  double length_m = 0.0;                                 // kCylinder: along the cylinder's own z axis
  Eigen::Vector3d origin_B_m = Eigen::Vector3d::Zero();  // shape centre in the body frame
  Eigen::Vector3d rpy_B_rad = Eigen::Vector3d::Zero();   // shape orientation (roll, pitch, yaw)
};

/// Rigid-body mass properties. Inertia is about the centre of mass, in body axes.
struct MassProperties {
  double mass_kg = 0.0;
  Eigen::Vector3d com_B_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia_B_kgm2 = Eigen::Matrix3d::Zero();
};

/// A body fixed to the platform (a pole, a docking part): part of the platform's rigid body.
struct Tool {
  std::string name;
  MassProperties mass;                                   // in the tool's own frame
  Eigen::Vector3d origin_P_m = Eigen::Vector3d::Zero();  // tool frame in P
  Eigen::Vector3d rpy_P_rad = Eigen::Vector3d::Zero();
  std::vector<Shape> collision;
  std::string mesh;
};

enum class JointType { kSpherical, kFixed };

struct SubAircraft {
  std::string name;
  MassProperties mass;  // CoM at the joint (seed §III-A) unless com_B_m says
  JointType joint = JointType::kSpherical;
  Eigen::Vector3d joint_P_m = Eigen::Vector3d::Zero();  // d_i: joint (= CoM) position in P
  double initial_yaw_rad = 0.0;                         // initial yaw of S_i relative to P
  std::vector<Shape> collision;
  std::string mesh;
};

struct Vehicle {
  std::string name;
  std::string source_file;
  MassProperties platform;  // com_B_m is d_c
  std::vector<Shape> platform_collision;
  std::string platform_mesh;
  std::vector<Tool> tools;
  std::vector<SubAircraft> sub_aircraft;

  /// m: total mass of platform, tools and sub-aircraft.
  double TotalMass_kg() const;
};

/// Loads and validates a vehicle YAML file. Throws bridge::ConfigError (file:line: key: what).
Vehicle LoadVehicle(const std::string& path);

}  // namespace iapsim::physics
