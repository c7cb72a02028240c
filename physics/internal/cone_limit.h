#pragma once
// A cone limit on a spherical joint of a Bullet multibody: the tilt θ between the child's axis and the
// direction that axis has at the joint's zero position, in the parent, stays within θ_max; twist about the
// axis is free (a ball joint's stem touching its socket's rim, at the same angle in every direction).
//
// Written here because Bullet's btMultiBodySphericalJointLimit bounds three Euler angles (a box, not a
// cone) and builds its rows from both links' world Jacobians, which leaves out the coupling between two
// links of one multibody in the row's effective mass. This row acts on the joint's own coordinates (its
// three velocity dofs are the child's angular velocity relative to the parent, in the child's frame), so
// J M⁻¹ Jᵀ is exact and the impulse reacts on the parent by construction. It is unilateral and speculative
// like a contact: it only exists while the limit can be reached within the step, and it lets the joint
// approach the limit but not cross it (an overshoot is pushed back by the solver's error reduction).

#include <BulletDynamics/Featherstone/btMultiBodyConstraint.h>

namespace iapsim::physics::internal {

class ConeLimit final : public btMultiBodyConstraint {
 public:
  /// `axis_child`: the limited axis in the child link's Bullet frame; `rest_axis_parent`: the direction of
  /// that axis at the zero joint position, in the parent's Bullet frame (unit vectors).
  ConeLimit(btMultiBody* multibody, int link, const btVector3& axis_child, const btVector3& rest_axis_parent,
            btScalar max_tilt_rad);

  void finalizeMultiDof() override;
  int getIslandIdA() const override;
  int getIslandIdB() const override;
  void createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                            const btContactSolverInfo& info) override;
  void debugDraw(btIDebugDraw*) override {}

  /// The tilt at the last row creation (the start of the last step), rad.
  btScalar tilt_rad() const { return tilt_rad_; }

 private:
  btVector3 axis_child_, rest_axis_parent_;
  btScalar max_tilt_rad_;
  btScalar tilt_rad_ = 0.0;
};

}  // namespace iapsim::physics::internal
