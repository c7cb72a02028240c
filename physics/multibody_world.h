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
// no accumulator). Contacts and latches are solved by Bullet's sequential impulses (projected Gauss-Seidel):
// warm started from the last step's impulses and iterated until no constraint row changes a velocity by more
// than `solver_tolerance_mps`, at most `solver_iterations` times (SolverStats says how often that cap was
// hit).
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
  /// The most sequential-impulse iterations in a step.
  int solver_iterations = 50;
  /// The solve of a step ends once an iteration changed no constraint row's velocity by more than this
  /// (m/s, or rad/s for angular rows); 0 runs every step's `solver_iterations`. Contact forces are then
  /// resolved to about mass x tolerance / step: 0.6 mN for a 6 kg IAP at 1 ms.
  double solver_tolerance_mps = 1e-7;
  /// Each step's contact and latch impulses start from the last step's (Bullet's articulated warm
  /// starting), so a resting or sliding contact converges in a few iterations instead of from zero.
  bool warm_start = true;
  /// Contact points further apart than this speed times the step cannot touch within the step unless they
  /// approach faster, and are not solved (Bullet's contact processing threshold); faster approaches
  /// penetrate for a step and are pushed apart by the error reduction. Bullet's default solves every point
  /// of a manifold, up to its 2 cm breaking threshold.
  double speculative_contact_speed_mps = 5.0;
  /// The distance within which a pair's contact points are searched for and kept (Bullet's contact breaking
  /// threshold) at most; 0 keeps Bullet's, 2 % of the smaller shape's motion radius (3.5 mm for the
  /// funnel's pieces, 10 mm for a 1 m pole). A conformal contact (a pole in a hole) has every piece of the
  /// wall within it in GJK and in the solve each step; at 1 ms steps a millimetre is what 1 m/s covers.
  double contact_breaking_distance_m = 0.0;
  /// Contact rows of multibodies from one factorisation of each multibody's mass matrix per step
  /// (physics/internal/contact_solver.h); false builds every row with Bullet's own setup (the same rows,
  /// several times the cost), for comparison.
  bool factored_contact_rows = true;
  /// A vehicle sleeps once no point of it has moved faster than `sleep_speed_mps` for `sleep_after_s` while
  /// the loads on it stayed the same (within 1 µN and 1 µN·m): it is neither integrated nor solved, keeps its
  /// pose and its contact forces, and wakes when a load on it changes, a latch on it closes or opens, or a
  /// moving body touches it. Exact for a body at rest under constant loads; 0 s: never.
  double sleep_after_s = 0.5;
  double sleep_speed_mps = 1e-4;
};

/// How the contact and latch solver did since the world was made.
struct SolverStats {
  uint64_t solves = 0;          // island solves (one per step and group of touching bodies)
  uint64_t iterations = 0;      // summed over the solves
  int max_iterations = 0;       // the most one solve took
  uint64_t capped_solves = 0;   // solves that ran solver_iterations without reaching the tolerance
  double max_residual_mps = 0;  // the largest velocity change left by the last iteration of a capped solve
  uint64_t contact_points = 0;  // points the solves were given (touching or within the speculative distance)
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
  Eigen::Vector3d point_W_m = Eigen::Vector3d::Zero();       // on body a
  Eigen::Vector3d normal_W = Eigen::Vector3d::Zero();        // unit, from b toward a
  Eigen::Vector3d force_on_a_W_N = Eigen::Vector3d::Zero();  // normal + friction; b gets the opposite
  double depth_m = 0.0;                                      // negative when penetrating
};

class MultibodyWorld {
 public:
  MultibodyWorld(const WorldConfig& config, double step_s);
  ~MultibodyWorld();
  MultibodyWorld(const MultibodyWorld&) = delete;
  MultibodyWorld& operator=(const MultibodyWorld&) = delete;

  /// Adds a free-floating multibody whose root link frame starts at (p_WR, q_WR), every joint at its zero
  /// position and at rest, the whole moving as one rigid body with the root frame's velocity v_WR and
  /// angular velocity w_WR (in W; zero: at rest). Body names are "<name>/<link>". Returns the root's body id;
  /// link i of the description is body root + i. Throws std::invalid_argument for a description Bullet cannot
  /// take.
  int AddMultibody(const std::string& name, const model::MultibodyDescription& description,
                   const Eigen::Vector3d& p_WR_m, const Eigen::Quaterniond& q_WR,
                   const Material& material = Material{}, const CollisionFilter& filter = CollisionFilter{},
                   const Eigen::Vector3d& v_WR_W_mps = Eigen::Vector3d::Zero(),
                   const Eigen::Vector3d& w_WR_W_radps = Eigen::Vector3d::Zero());

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
  const SolverStats& solver_stats() const;
  /// How far along the ray from `from_W` in the unit direction `direction_W` the first static surface (the
  /// ground plane or a static object) lies, or `max_m` when none is nearer. For the air's ground effect.
  double StaticSurfaceDistance_m(const Eigen::Vector3d& from_W, const Eigen::Vector3d& direction_W,
                                 double max_m) const;
  /// Whether `body` can move: a vehicle's link or an object with mass.
  bool movable(int body) const;
  /// The radius of a sphere about the body's CoM that holds its collision shapes (0 without any).
  double bounding_radius_m(int body) const;
  /// Where the segment from `from_W` to `to_W` first meets the collision shapes of `body`, as a fraction
  /// of the way along it, or 1 when it misses them. For the air's downwash.
  double BodyRayFraction(int body, const Eigen::Vector3d& from_W, const Eigen::Vector3d& to_W) const;
  /// Whether the multibody that `body` belongs to sleeps (see WorldConfig::sleep_after_s).
  bool asleep(int body) const;
  /// The sum of the last step's contact forces on `body` (from everything it touches), in W.
  Eigen::Vector3d ContactForce_W(int body) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iapsim::physics
