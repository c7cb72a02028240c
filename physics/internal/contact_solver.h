#pragma once
// Bullet's multibody constraint solver (sequential impulses, projected Gauss-Seidel) with two changes that
// make contact as cheap as Bullet's iterations allow. Internal to physics/: it exposes Bullet types.
//
// 1. Warm starting: every contact row (normal and both friction directions) and every latch row starts
//    from the impulse it ended the last step with, applied to the bodies before the iterations, as Catto's
//    sequential impulses do (GDC 2006, "Fast and Simple Physics using Sequential Impulses"), so a resting or
//    steadily sliding contact starts at its solution. Bullet's own SOLVER_USE_ARTICULATED_WARMSTARTING
//    (3.24) is not used: it starts friction from zero (a pole leaning in the funnel's hole took 34 iterations
//    a step on average with it, 6 with this, 48 cold) and applies a latch row's warm impulse to a multibody
//    but not to a rigid body on its other side, which spun a latched rod-and-crate pair up from 0.7 to
//    12 rad/s (measured).
//
// 2. Contact rows of multibodies built from one factorisation of each multibody's mass matrix per step.
//    Bullet builds each row (a contact point's normal and two friction directions: 36 rows for an IAP
//    standing on its three boxes) with its own articulated-body pass for M⁻¹Jᵀ and its own Jacobian walk:
//    68 % of the resting IAP's step (callgrind). MultibodyMass instead assembles M = Σ_k J_kᵀ M_k J_k from
//    the links' spatial Jacobians, inverts it once (block elimination along the tree, which fills nothing
//    in), and gives each row its Jacobian in closed form and M⁻¹Jᵀ from the columns of M⁻¹ it touches. The
//    rows are Bullet's (btMultiBodySolverConstraint, solved by Bullet's iterations) with Bullet's right-hand
//    sides (error reduction, speculative distance, restitution, stiffness/damping); contact_solver_test
//    checks the Jacobians and responses against Bullet's fillContactJacobianMultiDof and
//    calcAccelerationDeltasMultiDof, and a stepped scene against Bullet's own rows. Multibodies with joints
//    other than spherical and fixed, movable rigid bodies and rolling or spinning friction keep Bullet's
//    rows.

#include <BulletCollision/NarrowPhaseCollision/btManifoldPoint.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <vector>

namespace iapsim::physics::internal {

/// The mass matrix of a btMultiBody whose joints are spherical or fixed, in Bullet's generalised velocities
/// (base angular and linear velocity of its CoM in W, then each spherical joint's rate in its child's frame),
/// at the configuration of the current step (Bullet's cached link transforms).
class MultibodyMass {
 public:
  /// Whether every joint of `multibody` is spherical or fixed.
  static bool Supports(const btMultiBody& multibody);

  /// Frames, mass matrix and its inverse for `multibody` now. No allocation after the first call.
  void Update(const btMultiBody& multibody);

  int dofs() const { return dofs_; }
  /// False when the last Update found M not positive definite (then the rows are left to Bullet).
  bool valid() const { return valid_; }
  /// The Jacobian of the velocity of the point p_W of `link` (-1: the base) along n_W: jac·q̇ = n·v_p.
  void ContactJacobian(int link, const btVector3& p_W, const btVector3& n_W, double* jac) const;
  /// response = M⁻¹ jac for a row of `link`'s ContactJacobian: the change of generalised velocity per unit
  /// impulse along the row.
  void Response(int link, const double* jac, double* response) const;

 private:
  struct Link {
    int parent = -1;        // link index in `links_` (0: the base), -1 for the base
    int dof_offset = -1;    // column of its first joint rate, -1 for a fixed joint or the base
    std::vector<int> path;  // the links with a joint rate from this one to the base (this one first)
    Eigen::Matrix3d R_WL;   // link (principal, CoM) frame to W
    Eigen::Vector3d com_W;
    Eigen::Vector3d pivot_W;  // its joint's pivot
    double mass = 0.0;
    Eigen::Vector3d inertia_L;  // principal moments
  };

  // adds `block` to the mass matrix at (row, col) and, off the diagonal, its transpose at (col, row)
  void AddBlock(int row, int col, const Eigen::Matrix3d& block);
  // inverse_ from mass_; false when M is not positive definite
  bool Invert();

  // a link's spatial Jacobian for the rates of a joint on its way to the base: first column, angular part,
  // linear part (scratch; the base's two blocks are written out in Update)
  struct JacobianBlock {
    int col;
    Eigen::Matrix3d angular, linear;
  };

  int dofs_ = 0;
  std::vector<Link> links_;       // base first, then Bullet's links in order (a parent before its children)
  std::vector<int> node_parent_;  // per node of three rates (Invert), -1 for the root
  Eigen::MatrixXd mass_;
  Eigen::MatrixXd eliminated_;  // scratch (Invert)
  Eigen::MatrixXd inverse_;
  std::vector<JacobianBlock> blocks_;
  bool valid_ = false;
};

class ContactSolver final : public btMultiBodyConstraintSolver {
 public:
  void set_warm_start(bool warm_start) { warm_start_ = warm_start; }
  /// false: every row through Bullet's own setup (for comparison).
  void set_factored_rows(bool factored_rows) { factored_rows_ = factored_rows; }

  btScalar solveGroupCacheFriendlySetup(btCollisionObject** bodies, int num_bodies,
                                        btPersistentManifold** manifolds, int num_manifolds,
                                        btTypedConstraint** constraints, int num_constraints,
                                        const btContactSolverInfo& info, btIDebugDraw* debug_draw) override;

 protected:
  void convertContacts(btPersistentManifold** manifolds, int num_manifolds,
                       const btContactSolverInfo& info) override;

 private:
  struct Side {
    btMultiBody* multibody = nullptr;
    int link = -1;
    const MultibodyMass* mass = nullptr;
    int solver_body = -1;  // a static body's, when there is no multibody
  };

  bool Factorable(const btPersistentManifold& manifold);
  static void ResetUnsolved(btManifoldPoint& point);
  static void ResetUnsolved(btPersistentManifold& manifold);
  const MultibodyMass* MassOf(btMultiBody* multibody);
  Side SideOf(const btCollisionObject* object, double step_s);
  void AddRows(btPersistentManifold& manifold, const btContactSolverInfo& info);
  btMultiBodySolverConstraint& AddRow(btMultiBodyConstraintArray& rows, const Side& a, const Side& b,
                                      btManifoldPoint& point, const btVector3& direction, bool friction,
                                      const btContactSolverInfo& info);
  void FillSide(const Side& side, bool is_a, const btVector3& p_W, const btVector3& direction,
                btMultiBodySolverConstraint* row, double* rel_vel, double* denominator);
  void Start(btMultiBodySolverConstraint& row, btScalar impulse);

  bool warm_start_ = true;
  bool factored_rows_ = true;
  // scratch: the manifolds Bullet converts itself, and those converted here
  btAlignedObjectArray<btPersistentManifold*> bullet_manifolds_;
  btAlignedObjectArray<btPersistentManifold*> factored_manifolds_;
  // per multibody seen, its mass matrix; `solve_` marks those updated for the current solve
  struct CachedMass {
    const btMultiBody* multibody = nullptr;
    uint64_t solve = 0;
    std::unique_ptr<MultibodyMass> mass;
  };
  std::vector<CachedMass> masses_;
  uint64_t solve_ = 0;
};

}  // namespace iapsim::physics::internal
