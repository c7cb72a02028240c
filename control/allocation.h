#pragma once
// Control allocation of the seed paper §IV-A: the mapping matrix B of equation (6), the rank test (8) that
// tells fully- from under-actuated IAPs, the least-norm allocation Λ = B⁺U of (17) through the full-rank
// decomposition B = XY, and the decomposition (18) of a thrust vector into roll and pitch for a given yaw.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "model/vehicle.h"

namespace iapsim::control {

using Vector6d = Eigen::Matrix<double, 6, 1>;

class Allocation {
 public:
  /// B from the joint positions d_i in P (equation (6)).
  explicit Allocation(const std::vector<Eigen::Vector3d>& joints_P_m);
  explicit Allocation(const model::Vehicle& vehicle);

  const Eigen::MatrixXd& B() const { return B_; }
  int rank() const { return rank_; }
  /// rank B = 6; otherwise the joints are collinear (8) and rank B = 5.
  bool fully_actuated() const { return rank_ == 6; }
  const Eigen::MatrixXd& B_pinv() const { return B_pinv_; }

  /// Λ = B⁺U (17): the least-norm thrust vectors (3n, in P) for the wrench U (in P, about P's origin).
  Eigen::VectorXd Allocate(const Vector6d& U) const { return B_pinv_ * U; }

 private:
  Eigen::MatrixXd B_;
  Eigen::MatrixXd B_pinv_;
  int rank_ = 0;
};

/// The wrench U that holds the IAP still at attitude R_WP: U = −G of equation (4), G = [mgRᵀe3; d_0^ mgRᵀe3].
Vector6d HoverWrench(const model::Vehicle& vehicle, const Eigen::Quaterniond& q_WP, double gravity_mps2);

/// Equation (18): the roll and pitch (rad) that point a sub-aircraft's thrust (−z_S) along `thrust_W` with
/// yaw `yaw_rad` (Z-Y-X Euler angles in W). thrust_W must not be zero.
Eigen::Vector2d RollPitchForThrust(const Eigen::Vector3d& thrust_W, double yaw_rad);

/// The attitude R_WS = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Quaterniond AttitudeFromEuler(double roll_rad, double pitch_rad, double yaw_rad);

}  // namespace iapsim::control
