#pragma once
// A reference that arrives as pose commands over time instead of a known trajectory: a replayed command log
// (the seed's three-square flight replays a real flight's recorded pose commands, §VI-B) or a live
// teleoperation topic. Each command holds until the next. What the tracker flies is chosen by the shaping:
// - second_order (the default): the commands through the reference shaper (control/reference_shaper.h),
//   rate- and acceleration-limited with exact derivatives, starting from where the IAP held before the
//   first command;
// - none: the last command itself. Nothing tells the velocity a pilot meant, so it is estimated from
//   successive commands: their finite difference through a first-order low-pass, which keeps the tracker's
//   feed-forward from jumping at every sample, and the acceleration likewise from the filtered velocity.
//   The angular acceleration is left zero. (A step in the commands still reaches the tracker as a step.)

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "control/reference_shaper.h"
#include "control/trajectory.h"

namespace iapsim::control {

struct ReferenceShaping {
  enum class Type { kNone, kSecondOrder };
  Type type = Type::kSecondOrder;
  double velocity_time_constant_s = 0.1;  // kNone: of the low-pass on the estimated derivatives (0: none)
  ReferenceShaperConfig second_order;     // kSecondOrder
};

/// How far the flown reference was from the raw command, over the control updates since the first command.
struct ReferenceLag {
  double max_m = 0.0, rms_m = 0.0;      // position
  double max_deg = 0.0, rms_deg = 0.0;  // attitude: the angle of R̄ᵀ R_cmd
};

class CommandedPoseReference {
 public:
  /// Throws std::invalid_argument for shaper settings out of range (ReferenceShaper).
  explicit CommandedPoseReference(const ReferenceShaping& shaping);

  /// A pose command at time t_s. Returns false (and ignores it) when it is not finite, its quaternion is
  /// not a rotation, or it is not later than the previous command.
  bool Add(double t_s, const Eigen::Vector3d& p_WP_m, const Eigen::Quaterniond& q_WP, bool five_dof);

  bool empty() const { return !last_t_s_; }
  /// The last command, with the velocity, acceleration and rate estimated from successive commands. Only
  /// when !empty().
  const PoseReference& command() const { return command_; }

  /// The reference to fly at this control update, dt_s after the previous one. Only when !empty();
  /// `start` is where the IAP held before the first command (the shaper starts there, at rest).
  PoseReference Update(const PoseReference& start, double dt_s);

  ReferenceLag lag() const;

 private:
  ReferenceShaping shaping_;
  std::optional<double> last_t_s_;
  PoseReference command_;
  std::optional<ReferenceShaper> shaper_;  // second order; starts at the first Update
  // lag statistics
  uint64_t updates_ = 0;
  double lag_max_m_ = 0.0, lag_sum_sq_m2_ = 0.0, lag_max_rad_ = 0.0, lag_sum_sq_rad2_ = 0.0;
};

}  // namespace iapsim::control
