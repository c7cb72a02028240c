#pragma once
// Bullet's default collision configuration, with one change: a pair of convex shapes that Bullet would hand
// to GJK (btConvexConvexAlgorithm: cylinders, cones and convex hulls against each other and against boxes)
// first has its two bounds (oriented boxes, or the cylinder itself) tested for separation, and goes to GJK
// only when they come within the contact breaking distance. Bullet culls the children of a compound by
// world-aligned boxes only, so the §VI-E pole (1 m long, pitched) overlapped 96 of the funnel's 97 pieces'
// boxes and ran GJK on each of them every step, in the hole 650,000 of a step's 1.3 M instructions
// (callgrind). Internal to physics/.

#include <BulletCollision/CollisionDispatch/btCollisionDispatcher.h>
#include <BulletCollision/CollisionDispatch/btDefaultCollisionConfiguration.h>

#include <Eigen/Core>
#include <vector>

namespace iapsim::physics::internal {

/// A box around a shape in the shape's frame S: Bullet's local bounds are aligned with S, which for a convex
/// piece of a decomposed mesh (a wedge of the funnel, turned about its axis) is far looser than a box along
/// the piece's own principal axes. A shape whose user pointer is a ShapeBox is culled with it.
struct ShapeBox {
  Eigen::Vector3d center_S = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_SB = Eigen::Matrix3d::Identity();
  Eigen::Vector3d half_m = Eigen::Vector3d::Zero();
};

/// The box along the principal axes of `points_S` (their covariance's eigenvectors) that holds them all.
ShapeBox PrincipalBox(const std::vector<Eigen::Vector3d>& points_S);

/// What a convex shape is culled with: its oriented box, or the cylinder itself (a box around a pole 1 m long
/// and 15 mm thick reaches 21 mm from its axis at the corners, which in a 25 mm hole is every wall piece).
struct Bound {
  enum class Kind { kBox, kCylinder };
  Kind kind = Kind::kBox;
  Eigen::Vector3d center_W = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_WB = Eigen::Matrix3d::Identity();  // a cylinder's axis is the third column
  Eigen::Vector3d half_m = Eigen::Vector3d::Zero();  // a box's half extents; a cylinder's (r, r, half length)
};

/// Whether two bounds are further apart than `gap_m` along one of the separating axes tried: each box's face
/// normals, each cylinder's axis, their cross products and the line between the centres, each with the
/// shapes' exact extent along it (Ericson, "Real-Time Collision Detection", §4.4 and §5.5). False means they
/// may be within `gap_m`.
bool BoundsApart(const Bound& a, const Bound& b, double gap_m);

/// Its culled convex pairs read the breaking distance from the dispatcher: use it with a Dispatcher (below).
class CollisionConfiguration final : public btDefaultCollisionConfiguration {
 public:
  CollisionConfiguration();
  ~CollisionConfiguration() override;
  btCollisionAlgorithmCreateFunc* getCollisionAlgorithmCreateFunc(int proxy_type_0,
                                                                  int proxy_type_1) override;

 private:
  btCollisionAlgorithmCreateFunc* culled_convex_create_func_;
};

/// Bullet's dispatcher, with the distance within which a pair's contact points are searched for and kept (its
/// contact breaking threshold) capped. Bullet's is 2 % of the smaller of the two shapes' motion radii, sized
/// for game steps of 1/60 s: for the §VI-E pole in the funnel 3.5 mm, within which a conformal contact (a
/// 30 mm pole against a 50 mm hole) has about a dozen of the wall's pieces around each contact, each in
/// GJK and its points in the solve, every step. At 1 ms steps bodies move a millimetre a step at 1 m/s.
class Dispatcher final : public btCollisionDispatcher {
 public:
  /// `max_breaking_m` 0 keeps Bullet's distance.
  Dispatcher(btCollisionConfiguration* config, double max_breaking_m);
  btPersistentManifold* getNewManifold(const btCollisionObject* body0,
                                       const btCollisionObject* body1) override;
  /// The breaking distance of a pair of whole shapes (a compound's, not its children's), as their manifold
  /// gets it.
  double BreakingDistance(const btCollisionShape& shape0, const btCollisionShape& shape1) const;

 private:
  double max_breaking_m_;
};

}  // namespace iapsim::physics::internal
