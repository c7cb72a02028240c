#pragma once
// Bullet's default collision configuration, with one change: a pair of convex shapes that Bullet would hand to
// GJK (btConvexConvexAlgorithm: cylinders, cones and convex hulls against each other and against boxes) first
// has its two oriented bounding boxes tested for separation, and goes to GJK only when they overlap within
// the contact breaking distance. Bullet culls the children of a compound by world-aligned boxes only, so the
// §VI-E pole (1 m long, pitched) overlaps 96 of the funnel's 97 pieces' boxes and ran GJK on each of them
// every step: 118,000 of the peg-in-hole step's 290,000 instructions (callgrind). Internal to physics/.

#include <BulletCollision/CollisionDispatch/btDefaultCollisionConfiguration.h>

#include <Eigen/Core>
#include <vector>

namespace iapsim::physics::internal {

/// A box around a shape in the shape's frame S: Bullet's local bounds are aligned with S, which for a convex
/// piece of a decomposed mesh (a wedge of the funnel, turned about its axis) is far looser than a box along the
/// piece's own principal axes. A shape whose user pointer is a ShapeBox is culled with it.
struct ShapeBox {
  Eigen::Vector3d center_S = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_SB = Eigen::Matrix3d::Identity();
  Eigen::Vector3d half_m = Eigen::Vector3d::Zero();
};

/// The box along the principal axes of `points_S` (their covariance's eigenvectors) that holds them all.
ShapeBox PrincipalBox(const std::vector<Eigen::Vector3d>& points_S);

/// Whether two oriented boxes (centres in W, rotations box -> W, half extents) are further apart than
/// `gap_m` along one of the 15 separating axes of the box-box test (Gottschalk et al., "OBBTree", SIGGRAPH
/// 1996). False means they may be within `gap_m`.
bool OrientedBoxesApart(const Eigen::Vector3d& center_a_W, const Eigen::Matrix3d& R_WA,
                        const Eigen::Vector3d& half_a_m, const Eigen::Vector3d& center_b_W,
                        const Eigen::Matrix3d& R_WB, const Eigen::Vector3d& half_b_m, double gap_m);

class CollisionConfiguration final : public btDefaultCollisionConfiguration {
 public:
  CollisionConfiguration();
  ~CollisionConfiguration() override;
  btCollisionAlgorithmCreateFunc* getCollisionAlgorithmCreateFunc(int proxy_type_0, int proxy_type_1) override;

 private:
  btCollisionAlgorithmCreateFunc* culled_convex_create_func_;
};

}  // namespace iapsim::physics::internal
