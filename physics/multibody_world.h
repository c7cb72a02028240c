#pragma once
// The physics world: Bullet's featherstone multibodies (btMultiBody, double precision) built from model
// descriptions, static and movable objects, a ground plane, contacts. Bullet stays behind this header.
//
// Frames: W is NED (gravity along +z). A body's frame B is its URDF link frame; Bullet's own frame per body
// (the CoM, principal axes) never leaks out. Every body has an id: multibody links in the order they were
// added (root first), then objects; the ground is kGround.
//
// Meshes (model::Shape::Kind::kMesh) collide as one convex hull per part of the file (exact to the mesh's
// surface, edges rounded to 1 mm), or, on a static object only, with their triangles (a Bullet BVH triangle
// mesh); a moving body's non-convex mesh is an error: split it into convex parts.
//
// Fidelity settings (see NOTES): no damping, no velocity clamps, one Bullet step per Step() (no substeps,
// no accumulator), `solver_iterations` sequential-impulse iterations for contacts and latches.
//
// Latches join two bodies rigidly at run time (docking, seed §IV-E): a Bullet fixed constraint holding the
// relative pose the bodies had when it closed. While it is closed, contacts between the two bodies are
// dropped, since their shapes touch or overlap where they dock and contact impulses would fight it.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "model/urdf.h"
#include "model/vehicle.h"

namespace iapsim::physics {

constexpr int kGround = -1;

/// Contact material of one body. For a pair of bodies Bullet multiplies their frictions and restitutions,
/// so the ground defaults to friction 1 and a pair's friction is the other body's value.
struct Material {
  double friction = 0.5;
  double restitution = 0.0;
  // 0: rigid contact (Bullet's default error reduction); > 0: a spring-damper contact with these values
  double contact_stiffness_N_per_m = 0.0;
  double contact_damping_Ns_per_m = 0.0;
};

/// Bits of a body's collision group and of the groups it collides with: two bodies collide when each one's
/// mask has a bit of the other's group.
struct CollisionFilter {
  int group = 1;
  int mask = -1;
};

struct WorldObject {
  std::string name;
  std::vector<model::Shape> shapes;  // in the object frame O; a non-convex mesh only when static
  double mass_kg = 0.0;              // 0: static
  Eigen::Vector3d inertia_kgm2 = Eigen::Vector3d::Zero();  // principal, about O (the CoM); 0: from shapes
  Eigen::Vector3d p_WO_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_WO = Eigen::Quaterniond::Identity();
  Material material;
  CollisionFilter filter;
};

struct WorldConfig {
  double gravity_mps2 = 9.81;  // along +z of W (NED)
  bool ground = true;
  double ground_z_m = 0.0;  // the plane z = ground_z_m, solid below (z > ground_z_m)
  Material ground_material{1.0, 0.0, 0.0, 0.0};
  std::vector<WorldObject> objects;
  int solver_iterations = 50;
};

/// Kinematics of one body's frame B at the end of the last step. Velocities and accelerations are those of
/// B's origin; accelerations are the change of velocity over the last step divided by the step.
struct BodyState {
  Eigen::Vector3d p_WB_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_WB_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_WB_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_WB_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d alpha_WB_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_WBcom_m = Eigen::Vector3d::Zero();  // the body's centre of mass
  Eigen::Vector3d v_WBcom_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_WBcom_W = Eigen::Vector3d::Zero();
};

/// One contact point of the last step.
struct Contact {
  int body_a = kGround;
  int body_b = kGround;
  Eigen::Vector3d point_W_m = Eigen::Vector3d::Zero();  // on body a
  Eigen::Vector3d normal_W = Eigen::Vector3d::Zero();   // unit, from b toward a
  Eigen::Vector3d force_on_a_W_N = Eigen::Vector3d::Zero();  // normal + friction; b gets the opposite
  double depth_m = 0.0;                                  // negative when penetrating
};

class MultibodyWorld {
 public:
  MultibodyWorld(const WorldConfig& config, double step_s);
  ~MultibodyWorld();
  MultibodyWorld(const MultibodyWorld&) = delete;
  MultibodyWorld& operator=(const MultibodyWorld&) = delete;

  /// Adds a free-floating multibody whose root link frame starts at (p_WR, q_WR), every joint at its zero
  /// position and everything at rest. Body names are "<name>/<link>". Returns the root's body id; link i of
  /// the description is body root + i. Throws std::invalid_argument for a description Bullet cannot take.
  int AddMultibody(const std::string& name, const model::MultibodyDescription& description,
                   const Eigen::Vector3d& p_WR_m, const Eigen::Quaterniond& q_WR,
                   const Material& material = Material{}, const CollisionFilter& filter = CollisionFilter{});

  int body_count() const;
  const std::string& body_name(int body) const;
  /// The body called `name`, or -2 when there is none.
  int FindBody(const std::string& name) const;
  double mass_kg(int body) const;
  /// The body's inertia about its CoM, in B.
  Eigen::Matrix3d inertia_B_kgm2(int body) const;

  /// Loads for the next step only (cleared after it). Forces act at the body's CoM.
  void AddForce_W(int body, const Eigen::Vector3d& force_W_N);
  void AddTorque_W(int body, const Eigen::Vector3d& torque_W_Nm);
  /// A torque through the joint of a multibody link: on the link, and its reaction on the joint's parent.
  void AddJointTorque_W(int body, const Eigen::Vector3d& torque_W_Nm);

  /// Declares an open latch between two bodies and returns its id. Both need collision shapes (Bullet
  /// solves a multibody constraint only between bodies with colliders) and at least one must be a multibody
  /// link. Throws std::invalid_argument.
  int AddLatch(int body_a, int body_b);
  /// Closes the latch: from now on it holds the bodies' current relative pose, and contacts between the
  /// two are ignored. Nothing happens when it is closed already.
  void CloseLatch(int latch);
  /// Opens the latch: the bodies move and collide freely again. Nothing happens when it is open.
  void OpenLatch(int latch);
  bool latched(int latch) const;

  /// Advances one step. No allocation once contacts have reached their largest count.
  void Step();

  double step_s() const;
  int64_t step_count() const;
  const BodyState& body(int body) const;
  const std::vector<Contact>& contacts() const;
  /// The sum of the last step's contact forces on `body` (from everything it touches), in W.
  Eigen::Vector3d ContactForce_W(int body) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iapsim::physics
