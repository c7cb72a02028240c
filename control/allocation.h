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

/// What a sub-aircraft's thrust vector Λ_i may be: its magnitude within [min_N, max_N] and at most
/// max_tilt_rad from straight up (−z_W).
struct ThrustLimits {
  double min_N = 0.0;
  double max_N = 0.0;
  double max_tilt_rad = 0.0;
  bool Admits(const Eigen::Vector3d& thrust_W_N) const;
};

/// The parts of a wrench U (in P) in the order graceful allocation gives them up, last first:
/// the force along the vertical (holding altitude against gravity), the torque about P's x and y (roll,
/// pitch), the horizontal force (position), the torque about P's z (yaw).
enum class WrenchPart { kVertical, kRollPitch, kHorizontal, kYaw };
constexpr int kWrenchParts = 4;
/// U's part `part` at the platform attitude R_WP; the four parts sum to U.
Vector6d PartOf(const Vector6d& U_P, const Eigen::Matrix3d& R_WP, WrenchPart part);

/// Allocation within the thrust limits with priorities (issue 23). Least-norm (17) is linear, so B⁺U is
/// the sum of B⁺ of U's parts; taking the parts in priority order, each is scaled by the largest s in
/// [0, 1] (bisection) that keeps every Λ_i within its limits on top of the parts already taken, so a lower
/// part never takes authority from a higher one: yaw is given up first, then the horizontal force, then
/// roll and pitch, and the vertical force last, as PX4's mixer keeps a quadrotor's thrust and attitude
/// before its yaw. (Projecting each Λ_i onto its limits instead changes every part at once: a tilt cut at
/// constant magnitude turns yaw torque into lift.) `kept` (size kWrenchParts) receives each part's s.
/// Λ (3n, in P) may still be outside the limits where the vertical part alone does not fit.
Eigen::VectorXd AllocateWithinLimits(const Allocation& allocation, const Vector6d& U_P,
                                     const Eigen::Matrix3d& R_WP, const std::vector<ThrustLimits>& limits,
                                     double* kept);

/// The wrench U that holds the IAP still at attitude R_WP: U = −G of equation (4), G = [mgRᵀe3; d_0^ mgRᵀe3].
Vector6d HoverWrench(const model::Vehicle& vehicle, const Eigen::Quaterniond& q_WP, double gravity_mps2);

/// Equation (18): the roll and pitch (rad) that point a sub-aircraft's thrust (−z_S) along `thrust_W` with
/// yaw `yaw_rad` (Z-Y-X Euler angles in W). thrust_W must not be zero.
Eigen::Vector2d RollPitchForThrust(const Eigen::Vector3d& thrust_W, double yaw_rad);

/// The attitude R_WS = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Quaterniond AttitudeFromEuler(double roll_rad, double pitch_rad, double yaw_rad);

}  // namespace iapsim::control
