#pragma once
// The IAP computer of the seed's Fig. 3 / §IV-A: tracker (10) or (16) -> allocation (17) within the
// sub-aircraft's thrust limits, giving up yaw, then position, then attitude before altitude (issue 23) ->
// per sub-aircraft collective thrust and attitude by (18), which the simulated flight controllers execute.
// Bus-free: the control process, tests and RL drive it in-process.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "control/tracker.h"
#include "model/vehicle.h"

namespace iapsim::control {

/// The yaw ψ_i each sub-aircraft is commanded, which (18) needs to turn a thrust vector into roll and pitch.
enum class SubAircraftYaw {
  kReference,  // the reference's platform yaw + the sub-aircraft's initial yaw (seed §VI-D)
  kPlatform,   // the measured platform yaw + the initial yaw
};

struct IapControllerConfig {
  TrackerGains gains;
  double gravity_mps2 = 9.81;
  /// Thrust vectors are limited to this share of the rotors' maximum collective thrust, leaving the
  /// flight controller room for its attitude loop.
  double max_thrust_fraction = 0.9;
  /// Largest tilt of a sub-aircraft's thrust from the vertical (18 needs |roll|, |pitch| < 90°).
  double max_tilt_rad = 60.0 * M_PI / 180.0;
  SubAircraftYaw sub_aircraft_yaw = SubAircraftYaw::kReference;
};

/// What one sub-aircraft is told: collective thrust along −z_S and attitude R_WS.
struct AttitudeCommand {
  double thrust_N = 0.0;
  Eigen::Quaterniond q_WS = Eigen::Quaterniond::Identity();
};

struct ControlOutput {
  std::vector<AttitudeCommand> sub_aircraft;
  Vector6d wrench_P = Vector6d::Zero();                       // U asked by the tracker (P, about P's origin)
  Eigen::VectorXd thrusts_P_N;                                // Λ after the limits, 3n, in P
  bool saturated = false;                                     // some of U was given up to fit the limits
  std::array<double, kWrenchParts> kept{1.0, 1.0, 1.0, 1.0};  // of each WrenchPart, the share realised
};

class IapController {
 public:
  IapController(const model::Vehicle& vehicle, const IapControllerConfig& config);

  /// One control step. Non-finite inputs are rejected: counted, the last safe output kept (the level
  /// hover before any), and false returned; the integral is not touched.
  bool Update(const PoseReference& reference, const PlatformState& state, const Vector6d& external_wrench_P,
              double dt_s);

  const ControlOutput& output() const { return output_; }
  const Tracker& tracker() const { return tracker_; }
  void ResetIntegral() { tracker_.Reset(); }
  uint64_t rejected_updates() const { return rejected_; }
  uint64_t saturated_updates() const { return saturated_; }
  /// Per WrenchPart, the updates where graceful allocation gave up some of it.
  const std::array<uint64_t, kWrenchParts>& part_cut_updates() const { return part_cuts_; }

 private:
  /// Λ_i (in W) onto its limits (where even the vertical part alone does not fit); returns whether it was
  /// cut.
  bool Limit(int i, Eigen::Vector3d* thrust_W_N) const;
  void Command(const Eigen::Matrix3d& R_WP, double platform_yaw_rad, const Eigen::VectorXd& thrusts_P_N);

  model::Vehicle vehicle_;
  IapControllerConfig config_;
  Tracker tracker_;
  ControlOutput output_;
  uint64_t rejected_ = 0;
  uint64_t saturated_ = 0;
  std::vector<ThrustLimits> limits_;  // per sub-aircraft
  std::array<uint64_t, kWrenchParts> part_cuts_{};
};

/// ZYX yaw of a rotation (atan2 of R e1's horizontal part).
double YawOf(const Eigen::Matrix3d& R);

}  // namespace iapsim::control
