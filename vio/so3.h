#pragma once
// SO(3) on Eigen: the hat map, Exp and Log, and the right Jacobian with its inverse, as in Forster et al.,
// "On-Manifold Preintegration for Real-Time Visual-Inertial Odometry", IEEE T-RO 33(1), 2017, eqs. (3), (4),
// (8) and (9). Perturbations in vio/ are on the right: R = R̄ Exp(δφ), δφ in the body frame.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace iapsim::vio {

/// [v]×: the matrix with [v]× u = v × u.
Eigen::Matrix3d Skew(const Eigen::Vector3d& v);
/// Exp(φ) = the rotation by |φ| about φ/|φ| (Rodrigues), exact near φ = 0.
Eigen::Matrix3d Exp(const Eigen::Vector3d& phi);
Eigen::Quaterniond ExpQuaternion(const Eigen::Vector3d& phi);
/// Log(R), the rotation vector of angle in [0, π].
Eigen::Vector3d Log(const Eigen::Matrix3d& R);
Eigen::Vector3d Log(const Eigen::Quaterniond& q);
/// J_r(φ): Exp(φ + δφ) ≈ Exp(φ) Exp(J_r(φ) δφ).
Eigen::Matrix3d RightJacobian(const Eigen::Vector3d& phi);
/// J_r⁻¹(φ): Log(Exp(φ) Exp(δφ)) ≈ φ + J_r⁻¹(φ) δφ.
Eigen::Matrix3d RightJacobianInverse(const Eigen::Vector3d& phi);

}  // namespace iapsim::vio
