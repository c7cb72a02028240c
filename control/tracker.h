#pragma once
// The IAP trajectory trackers of the seed paper §IV-A: the fully-actuated law (10) (after Lee et al. [14])
// and, for IAPs whose joints are collinear (8), the under-actuated law (16) that tracks the position and the
// direction r = R e1 of the platform's x axis on S². Both compute the wrench U on the platform (in P, about
// its origin) that the allocation (17) turns into sub-aircraft thrust vectors.
//
// The model terms are those of equation (4): M = diag(m I, J) with J about P's origin (equation (3)),
// C = diag((mω)^, −(Jω)^), G = [mg Rᵀe3; d_0^ mg Rᵀe3].

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "control/allocation.h"
#include "control/trajectory.h"
#include "model/vehicle.h"

namespace iapsim::control {

/// Where the position part of k^I ∫e_T dt integrates.
enum class PositionIntegralFrame {
  /// (10) as the seed writes it: ∫ R_0ᵀ(p − p̄) dt, the errors in P summed. What it has learnt (a wind, a
  /// weight the model lacks) turns with the platform, so a platform that yaws (or rolls) away from where it
  /// learnt it pushes sideways until the integral catches up: in a steady wind, the error across the wind
  /// follows the yaw.
  kPlatform,
  /// ∫ (p − p̄) dt in W, turned into P when applied: the integral holds a disturbance that is fixed in W (a
  /// wind, a mass error) whatever the platform's attitude, as a multirotor's position loop usually does (PX4
  /// integrates its velocity error in NED).
  kWorld,
};

/// Diagonal gains per axis, ordered x, y, z (position, in P) then roll, pitch, yaw (attitude, about P's
/// axes). Defaults: the seed's Table II, used for every IAP in the paper.
struct TrackerGains {
  Vector6d kp = (Vector6d() << 8, 8, 8, 8, 5, 6).finished();       // N/m, N·m/rad
  Vector6d ki = (Vector6d() << 1, 1, 1, 1, 1, 1).finished();       // N/(m·s), N·m/(rad·s); position: per W
                                                                   // axis with kWorld
  Vector6d kd = (Vector6d() << 10, 10, 5, 10, 10, 15).finished();  // N/(m/s), N·m/(rad/s)
  /// Anti-windup: |∫e_T dt| per axis is held within these bounds (m·s, rad·s).
  Vector6d integral_limit = (Vector6d() << 5, 5, 5, 1, 1, 1).finished();
  PositionIntegralFrame position_integral_frame = PositionIntegralFrame::kPlatform;
};

/// The platform's measured state: pose in W and twist in P (the frame of equation (4)).
struct PlatformState {
  Eigen::Vector3d p_WP_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_WP = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_WP_P_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_WP_P_radps = Eigen::Vector3d::Zero();
};

/// Errors of the last update, for logs and plots.
struct TrackingError {
  Vector6d e_T = Vector6d::Zero();   // pose error (position in P, attitude error vector)
  Vector6d e_xi = Vector6d::Zero();  // twist error ξ − ξ̄
};

class Tracker {
 public:
  /// Picks the law from the rank of B (test (8)).
  Tracker(const model::Vehicle& vehicle, const TrackerGains& gains, double gravity_mps2);

  bool fully_actuated() const { return allocation_.fully_actuated(); }
  const Allocation& allocation() const { return allocation_; }
  /// r_0 of (11): the tracked body axis of an under-actuated IAP, along its joint line.
  const Eigen::Vector3d& tracked_axis_P() const { return line_P_; }

  /// U (in P, about P's origin) for the reference at this instant. `external_wrench_P` is F_e of (10), the
  /// measured or estimated contact wrench on the platform (zero in free flight). `integrate` false holds
  /// the integral (conditional integration while the allocation saturates). Inputs must be finite.
  Vector6d Update(const PoseReference& reference, const PlatformState& state,
                  const Vector6d& external_wrench_P, double dt_s, bool integrate);

  const TrackingError& error() const { return error_; }
  /// ∫e_T dt: its position part in P, or in W with PositionIntegralFrame::kWorld.
  const Vector6d& integral() const { return integral_; }
  void Reset() { integral_.setZero(); }

 private:
  Allocation allocation_;
  TrackerGains gains_;
  double mass_kg_;
  Eigen::Matrix3d J_P_kgm2_;
  Eigen::Vector3d d_0_P_m_;
  Eigen::Vector3d line_P_ = Eigen::Vector3d::UnitX();         // r_0: the joint line (under-actuated IAPs)
  Eigen::Vector3d line_point_P_m_ = Eigen::Vector3d::Zero();  // a point of the joint line
  double gravity_mps2_;
  Vector6d integral_ = Vector6d::Zero();
  TrackingError error_;
};

}  // namespace iapsim::control
