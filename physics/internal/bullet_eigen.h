#pragma once
// Conversions between Bullet's (double-precision) math types and Eigen's, for the physics library's own
// sources: no public header includes Bullet.

#include <LinearMath/btMatrix3x3.h>
#include <LinearMath/btQuaternion.h>
#include <LinearMath/btVector3.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace iapsim::physics::internal {

static_assert(sizeof(btScalar) == sizeof(double), "iapsim needs Bullet's double-precision build");

inline btVector3 Bt(const Eigen::Vector3d& v) { return btVector3(v.x(), v.y(), v.z()); }
inline btQuaternion Bt(const Eigen::Quaterniond& q) { return btQuaternion(q.x(), q.y(), q.z(), q.w()); }
inline btMatrix3x3 BtMatrix(const Eigen::Matrix3d& R) {
  return btMatrix3x3(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2));
}
inline Eigen::Vector3d Eig(const btVector3& v) { return Eigen::Vector3d(v.x(), v.y(), v.z()); }
inline Eigen::Quaterniond Eig(const btQuaternion& q) {
  return Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z());
}
// row-major into Eigen
inline Eigen::Matrix3d Eig(const btMatrix3x3& m) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r) out.row(r) = Eig(m.getRow(r)).transpose();
  return out;
}

}  // namespace iapsim::physics::internal
