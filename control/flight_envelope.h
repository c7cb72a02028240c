#pragma once
// The flight envelope of one IAP: where and how its reference may go. A pose command from outside (a replayed
// log, a teleoperation topic, a ROS node) outside the envelope is clamped onto it or rejected, and counted;
// a configured trajectory that leaves it is a configuration error. The limits are those a flight operator
// sets on a real vehicle (PX4's geofence GF_*, MPC_XY/Z_VEL_MAX, MPC_TILT_MAX); the defaults keep a
// laboratory-scale IAP within a 200 m box, 10 m/s and 60 degrees.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>

#include "bridge/config.h"
#include "control/trajectory.h"

namespace iapsim::control {

struct FlightEnvelopeConfig {
  Eigen::Vector3d geofence_min_W_m{-100.0, -100.0, -100.0};  // W is NED: z = -100 is 100 m up
  Eigen::Vector3d geofence_max_W_m{100.0, 100.0, 10.0};
  double max_speed_mps = 10.0;  // of the platform's reference
  // of the platform's reference: its z axis from the vertical (a 5-DOF reference: its x axis from the
  // horizontal)
  double max_tilt_rad = 60.0 * M_PI / 180.0;
  enum class Action { kClamp, kReject };
  Action action = Action::kClamp;
};

/// Reads an `envelope` section; every key optional. Throws bridge::ConfigError naming the key and line.
FlightEnvelopeConfig ReadFlightEnvelope(bridge::YamlMap& envelope);

struct EnvelopeCounts {
  uint64_t commands = 0;  // pose commands checked
  uint64_t clamped = 0;
  uint64_t rejected = 0;
  // the commands that broke each limit (one command may break several)
  uint64_t outside_geofence = 0, too_fast = 0, too_tilted = 0;
};

class FlightEnvelope {
 public:
  explicit FlightEnvelope(const FlightEnvelopeConfig& config);

  struct PoseCommand {
    Eigen::Vector3d p_WP_m;
    Eigen::Quaterniond q_WP;
  };
  /// A pose command at t_s (after the previous one admitted): itself when inside the envelope, clamped onto
  /// it (nearest point of the geofence, speed from the previous command cut to the limit, tilt cut to the
  /// limit with the heading kept) or nullopt (rejected: the previous one holds), by the configured action.
  std::optional<PoseCommand> Admit(double t_s, const PoseCommand& command, bool five_dof);

  /// What is wrong with `trajectory` sampled every `dt_s` over [0, duration_s]: the first sample outside
  /// the envelope, described (time and limit); empty when it stays inside.
  std::string Check(const Trajectory& trajectory, double duration_s, double dt_s) const;

  const EnvelopeCounts& counts() const { return counts_; }
  const FlightEnvelopeConfig& config() const { return config_; }

 private:
  FlightEnvelopeConfig config_;
  EnvelopeCounts counts_;
  std::optional<double> last_t_s_;
  Eigen::Vector3d last_p_WP_m_ = Eigen::Vector3d::Zero();
};

}  // namespace iapsim::control
