#pragma once
// URDF for IAPs: written from a Vehicle (`iapsim urdf`), and read back into a plain multibody description
// that the physics builds from.
//
// URDF has no spherical joint and urdfdom rejects unknown joint types. iapsim accepts type="spherical"
// (RaiSim's convention, which the seed paper's engine used) through one pre-parse step: the XML is read with
// tinyxml2, every spherical joint is rewritten to "floating" and remembered, then urdfdom parses the result.
// Floating joints of the original file remain an error: a vehicle has one floating base. A spherical joint's
// friction is URDF's own <dynamics damping="N·m·s/rad" friction="N·m"/>, and its cone limit is
// <limit upper="rad"/>, the largest tilt of the child's z axis (as MuJoCo's ball-joint range, of the tilt
// only); the pre-parse step reads both and removes the limit, which urdfdom does not take on a floating
// joint.
//
// URDF has no cone either (docking parts need one, seed §IV-E). iapsim writes <cone radius="R" length="L"/>,
// named after SDFormat's cone, with Shape's convention (along z, centred on half its length, apex toward +z);
// the same pre-parse step renames it to <cylinder> for urdfdom and restores the cone in the description.
//
// Collision meshes are URDF's own <mesh filename scale/>. A vehicle's links move, so their meshes collide as
// convex hulls, one per part of the file (a vehicle YAML refuses `convex: false`). A relative filename is
// relative to the URDF file (LoadUrdfFile); `iapsim urdf` writes absolute paths.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "model/vehicle.h"

namespace iapsim::model {

/// The vehicle as iapsim's URDF (type="spherical", <cone>: what LoadUrdfFile reads back).
std::string GenerateUrdf(const Vehicle& vehicle);

/// The vehicle as URDF that standard ROS tools take (check_urdf, robot_state_publisher, rviz; `iapsim urdf
/// --ros`), for display, not for simulation: a massless root `base_link` fixed to the platform (KDL takes no
/// inertia at the root); each spherical joint as three joints through two massless links, roll about x, pitch
/// about y, yaw about z of the joint frame (`SUB_roll`, `SUB_pitch`, `SUB_yaw`; R = Rx Ry Rz spans every
/// attitude), each with the joint's damping and friction, roll and pitch limited to the cone's half angle
/// where there is one (a square around the cone, the nearest URDF has), the others continuous; cones as
/// cylinders of their size; and visuals for every link: its mesh, or its shapes, and for a sub-aircraft its
/// arms and propeller discs from its rotor set.
std::string GenerateRosUrdf(const Vehicle& vehicle);

struct LinkDescription {
  std::string name;
  MassProperties mass;  // in the link frame
  std::vector<Shape> collision;
  std::string mesh;
};

struct JointDescription {
  std::string name;
  JointType type = JointType::kSpherical;
  int parent = 0;                                             // index into links
  int child = 0;                                              // index into links
  Eigen::Vector3d origin_parent_m = Eigen::Vector3d::Zero();  // child frame origin in the parent frame
  Eigen::Vector3d rpy_parent_rad = Eigen::Vector3d::Zero();   // child frame orientation in the parent frame
  // spherical: <dynamics damping friction> and <limit upper> (the cone's half angle, rad)
  JointResistance resistance;
};

struct MultibodyDescription {
  std::string name;
  std::vector<LinkDescription> links;    // links[0] is the root (the platform, a free body)
  std::vector<JointDescription> joints;  // in tree order: a joint's parent comes before its child
};

/// A free body of one link: a uniform solid cylinder along the link's z axis, its frame at the centre,
/// colliding as itself (a tool alone, as the peg-in-hole's pole).
MultibodyDescription SolidCylinder(const std::string& name, double mass_kg, double radius_m, double length_m);

/// Parses URDF text; `source` (a file name) is used in error messages. Throws std::invalid_argument.
MultibodyDescription ParseUrdf(const std::string& xml, const std::string& source);

/// Reads and parses a URDF file; relative mesh file names become relative to its folder. Throws
/// std::invalid_argument naming the file.
MultibodyDescription LoadUrdfFile(const std::string& path);

}  // namespace iapsim::model
