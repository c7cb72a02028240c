#include "physics/internal/cone_limit.h"

#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>

#include <algorithm>
#include <cmath>

namespace iapsim::physics::internal {
namespace {

constexpr btScalar kUnlimitedImpulse = 1e30;
// the row is made while the tilt is within this of the limit, plus twice what the joint turns in a step
constexpr btScalar kMarginRad = 0.02;

int IslandOf(const btMultiBody* multibody, int link) {
  const btMultiBodyLinkCollider* collider =
      link < 0 ? multibody->getBaseCollider() : multibody->getLink(link).m_collider;
  return collider ? collider->getIslandTag() : -1;
}

btMatrix3x3 WorldRotationOf(const btMultiBody* multibody, int link) {
  return link < 0 ? multibody->getBaseWorldTransform().getBasis()
                  : multibody->getLink(link).m_cachedWorldTransform.getBasis();
}

}  // namespace

ConeLimit::ConeLimit(btMultiBody* multibody, int link, const btVector3& axis_child,
                     const btVector3& rest_axis_parent, btScalar max_tilt_rad)
    : btMultiBodyConstraint(multibody, multibody, link, multibody->getLink(link).m_parent, 1,
                            /*isUnilateral=*/true, MULTIBODY_CONSTRAINT_SPHERICAL_LIMIT),
      axis_child_(axis_child),
      rest_axis_parent_(rest_axis_parent),
      max_tilt_rad_(max_tilt_rad) {
  m_maxAppliedImpulse = kUnlimitedImpulse;
}

void ConeLimit::finalizeMultiDof() {
  allocateJacobiansMultiDof();  // zero: only row 0 of A is filled, per step
  m_numDofsFinalized = m_jacSizeBoth;
}

int ConeLimit::getIslandIdA() const { return IslandOf(m_bodyA, m_linkA); }
int ConeLimit::getIslandIdB() const { return IslandOf(m_bodyB, m_linkB); }

void ConeLimit::createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                                     const btContactSolverInfo& info) {
  if (m_numDofsFinalized != m_jacSizeBoth) finalizeMultiDof();
  const btMatrix3x3 R_W_child = WorldRotationOf(m_bodyA, m_linkA);
  const btVector3 axis_W = R_W_child * axis_child_;
  const btVector3 rest_W = WorldRotationOf(m_bodyB, m_linkB) * rest_axis_parent_;
  const btVector3 away_W = rest_W.cross(axis_W);  // turning about it tilts the axis further from rest
  tilt_rad_ = std::atan2(away_W.length(), rest_W.dot(axis_W));

  const btScalar* joint_velocity = m_bodyA->getJointVelMultiDof(m_linkA);
  const btScalar joint_speed = btVector3(joint_velocity[0], joint_velocity[1], joint_velocity[2]).length();
  if (tilt_rad_ < max_tilt_rad_ - kMarginRad - 2.0 * joint_speed * info.m_timeStep ||
      away_W.length() < SIMD_EPSILON) {
    internalSetAppliedImpulse(0, 0.0);  // no stale impulse to warm start from when the row comes back
    return;
  }
  // the joint's velocity dofs are the child's angular velocity relative to the parent in the child's frame:
  // J q̇ = −n·ω_rel ≥ 0 keeps the tilt from growing
  const btVector3 away_child = R_W_child.transpose() * away_W.normalized();
  btScalar* jacobian = jacobianA(0);
  const int offset = 6 + m_bodyA->getLink(m_linkA).m_dofOffset;
  for (int i = 0; i < 3; ++i) jacobian[offset + i] = -away_child[i];

  btMultiBodySolverConstraint& row = rows.expandNonInitializing();
  const btVector3 zero(0.0, 0.0, 0.0);
  fillMultiBodyConstraint(row, data, jacobian, jacobianB(0), zero, zero, zero, zero,
                          /*posError=*/max_tilt_rad_ - tilt_rad_, info, 0.0, m_maxAppliedImpulse);
  row.m_orgConstraint = this;
  row.m_orgDofIndex = 0;
}

}  // namespace iapsim::physics::internal
