#include "physics/internal/collision_configuration.h"

#include <BulletCollision/BroadphaseCollision/btCollisionAlgorithm.h>
#include <BulletCollision/BroadphaseCollision/btDispatcher.h>
#include <BulletCollision/CollisionDispatch/btCollisionDispatcher.h>
#include <BulletCollision/CollisionDispatch/btCollisionObjectWrapper.h>
#include <BulletCollision/CollisionDispatch/btConvexConvexAlgorithm.h>
#include <BulletCollision/CollisionDispatch/btManifoldResult.h>
#include <BulletCollision/CollisionShapes/btCollisionShape.h>
#include <BulletCollision/NarrowPhaseCollision/btPersistentManifold.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

namespace iapsim::physics::internal {
namespace {

Eigen::Vector3d Eig(const btVector3& v) { return Eigen::Vector3d(v.x(), v.y(), v.z()); }

Eigen::Matrix3d Eig(const btMatrix3x3& m) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r) out.row(r) = Eig(m.getRow(r)).transpose();
  return out;
}

// A shape's box in its own frame (Bullet's local bounds, margin included), placed in W.
struct OrientedBox {
  Eigen::Vector3d center_W;
  Eigen::Matrix3d R_WB;
  Eigen::Vector3d half_m;
};

OrientedBox BoxOf(const btCollisionObjectWrapper& object) {
  const btCollisionShape* shape = object.getCollisionShape();
  const btTransform& X_WS = object.getWorldTransform();
  const Eigen::Matrix3d R_WS = Eig(X_WS.getBasis());
  const Eigen::Vector3d p_WS = Eig(X_WS.getOrigin());
  OrientedBox box;
  if (const auto* principal = static_cast<const ShapeBox*>(shape->getUserPointer())) {
    box.R_WB = R_WS * principal->R_SB;
    box.center_W = p_WS + R_WS * principal->center_S;
    box.half_m = principal->half_m;
    return box;
  }
  btTransform identity;
  identity.setIdentity();
  btVector3 min, max;
  shape->getAabb(identity, min, max);
  box.R_WB = R_WS;
  box.center_W = p_WS + R_WS * Eig(0.5 * (min + max));
  box.half_m = Eig(0.5 * (max - min));
  return box;
}

// GJK only for pairs whose boxes are within the distance at which Bullet keeps contact points: beyond it
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
    // the distance within which the manifold keeps points (btCollisionDispatcher::getNewManifold): the
    // smaller of the two bodies' (their whole shapes', compounds included), or Bullet's global one
    const btCollisionShape* shape0 = body0->getCollisionObject()->getCollisionShape();
    const btCollisionShape* shape1 = body1->getCollisionObject()->getCollisionShape();
    const bool relative = static_cast<btCollisionDispatcher*>(m_dispatcher)->getDispatcherFlags() &
                          btCollisionDispatcher::CD_USE_RELATIVE_CONTACT_BREAKING_THRESHOLD;
    const double gap_m = (relative ? std::min(shape0->getContactBreakingThreshold(gContactBreakingThreshold),
                                              shape1->getContactBreakingThreshold(gContactBreakingThreshold))
                                   : gContactBreakingThreshold) +
                         result->m_closestPointDistanceThreshold;
    const OrientedBox a = BoxOf(*body0);
    const OrientedBox b = BoxOf(*body1);
    if (!OrientedBoxesApart(a.center_W, a.R_WB, a.half_m, b.center_W, b.R_WB, b.half_m, gap_m)) {
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

  void getAllContactManifolds(btManifoldArray& manifolds) override { gjk_->getAllContactManifolds(manifolds); }

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

bool OrientedBoxesApart(const Eigen::Vector3d& center_a_W, const Eigen::Matrix3d& R_WA,
                        const Eigen::Vector3d& half_a_m, const Eigen::Vector3d& center_b_W,
                        const Eigen::Matrix3d& R_WB, const Eigen::Vector3d& half_b_m, double gap_m) {
  // in A's frame: B's rotation R and centre t; a box grown by gap_m on every side stands for "within gap_m"
  const Eigen::Matrix3d R = R_WA.transpose() * R_WB;
  const Eigen::Vector3d t = R_WA.transpose() * (center_b_W - center_a_W);
  const Eigen::Vector3d a = half_a_m.array() + gap_m;
  const Eigen::Vector3d& b = half_b_m;
  // |R| plus a little, so that near-parallel edges (a cross product close to zero) never separate wrongly
  const Eigen::Matrix3d abs_R = R.cwiseAbs().array() + 1e-9;
  for (int i = 0; i < 3; ++i) {  // A's faces
    if (std::abs(t[i]) > a[i] + b.dot(abs_R.row(i))) return true;
  }
  for (int j = 0; j < 3; ++j) {  // B's faces
    if (std::abs(t.dot(R.col(j))) > a.dot(abs_R.col(j)) + b[j]) return true;
  }
  for (int i = 0; i < 3; ++i) {  // edge pairs: A's axis i x B's axis j
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const double ra = a[i1] * abs_R(i2, j) + a[i2] * abs_R(i1, j);
      const double rb = b[j1] * abs_R(i, j2) + b[j2] * abs_R(i, j1);
      if (std::abs(t[i2] * R(i1, j) - t[i1] * R(i2, j)) > ra + rb) return true;
    }
  }
  return false;
}

CollisionConfiguration::CollisionConfiguration()
    : culled_convex_create_func_(new CulledConvexCreateFunc(m_convexConvexCreateFunc)) {}

CollisionConfiguration::~CollisionConfiguration() { delete culled_convex_create_func_; }

btCollisionAlgorithmCreateFunc* CollisionConfiguration::getCollisionAlgorithmCreateFunc(int proxy_type_0,
                                                                                       int proxy_type_1) {
  btCollisionAlgorithmCreateFunc* bullet =
      btDefaultCollisionConfiguration::getCollisionAlgorithmCreateFunc(proxy_type_0, proxy_type_1);
  return bullet == m_convexConvexCreateFunc ? culled_convex_create_func_ : bullet;
}

}  // namespace iapsim::physics::internal
