#include "vio/so3.h"

#include <cmath>

namespace iapsim::vio {
namespace {
// Below this angle the closed forms lose precision to cancellation; their Taylor series take over.
constexpr double kSmallAngle_rad = 1e-6;
}  // namespace

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Matrix3d Exp(const Eigen::Vector3d& phi) { return ExpQuaternion(phi).toRotationMatrix(); }

Eigen::Quaterniond ExpQuaternion(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < kSmallAngle_rad) {
    const Eigen::Vector3d half = 0.5 * phi;
    return Eigen::Quaterniond(1.0, half.x(), half.y(), half.z()).normalized();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle));
}

Eigen::Vector3d Log(const Eigen::Matrix3d& R) { return Log(Eigen::Quaterniond(R)); }

Eigen::Vector3d Log(const Eigen::Quaterniond& q_in) {
  // q and −q are the same rotation: take w ≥ 0 so that the angle is in [0, π].
  const Eigen::Quaterniond q = q_in.w() < 0.0 ? Eigen::Quaterniond(-q_in.coeffs()) : q_in;
  const double sin_half = q.vec().norm();
  if (sin_half < 0.5 * kSmallAngle_rad) return 2.0 * q.vec() / q.w();
  const double angle = 2.0 * std::atan2(sin_half, q.w());
  return angle / sin_half * q.vec();
}

Eigen::Matrix3d RightJacobian(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  const Eigen::Matrix3d phi_x = Skew(phi);
  if (angle < kSmallAngle_rad) return Eigen::Matrix3d::Identity() - 0.5 * phi_x;
  const double angle2 = angle * angle;
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(angle)) / angle2 * phi_x +
         (angle - std::sin(angle)) / (angle2 * angle) * phi_x * phi_x;
}

Eigen::Matrix3d RightJacobianInverse(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  const Eigen::Matrix3d phi_x = Skew(phi);
  if (angle < kSmallAngle_rad) return Eigen::Matrix3d::Identity() + 0.5 * phi_x;
  const double angle2 = angle * angle;
  return Eigen::Matrix3d::Identity() + 0.5 * phi_x +
         (1.0 / angle2 - (1.0 + std::cos(angle)) / (2.0 * angle * std::sin(angle))) * phi_x * phi_x;
}

}  // namespace iapsim::vio
