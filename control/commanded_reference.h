#pragma once
// A reference that arrives as pose commands over time instead of a known trajectory: a replayed command log
// (the seed's three-square flight replays a real flight's recorded pose commands, §VI-B) or a live
// teleoperation topic. Each command holds until the next. Nothing tells the velocity a pilot meant, so it
// is estimated from successive commands: their finite difference through a first-order low-pass, which
// keeps the tracker's feed-forward from jumping at every sample, and the acceleration likewise from the
// filtered velocity. The angular acceleration is left zero.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>

#include "control/trajectory.h"

namespace iapsim::control {

class CommandedPoseReference {
 public:
  /// `velocity_time_constant_s`: of the low-pass on the finite-difference velocity, acceleration and rate
  /// (0: none).
  explicit CommandedPoseReference(double velocity_time_constant_s) : tau_s_(velocity_time_constant_s) {}

  /// A pose command at time t_s. Returns false (and ignores it) when it is not finite, its quaternion is
  /// not a rotation, or it is not later than the previous command.
  bool Add(double t_s, const Eigen::Vector3d& p_WP_m, const Eigen::Quaterniond& q_WP, bool five_dof);

  bool empty() const { return !last_t_s_; }
  /// The reference now: the last command, with the estimated velocity and rate. Only when !empty().
  const PoseReference& current() const { return reference_; }

 private:
  double tau_s_;
  std::optional<double> last_t_s_;
  PoseReference reference_;
};

}  // namespace iapsim::control
