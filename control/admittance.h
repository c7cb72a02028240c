#pragma once
// The admittance outer loop of the seed's §IV-B: per axis, M_e ë + D_e ė + K_e e = F_e^w (19), with
// e = [p̄_r − p̄; γ̄_r − γ̄] (20) the offset of the revised pose command from the nominal one (position in W,
// ZYX Euler angles roll, pitch, yaw) and F_e^w the (filtered) external wrench on the platform in W. The
// baseline tracker then follows the revised command, so the platform yields to contact like the
// mass-damper-spring instead of fighting it.

#include <Eigen/Core>
#include <cstdint>

#include "control/allocation.h"
#include "control/trajectory.h"

namespace iapsim::control {

/// Diagonal admittance per axis x, y, z (W) then roll, pitch, yaw (Euler angles). Defaults: the seed's
/// Table IV (soft in pitch for the peg-in-hole of §VI-E).
struct AdmittanceConfig {
  Vector6d mass = Vector6d::Ones();                                              // kg, kg·m²/rad
  Vector6d damping = (Vector6d() << 28.28, 28.28, 28.28, 28.28, 14.14, 28.28).finished();  // N·s/m, N·m·s/rad
  Vector6d stiffness = (Vector6d() << 100, 100, 100, 100, 25, 100).finished();   // N/m, N·m/rad
  /// |e| per axis is held within these, so a contact spike cannot throw the command away.
  double max_offset_m = 0.3;
  double max_offset_rad = 30.0 * M_PI / 180.0;
};

class Admittance {
 public:
  /// dt_s: the fixed step between updates (> 0); masses positive, damping and stiffness non-negative.
  /// Throws std::invalid_argument otherwise.
  Admittance(const AdmittanceConfig& config, double dt_s);

  /// Advances the offsets one step with `wrench_W` (force N then torque N·m, both in W) held over it, and
  /// returns `nominal` revised by them, with the offsets' rates and accelerations added to its velocity,
  /// acceleration, ω̄ and dω̄/dt. A non-finite wrench is rejected (counted) and the offsets kept.
  PoseReference Update(const PoseReference& nominal, const Vector6d& wrench_W);

  /// e, ė, ë after the last update (m, rad and their rates).
  const Vector6d& offset() const { return offset_; }
  const Vector6d& offset_rate() const { return offset_rate_; }
  const Vector6d& offset_accel() const { return offset_accel_; }
  /// Updates where an offset reached its limit and was held there.
  uint64_t saturated_updates() const { return saturated_; }
  uint64_t rejected_updates() const { return rejected_; }
  void Reset();

 private:
  AdmittanceConfig config_;
  Vector6d offset_limit_;
  // per axis, the exact map of (e, ė) over one step with the input held: x ← Φx + Γu
  Eigen::Matrix<double, 6, 4> Phi_;  // row i: Φ of axis i, row-major (Φ00, Φ01, Φ10, Φ11)
  Eigen::Matrix<double, 6, 2> Gamma_;
  Vector6d offset_ = Vector6d::Zero();
  Vector6d offset_rate_ = Vector6d::Zero();
  Vector6d offset_accel_ = Vector6d::Zero();
  uint64_t saturated_ = 0;
  uint64_t rejected_ = 0;
};

/// ZYX Euler angles (roll, pitch, yaw) of an attitude and their first two rates from ω and dω/dt in the
/// body frame (the inverse of ReferenceFromEuler's map; singular at pitch ±90°).
void EulerFromReference(const PoseReference& reference, Eigen::Vector3d* rpy_rad, Eigen::Vector3d* rpy_rate_radps,
                        Eigen::Vector3d* rpy_accel_radps2);

}  // namespace iapsim::control
