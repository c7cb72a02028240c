#include "physics/internal/contact_solver.h"

#include <BulletCollision/NarrowPhaseCollision/btPersistentManifold.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "physics/internal/bullet_eigen.h"

namespace iapsim::physics::internal {
namespace {

Eigen::Matrix3d Cross(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

}  // namespace

bool MultibodyMass::Supports(const btMultiBody& multibody) {
  if (multibody.hasFixedBase()) return false;
  for (int i = 0; i < multibody.getNumLinks(); ++i) {
    const auto type = multibody.getLink(i).m_jointType;
    if (type != btMultibodyLink::eSpherical && type != btMultibodyLink::eFixed) return false;
  }
  return true;
}

void MultibodyMass::Update(const btMultiBody& multibody) {
  const int links = multibody.getNumLinks() + 1;
  dofs_ = 6 + multibody.getNumDofs();
  if (static_cast<int>(links_.size()) != links) {  // the tree's shape: once
    links_.assign(links, Link());
    for (int i = 0; i < multibody.getNumLinks(); ++i) {
      const btMultibodyLink& bullet = multibody.getLink(i);
      Link& link = links_[i + 1];
      link.parent = bullet.m_parent + 1;
      link.dof_offset = bullet.m_jointType == btMultibodyLink::eSpherical ? 6 + bullet.m_dofOffset : -1;
      for (int j = i + 1; j > 0; j = links_[j].parent) {
        if (links_[j].dof_offset >= 0) link.path.push_back(j);
      }
    }
    // the rates in nodes of three (Invert): the base's angular rates, its linear rates, then each spherical
    // joint's, a node's parent the nearest node toward the base
    node_parent_.assign(dofs_ / 3, -1);
    node_parent_[1] = 0;
    for (const Link& link : links_) {
      if (link.dof_offset < 0) continue;
      node_parent_[link.dof_offset / 3] = link.path.size() > 1 ? links_[link.path[1]].dof_offset / 3 : 1;
    }
    mass_.resize(dofs_, dofs_);
    eliminated_.resize(dofs_, dofs_);
    inverse_.resize(dofs_, dofs_);
  }
  // the base: Bullet keeps the rotation from W into its frame, and its CoM
  Link& base = links_[0];
  base.R_WL = Eig(btMatrix3x3(multibody.getWorldToBaseRot())).transpose();
  base.com_W = Eig(multibody.getBasePos());
  base.pivot_W = base.com_W;
  base.mass = multibody.getBaseMass();
  base.inertia_L = Eig(multibody.getBaseInertia());
  // links from the rotations and CoM offsets Bullet cached for this step's configuration (as its own
  // Jacobians do), a parent before its children
  for (int i = 0; i < multibody.getNumLinks(); ++i) {
    const btMultibodyLink& bullet = multibody.getLink(i);
    Link& link = links_[i + 1];
    const Link& parent = links_[link.parent];
    // m_cachedRotParentToThis turns parent-frame vectors into this link's frame
    link.R_WL = parent.R_WL * Eig(btMatrix3x3(bullet.m_cachedRotParentToThis)).transpose();
    link.com_W = parent.com_W + link.R_WL * Eig(bullet.m_cachedRVector);  // parent CoM -> CoM, link frame
    link.pivot_W = link.com_W - link.R_WL * Eig(bullet.m_dVector);        // pivot -> CoM, link frame
    link.mass = bullet.m_mass;
    link.inertia_L = Eig(bullet.m_inertiaLocal);
  }

  // M = Σ_k J_kᵀ diag(I_k in W, m_k) J_k, J_k mapping the generalised velocities to link k's angular velocity
  // ω_k and its CoM's velocity v_k, in 3-column blocks: the base's ω_0 (ω: I, v: −[c_k − c_0]×) and v_0 (ω:
  // 0, v: I), and per spherical joint j on the way to the base its rates (ω: R_j, v: −[c_k − pivot_j]× R_j)
  mass_.setZero();
  for (const Link& link : links_) {
    const Eigen::Matrix3d inertia_W = link.R_WL * link.inertia_L.asDiagonal() * link.R_WL.transpose();
    // the base's two blocks written out: their identities and zeros would cost full 3 x 3 products
    const Eigen::Matrix3d arm = -Cross(link.com_W - base.com_W);
    AddBlock(0, 0, inertia_W + link.mass * arm.transpose() * arm);
    AddBlock(3, 0, link.mass * arm);
    AddBlock(3, 3, link.mass * Eigen::Matrix3d::Identity());
    blocks_.clear();
    for (const int j : link.path) {
      const Link& joint = links_[j];
      blocks_.push_back({joint.dof_offset, joint.R_WL, -Cross(link.com_W - joint.pivot_W) * joint.R_WL});
    }
    const int count = static_cast<int>(blocks_.size());
    for (int a = 0; a < count; ++a) {
      const JacobianBlock& block = blocks_[a];
      const Eigen::Matrix3d weighted_angular = inertia_W * block.angular;
      AddBlock(block.col, 0, weighted_angular.transpose() + link.mass * block.linear.transpose() * arm);
      AddBlock(block.col, 3, link.mass * block.linear.transpose());
      for (int b = 0; b <= a; ++b) {
        AddBlock(block.col, blocks_[b].col,
                 weighted_angular.transpose() * blocks_[b].angular +
                     link.mass * block.linear.transpose() * blocks_[b].linear);
      }
    }
  }
  valid_ = Invert();
}

// the loop above makes the (a, b) blocks with b up to a only: each adds its mirror, the diagonal ones once
void MultibodyMass::AddBlock(int row, int col, const Eigen::Matrix3d& block) {
  mass_.block<3, 3>(row, col) += block;
  if (row != col) mass_.block<3, 3>(col, row) += block.transpose();
}

void MultibodyMass::ContactJacobian(int link, const btVector3& p_W, const btVector3& n_W, double* jac) const {
  const Eigen::Vector3d p = Eig(p_W);
  const Eigen::Vector3d n = Eig(n_W);
  Eigen::Map<Eigen::VectorXd> row(jac, dofs_);
  row.setZero();
  // n·v_p with v_p = v_0 + ω_0 × (p − c_0) + Σ_j ω_j × (p − pivot_j): coefficient of a rate vector ω is r × n
  row.head<3>() = (p - links_[0].com_W).cross(n);
  row.segment<3>(3) = n;
  for (const int j : links_[link + 1].path) {
    const Link& joint = links_[j];
    row.segment<3>(joint.dof_offset) = joint.R_WL.transpose() * (p - joint.pivot_W).cross(n);
  }
}

void MultibodyMass::Response(int link, const double* jac, double* response) const {
  // jac is zero outside the base's rates and those of the joints between the link and the base, so each node
  // of three entries of M⁻¹ jac takes a few 3 x 3 blocks of M⁻¹ (fixed-size, unrolled) times jac's nodes
  const Eigen::Map<const Eigen::VectorXd> row(jac, dofs_);
  const std::vector<int>& path = links_[link + 1].path;
  for (int r = 0; r < dofs_; r += 3) {
    Eigen::Vector3d sum =
        inverse_.block<3, 3>(r, 0) * row.segment<3>(0) + inverse_.block<3, 3>(r, 3) * row.segment<3>(3);
    for (const int j : path) {
      const int col = links_[j].dof_offset;
      sum += inverse_.block<3, 3>(r, col) * row.segment<3>(col);
    }
    Eigen::Map<Eigen::Vector3d>(response + r) = sum;
  }
}

// M⁻¹ by block elimination along the tree, in nodes of three rates. A node's rates couple only to its
// ancestors' (branch-induced sparsity), so eliminating the nodes from the leaves to the root fills nothing
// in (Featherstone, "Rigid Body Dynamics Algorithms", 2008, §6.5), and M = Lᵀ D L with D the eliminated
// diagonal blocks and L(k, a) = D_k⁻¹ M(k, a) for each ancestor a of k. M⁻¹ then follows from the root down
// (Takahashi's equations, X = D⁻¹ L⁻ᵀ + (I − L) X, where D⁻¹ L⁻ᵀ has no blocks below the diagonal):
// X(k, j) = −Σ_a L(k, a) X(a, j) for each node j before k, and X(k, k) = D_k⁻¹ − Σ_a L(k, a) X(a, k). All in
// fixed-size 3 x 3 blocks, which Eigen unrolls: 6,900 instructions a step for the resting three-star's
// 15 x 15, where a dense Cholesky factorisation and inverse spent 16,200 (callgrind).
bool MultibodyMass::Invert() {
  const int nodes = dofs_ / 3;
  const auto block = [](Eigen::MatrixXd& m, int row, int col) { return m.block<3, 3>(3 * row, 3 * col); };
  Eigen::MatrixXd& schur = inverse_;     // the lower blocks of M as the elimination updates them, then M⁻¹
  Eigen::MatrixXd& lower = eliminated_;  // L(k, a) below the diagonal, D_k⁻¹ on it
  schur = mass_;
  for (int k = nodes - 1; k >= 0; --k) {
    // positive definite by Sylvester's criterion (leading minors), then inverted by cofactors
    const Eigen::Matrix3d d = block(schur, k, k);
    if (!(d(0, 0) > 0.0 && d(0, 0) * d(1, 1) - d(0, 1) * d(1, 0) > 0.0 && d.determinant() > 0.0))
      return false;
    block(lower, k, k) = d.inverse();
    for (int a = node_parent_[k]; a >= 0; a = node_parent_[a]) {
      block(lower, k, a) = block(lower, k, k) * block(schur, k, a);
    }
    for (int a = node_parent_[k]; a >= 0; a = node_parent_[a]) {
      for (int b = a; b >= 0; b = node_parent_[b]) {
        block(schur, a, b) -= block(schur, k, a).transpose() * block(lower, k, b);
      }
    }
  }
  Eigen::MatrixXd& x = inverse_;
  for (int k = 0; k < nodes; ++k) {
    for (int j = 0; j <= k; ++j) {
      Eigen::Matrix3d sum = j == k ? Eigen::Matrix3d(block(lower, k, k)) : Eigen::Matrix3d::Zero();
      for (int a = node_parent_[k]; a >= 0; a = node_parent_[a]) sum -= block(lower, k, a) * block(x, a, j);
      block(x, k, j) = sum;
      if (j < k) block(x, j, k) = sum.transpose();
    }
  }
  return true;
}

btScalar ContactSolver::solveGroupCacheFriendlySetup(btCollisionObject** bodies, int num_bodies,
                                                     btPersistentManifold** manifolds, int num_manifolds,
                                                     btTypedConstraint** constraints, int num_constraints,
                                                     const btContactSolverInfo& info,
                                                     btIDebugDraw* debug_draw) {
  ++solve_;
  const btScalar result = btMultiBodyConstraintSolver::solveGroupCacheFriendlySetup(
      bodies, num_bodies, manifolds, num_manifolds, constraints, num_constraints, info, debug_draw);
  if (!warm_start_) return result;
  for (int i = 0; i < m_multiBodyNormalContactConstraints.size(); ++i) {
    btMultiBodySolverConstraint& normal = m_multiBodyNormalContactConstraints[i];
    const auto* point = static_cast<const btManifoldPoint*>(normal.m_originalContactPoint);
    Start(normal, std::clamp(point->m_appliedImpulse, normal.m_lowerLimit, normal.m_upperLimit));
    // the two friction rows of the point follow each other (SOLVER_USE_2_FRICTION_DIRECTIONS); their
    // directions come from the normal alone (btPlaneSpace1), so they are last step's while it holds
    Start(m_multiBodyFrictionContactConstraints[normal.m_frictionIndex], point->m_appliedImpulseLateral1);
    Start(m_multiBodyFrictionContactConstraints[normal.m_frictionIndex + 1], point->m_appliedImpulseLateral2);
  }
  for (int i = 0; i < m_multiBodyNonContactConstraints.size(); ++i) {
    btMultiBodySolverConstraint& row = m_multiBodyNonContactConstraints[i];
    Start(row, row.m_orgConstraint->getAppliedImpulse(row.m_orgDofIndex));
  }
  return result;
}

// gives the row `impulse` as its applied impulse and its bodies the velocity change it makes, the way an
// iteration applies an impulse change (resolveSingleConstraintRowGeneric)
void ContactSolver::Start(btMultiBodySolverConstraint& row, btScalar impulse) {
  row.m_appliedImpulse = impulse;
  if (impulse == 0.0) return;
  // one side of the row: a multibody through its unit responses, or a rigid solver body
  auto apply = [&](btMultiBody* multibody, int jac_index, int delta_index, int solver_body,
                   const btVector3& normal, const btVector3& angular) {
    if (multibody) {
      btScalar* unit_response = &m_data.m_deltaVelocitiesUnitImpulse[jac_index];
      applyDeltaVee(unit_response, impulse, delta_index, multibody->getNumDofs() + 6);
      multibody->applyDeltaVeeMultiDof2(unit_response, impulse);
    } else if (solver_body >= 0) {
      btSolverBody& body = m_tmpSolverBodyPool[solver_body];
      body.internalApplyImpulse(normal * body.internalGetInvMass(), angular, impulse);
    }
  };
  apply(row.m_multiBodyA, row.m_jacAindex, row.m_deltaVelAindex, row.m_solverBodyIdA, row.m_contactNormal1,
        row.m_angularComponentA);
  apply(row.m_multiBodyB, row.m_jacBindex, row.m_deltaVelBindex, row.m_solverBodyIdB, row.m_contactNormal2,
        row.m_angularComponentB);
}

void ContactSolver::convertContacts(btPersistentManifold** manifolds, int num_manifolds,
                                    const btContactSolverInfo& info) {
  // Bullet converts the others, and every latch row, first
  bullet_manifolds_.resize(0);
  factored_manifolds_.resize(0);
  for (int m = 0; m < num_manifolds; ++m) {
    btPersistentManifold* manifold = manifolds[m];
    // most manifolds of a vehicle in the air (its boxes against the ground plane) have no point to solve
    bool solved = false;
    for (int p = 0; p < manifold->getNumContacts(); ++p) {
      solved =
          solved || manifold->getContactPoint(p).getDistance() <= manifold->getContactProcessingThreshold();
    }
    if (!solved) {
      ResetUnsolved(*manifold);
    } else {
      (Factorable(*manifold) ? factored_manifolds_ : bullet_manifolds_).push_back(manifold);
    }
  }
  btMultiBodyConstraintSolver::convertContacts(bullet_manifolds_.size() > 0 ? &bullet_manifolds_[0] : nullptr,
                                               bullet_manifolds_.size(), info);
  for (int m = 0; m < factored_manifolds_.size(); ++m) AddRows(*factored_manifolds_[m], info);
}

// a point not solved this step has nothing to warm start from when it comes back (as in Bullet's setup)
void ContactSolver::ResetUnsolved(btManifoldPoint& point) {
  point.m_appliedImpulse = 0.0;
  point.m_prevRHS = 0.0;
}

void ContactSolver::ResetUnsolved(btPersistentManifold& manifold) {
  for (int p = 0; p < manifold.getNumContacts(); ++p) ResetUnsolved(manifold.getContactPoint(p));
}

// between multibodies with spherical and fixed joints and static bodies, with Bullet's default friction
// model (two directions, no rolling, spinning or anisotropic friction, no friction anchors)
bool ContactSolver::Factorable(const btPersistentManifold& manifold) {
  if (!factored_rows_) return false;
  bool has_multibody = false;
  for (const btCollisionObject* object : {static_cast<const btCollisionObject*>(manifold.getBody0()),
                                          static_cast<const btCollisionObject*>(manifold.getBody1())}) {
    if (object->hasAnisotropicFriction() ||
        (object->getCollisionFlags() & btCollisionObject::CF_HAS_FRICTION_ANCHOR)) {
      return false;
    }
    if (const auto* collider = btMultiBodyLinkCollider::upcast(object)) {
      if (!MultibodyMass::Supports(*collider->m_multiBody) || !MassOf(collider->m_multiBody)->valid())
        return false;
      has_multibody = true;
    } else if (!object->isStaticObject()) {
      return false;
    }
  }
  for (int p = 0; p < manifold.getNumContacts(); ++p) {
    const btManifoldPoint& point = manifold.getContactPoint(p);
    if (point.m_combinedRollingFriction > 0.0 || point.m_combinedSpinningFriction > 0.0) return false;
  }
  return has_multibody;
}

const MultibodyMass* ContactSolver::MassOf(btMultiBody* multibody) {
  auto it = std::find_if(masses_.begin(), masses_.end(),
                         [multibody](const CachedMass& cached) { return cached.multibody == multibody; });
  if (it == masses_.end()) {
    masses_.push_back(CachedMass{multibody, 0, std::make_unique<MultibodyMass>()});
    it = masses_.end() - 1;
  }
  if (it->solve != solve_) {
    it->mass->Update(*multibody);
    it->solve = solve_;
  }
  return it->mass.get();
}

ContactSolver::Side ContactSolver::SideOf(const btCollisionObject* object, double step_s) {
  Side side;
  if (const auto* collider = btMultiBodyLinkCollider::upcast(object)) {
    side.multibody = collider->m_multiBody;
    side.link = collider->m_link;
    side.mass = MassOf(collider->m_multiBody);
  } else {
    side.solver_body = getOrInitSolverBody(*const_cast<btCollisionObject*>(object), step_s);
  }
  return side;
}

// Bullet's rows for each point within the processing threshold (convertMultiBodyContact): the normal, then
// its two friction directions
void ContactSolver::AddRows(btPersistentManifold& manifold, const btContactSolverInfo& info) {
  const Side a = SideOf(manifold.getBody0(), info.m_timeStep);
  const Side b = SideOf(manifold.getBody1(), info.m_timeStep);
  for (int p = 0; p < manifold.getNumContacts(); ++p) {
    btManifoldPoint& point = manifold.getContactPoint(p);
    if (point.getDistance() > manifold.getContactProcessingThreshold()) {
      ResetUnsolved(point);
      continue;
    }
    const int normal_index = m_multiBodyNormalContactConstraints.size();
    const int friction_index = m_multiBodyFrictionContactConstraints.size();
    AddRow(m_multiBodyNormalContactConstraints, a, b, point, point.m_normalWorldOnB, false, info)
        .m_frictionIndex = friction_index;
    btPlaneSpace1(point.m_normalWorldOnB, point.m_lateralFrictionDir1, point.m_lateralFrictionDir2);
    point.m_lateralFrictionDir1.normalize();
    point.m_lateralFrictionDir2.normalize();
    AddRow(m_multiBodyFrictionContactConstraints, a, b, point, point.m_lateralFrictionDir1, true, info)
        .m_frictionIndex = normal_index;
    AddRow(m_multiBodyFrictionContactConstraints, a, b, point, point.m_lateralFrictionDir2, true, info)
        .m_frictionIndex = normal_index;
  }
}

// One row along `direction` (from B toward A), with the right-hand side of setupMultiBodyContactConstraint
btMultiBodySolverConstraint& ContactSolver::AddRow(btMultiBodyConstraintArray& rows, const Side& a,
                                                   const Side& b, btManifoldPoint& point,
                                                   const btVector3& direction, bool friction,
                                                   const btContactSolverInfo& info) {
  btMultiBodySolverConstraint& row = rows.expandNonInitializing();
  row = btMultiBodySolverConstraint();
  row.m_solverBodyIdA = a.solver_body;
  row.m_multiBodyA = a.multibody;
  row.m_linkA = a.link;
  row.m_solverBodyIdB = b.solver_body;
  row.m_multiBodyB = b.multibody;
  row.m_linkB = b.link;
  row.m_originalContactPoint = &point;
  row.m_friction = point.m_combinedFriction;

  // constraint force mixing and error reduction: the world's, or the contact's stiffness and damping
  double cfm = friction ? info.m_frictionCFM : info.m_globalCfm;
  double erp = friction ? info.m_frictionERP : info.m_erp2;
  if (!friction) {
    if (point.m_contactPointFlags & (BT_CONTACT_FLAG_HAS_CONTACT_CFM | BT_CONTACT_FLAG_HAS_CONTACT_ERP)) {
      if (point.m_contactPointFlags & BT_CONTACT_FLAG_HAS_CONTACT_CFM) cfm = point.m_contactCFM;
      if (point.m_contactPointFlags & BT_CONTACT_FLAG_HAS_CONTACT_ERP) erp = point.m_contactERP;
    } else if (point.m_contactPointFlags & BT_CONTACT_FLAG_CONTACT_STIFFNESS_DAMPING) {
      const double denominator =
          std::max(info.m_timeStep * point.m_combinedContactStiffness1 + point.m_combinedContactDamping1,
                   SIMD_EPSILON);
      cfm = 1.0 / denominator;
      erp = info.m_timeStep * point.m_combinedContactStiffness1 / denominator;
    }
  }
  cfm /= info.m_timeStep;

  double rel_vel = 0.0, denominator = 0.0;
  const btVector3& p_A = point.getPositionWorldOnA();
  const btVector3& p_B = point.getPositionWorldOnB();
  row.m_contactNormal1 = direction;
  row.m_contactNormal2 = -direction;
  // a static body takes no impulse (its solver body has no inverse mass)
  row.m_angularComponentA.setZero();
  row.m_angularComponentB.setZero();
  if (a.multibody) {
    FillSide(a, true, p_A, direction, &row, &rel_vel, &denominator);
  } else {
    const btVector3 r = p_A - m_tmpSolverBodyPool[a.solver_body].getWorldTransform().getOrigin();
    row.m_relpos1CrossNormal = r.cross(direction);
  }
  if (b.multibody) {
    FillSide(b, false, p_B, -direction, &row, &rel_vel, &denominator);
  } else {
    const btVector3 r = p_B - m_tmpSolverBodyPool[b.solver_body].getWorldTransform().getOrigin();
    row.m_relpos2CrossNormal = r.cross(-direction);
  }
  const double d = denominator + cfm;
  row.m_jacDiagABInv = d > SIMD_EPSILON ? info.m_sor / d : 0.0;  // 0 disables a redundant row

  // velocity error, plus position error: penetration corrected at the error reduction rate; a gap (a
  // speculative point) may close within the step and no further
  double velocity_error = -rel_vel, position_error = 0.0;
  if (!friction) {
    velocity_error +=
        std::max(0.0, static_cast<double>(restitutionCurve(rel_vel, point.m_combinedRestitution,
                                                           info.m_restitutionVelocityThreshold)));
    const double distance = point.getDistance() + info.m_linearSlop;
    if (distance > 0.0) {
      velocity_error -= distance / info.m_timeStep;
    } else {
      position_error = -distance * erp / info.m_timeStep;
    }
    row.m_lowerLimit = 0.0;
    row.m_upperLimit = 1e10;
  } else {
    row.m_lowerLimit = -row.m_friction;
    row.m_upperLimit = row.m_friction;
  }
  row.m_rhs = (position_error + velocity_error) * row.m_jacDiagABInv;
  row.m_rhsPenetration = 0.0;
  row.m_cfm = cfm * row.m_jacDiagABInv;
  row.m_appliedImpulse = 0.0;
  row.m_appliedPushImpulse = 0.0;
  return row;
}

// a multibody's part of a row (`direction` from the other body toward this one): its Jacobian and unit
// response in Bullet's arrays, the moment arm of the force it takes (Bullet's constraint-force bookkeeping),
// its velocity along the row and its share of J M⁻¹ Jᵀ
void ContactSolver::FillSide(const Side& side, bool is_a, const btVector3& p_W, const btVector3& direction,
                             btMultiBodySolverConstraint* row, double* rel_vel, double* denominator) {
  btMultiBody* multibody = side.multibody;
  int& jac_index = is_a ? row->m_jacAindex : row->m_jacBindex;
  int& velocity_index = is_a ? row->m_deltaVelAindex : row->m_deltaVelBindex;
  const btVector3 com_W = side.link < 0 ? multibody->getBasePos()
                                        : multibody->getLink(side.link).m_cachedWorldTransform.getOrigin();
  (is_a ? row->m_relpos1CrossNormal : row->m_relpos2CrossNormal) = (p_W - com_W).cross(direction);

  const int dofs = multibody->getNumDofs() + 6;
  velocity_index = multibody->getCompanionId();
  if (velocity_index < 0) {
    velocity_index = m_data.m_deltaVelocities.size();
    multibody->setCompanionId(velocity_index);
    m_data.m_deltaVelocities.resize(m_data.m_deltaVelocities.size() + dofs, 0.0);
  }
  // uninitialised: ContactJacobian and Response write every entry
  jac_index = m_data.m_jacobians.size();
  m_data.m_jacobians.resizeNoInitialize(m_data.m_jacobians.size() + dofs);
  m_data.m_deltaVelocitiesUnitImpulse.resizeNoInitialize(m_data.m_deltaVelocitiesUnitImpulse.size() + dofs);
  double* jac = &m_data.m_jacobians[jac_index];
  double* response = &m_data.m_deltaVelocitiesUnitImpulse[jac_index];
  side.mass->ContactJacobian(side.link, p_W, direction, jac);
  side.mass->Response(side.link, jac, response);
  const double* velocity = multibody->getVelocityVector();
  // summed in locals: through the pointers, every term waited for the last one's store
  double side_rel_vel = 0.0, side_denominator = 0.0;
  for (int i = 0; i < dofs; ++i) {
    side_rel_vel += jac[i] * velocity[i];
    side_denominator += jac[i] * response[i];
  }
  *rel_vel += side_rel_vel;
  *denominator += side_denominator;
}

}  // namespace iapsim::physics::internal
