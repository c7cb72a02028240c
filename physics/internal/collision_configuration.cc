#include "physics/internal/collision_configuration.h"

#include <BulletCollision/BroadphaseCollision/btCollisionAlgorithm.h>
#include <BulletCollision/BroadphaseCollision/btDispatcher.h>
#include <BulletCollision/CollisionDispatch/btCollisionDispatcher.h>
#include <BulletCollision/CollisionDispatch/btCollisionObjectWrapper.h>
#include <BulletCollision/CollisionDispatch/btConvexConvexAlgorithm.h>
#include <BulletCollision/CollisionDispatch/btManifoldResult.h>
#include <BulletCollision/CollisionShapes/btCollisionShape.h>
#include <BulletCollision/CollisionShapes/btCylinderShape.h>
#include <BulletCollision/NarrowPhaseCollision/btPersistentManifold.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "physics/internal/bullet_eigen.h"

namespace iapsim::physics::internal {
namespace {

// A shape's bound in W: a cylinder itself, a mesh piece's principal box, else Bullet's bounds in the shape's
// frame (margins included).
Bound BoundOf(const btCollisionObjectWrapper& object) {
  const btCollisionShape* shape = object.getCollisionShape();
  const btTransform& X_WS = object.getWorldTransform();
  const Eigen::Matrix3d R_WS = Eig(X_WS.getBasis());
  const Eigen::Vector3d p_WS = Eig(X_WS.getOrigin());
  Bound bound;
  if (shape->getShapeType() == CYLINDER_SHAPE_PROXYTYPE) {
    const auto* cylinder = static_cast<const btCylinderShape*>(shape);
    const int axis = cylinder->getUpAxis();
    bound.kind = Bound::Kind::kCylinder;
    bound.center_W = p_WS;
    // the cylinder's axis last: columns (axis + 1, axis + 2, axis) of its frame
    bound.R_WB << R_WS.col((axis + 1) % 3), R_WS.col((axis + 2) % 3), R_WS.col(axis);
    const double radius_m = cylinder->getRadius();
    bound.half_m = Eigen::Vector3d(radius_m, radius_m, cylinder->getHalfExtentsWithMargin()[axis]);
    return bound;
  }
  if (const auto* principal = static_cast<const ShapeBox*>(shape->getUserPointer())) {
    bound.R_WB = R_WS * principal->R_SB;
    bound.center_W = p_WS + R_WS * principal->center_S;
    bound.half_m = principal->half_m;
    return bound;
  }
  btTransform identity;
  identity.setIdentity();
  btVector3 min, max;
  shape->getAabb(identity, min, max);
  bound.R_WB = R_WS;
  bound.center_W = p_WS + R_WS * Eig(0.5 * (min + max));
  bound.half_m = Eig(0.5 * (max - min));
  return bound;
}

// how far the bound reaches from its centre along the unit direction d
double Extent(const Bound& bound, const Eigen::Vector3d& d) {
  if (bound.kind == Bound::Kind::kBox) return bound.half_m.dot((bound.R_WB.transpose() * d).cwiseAbs());
  const double along = std::abs(d.dot(bound.R_WB.col(2)));
  return bound.half_m.x() * std::sqrt(std::max(0.0, 1.0 - along * along)) + bound.half_m.z() * along;
}

// the directions whose cross products give separating axes: a box's edges, a cylinder's axis
int EdgeDirections(const Bound& bound, Eigen::Vector3d* directions) {
  if (bound.kind == Bound::Kind::kCylinder) {
    directions[0] = bound.R_WB.col(2);
    return 1;
  }
  for (int i = 0; i < 3; ++i) directions[i] = bound.R_WB.col(i);
  return 3;
}

// GJK only for pairs whose bounds are within the distance at which Bullet keeps contact points: beyond it
// GJK finds no point and Bullet's manifold would drop the old ones, which is what a culled pair does.
class CulledConvexAlgorithm final : public btCollisionAlgorithm {
 public:
  CulledConvexAlgorithm(const btCollisionAlgorithmConstructionInfo& info, btCollisionAlgorithm* gjk)
      : btCollisionAlgorithm(info), gjk_(gjk) {}

  ~CulledConvexAlgorithm() override {
    gjk_->~btCollisionAlgorithm();
    m_dispatcher->freeCollisionAlgorithm(gjk_);
  }

  void processCollision(const btCollisionObjectWrapper* body0, const btCollisionObjectWrapper* body1,
                        const btDispatcherInfo& dispatch_info, btManifoldResult* result) override {
    // the distance within which the manifold keeps points (Dispatcher::getNewManifold), of the two bodies'
    // whole shapes (compounds included)
    const double gap_m = static_cast<const Dispatcher*>(m_dispatcher)
                             ->BreakingDistance(*body0->getCollisionObject()->getCollisionShape(),
                                                *body1->getCollisionObject()->getCollisionShape()) +
                         result->m_closestPointDistanceThreshold;
    if (!BoundsApart(BoundOf(*body0), BoundOf(*body1), gap_m)) {
      gjk_->processCollision(body0, body1, dispatch_info, result);
      return;
    }
    manifolds_.resize(0);
    gjk_->getAllContactManifolds(manifolds_);
    for (int m = 0; m < manifolds_.size(); ++m) {
      if (manifolds_[m]->getNumContacts() > 0) manifolds_[m]->clearManifold();
    }
  }

  btScalar calculateTimeOfImpact(btCollisionObject* body0, btCollisionObject* body1,
                                 const btDispatcherInfo& dispatch_info, btManifoldResult* result) override {
    return gjk_->calculateTimeOfImpact(body0, body1, dispatch_info, result);
  }

  void getAllContactManifolds(btManifoldArray& manifolds) override {
    gjk_->getAllContactManifolds(manifolds);
  }

 private:
  btCollisionAlgorithm* gjk_;
  btManifoldArray manifolds_;
};

class CulledConvexCreateFunc final : public btCollisionAlgorithmCreateFunc {
 public:
  explicit CulledConvexCreateFunc(btCollisionAlgorithmCreateFunc* gjk) : gjk_(gjk) {}

  btCollisionAlgorithm* CreateCollisionAlgorithm(btCollisionAlgorithmConstructionInfo& info,
                                                 const btCollisionObjectWrapper* body0,
                                                 const btCollisionObjectWrapper* body1) override {
    btCollisionAlgorithm* gjk = gjk_->CreateCollisionAlgorithm(info, body0, body1);
    // the dispatcher's pool holds algorithms up to btConvexConvexAlgorithm's size; this one is smaller
    static_assert(sizeof(CulledConvexAlgorithm) <= sizeof(btConvexConvexAlgorithm));
    void* memory = info.m_dispatcher1->allocateCollisionAlgorithm(sizeof(CulledConvexAlgorithm));
    return new (memory) CulledConvexAlgorithm(info, gjk);
  }

 private:
  btCollisionAlgorithmCreateFunc* gjk_;
};

// Bullet's default pools hold 4096 contact manifolds (6.4 MB in double precision) and 4096 collision
// algorithms, written through when the world is made: 17-42 ms (measured) of a physics process's start and
// of every environment of an RL vector. A scene here has up to about a hundred pairs (the funnel's 97 pieces
// against the pole), and a full pool is not an error: btCollisionDispatcher then takes the next one from the
// heap (getNewManifold, allocateCollisionAlgorithm) and frees it there (world_test: 300 boxes on the ground).
btDefaultCollisionConstructionInfo PoolSizes() {
  btDefaultCollisionConstructionInfo info;
  info.m_defaultMaxPersistentManifoldPoolSize = 256;
  info.m_defaultMaxCollisionAlgorithmPoolSize = 256;
  return info;
}

}  // namespace

ShapeBox PrincipalBox(const std::vector<Eigen::Vector3d>& points_S) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points_S) mean += p;
  mean /= static_cast<double>(points_S.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const auto& p : points_S) covariance += (p - mean) * (p - mean).transpose();
  ShapeBox box;
  box.R_SB = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvectors();
  Eigen::Vector3d min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max = -min;
  for (const auto& p : points_S) {
    const Eigen::Vector3d p_B = box.R_SB.transpose() * p;
    min = min.cwiseMin(p_B);
    max = max.cwiseMax(p_B);
  }
  box.center_S = box.R_SB * (0.5 * (min + max));
  box.half_m = 0.5 * (max - min);
  return box;
}

bool BoundsApart(const Bound& a, const Bound& b, double gap_m) {
  const Eigen::Vector3d between = b.center_W - a.center_W;
  const auto apart_along = [&](const Eigen::Vector3d& axis) {
    const double length = axis.norm();
    if (length < 1e-9) return false;  // parallel edges: no axis
    const Eigen::Vector3d d = axis / length;
    return std::abs(d.dot(between)) > Extent(a, d) + Extent(b, d) + gap_m;
  };
  Eigen::Vector3d edges_a[3], edges_b[3];
  const int count_a = EdgeDirections(a, edges_a);
  const int count_b = EdgeDirections(b, edges_b);
  // faces of a box (its edge directions are its face normals), a cylinder's axis
  for (int i = 0; i < count_a; ++i) {
    if (apart_along(edges_a[i])) return true;
  }
  for (int j = 0; j < count_b; ++j) {
    if (apart_along(edges_b[j])) return true;
  }
  for (int i = 0; i < count_a; ++i) {
    for (int j = 0; j < count_b; ++j) {
      if (apart_along(edges_a[i].cross(edges_b[j]))) return true;
    }
  }
  // round shapes separate along the line between them, which none of the above may be
  return (a.kind == Bound::Kind::kCylinder || b.kind == Bound::Kind::kCylinder) && apart_along(between);
}

CollisionConfiguration::CollisionConfiguration()
    : btDefaultCollisionConfiguration(PoolSizes()),
      culled_convex_create_func_(new CulledConvexCreateFunc(m_convexConvexCreateFunc)) {}

CollisionConfiguration::~CollisionConfiguration() { delete culled_convex_create_func_; }

btCollisionAlgorithmCreateFunc* CollisionConfiguration::getCollisionAlgorithmCreateFunc(int proxy_type_0,
                                                                                        int proxy_type_1) {
  btCollisionAlgorithmCreateFunc* bullet =
      btDefaultCollisionConfiguration::getCollisionAlgorithmCreateFunc(proxy_type_0, proxy_type_1);
  return bullet == m_convexConvexCreateFunc ? culled_convex_create_func_ : bullet;
}

Dispatcher::Dispatcher(btCollisionConfiguration* config, double max_breaking_m)
    : btCollisionDispatcher(config), max_breaking_m_(max_breaking_m) {}

btPersistentManifold* Dispatcher::getNewManifold(const btCollisionObject* body0,
                                                 const btCollisionObject* body1) {
  btPersistentManifold* manifold = btCollisionDispatcher::getNewManifold(body0, body1);
  manifold->setContactBreakingThreshold(
      BreakingDistance(*body0->getCollisionShape(), *body1->getCollisionShape()));
  return manifold;
}

double Dispatcher::BreakingDistance(const btCollisionShape& shape0, const btCollisionShape& shape1) const {
  // as btCollisionDispatcher::getNewManifold
  const double bullet_m = (getDispatcherFlags() & CD_USE_RELATIVE_CONTACT_BREAKING_THRESHOLD)
                              ? std::min(shape0.getContactBreakingThreshold(gContactBreakingThreshold),
                                         shape1.getContactBreakingThreshold(gContactBreakingThreshold))
                              : gContactBreakingThreshold;
  return max_breaking_m_ > 0.0 ? std::min(bullet_m, max_breaking_m_) : bullet_m;
}

}  // namespace iapsim::physics::internal
