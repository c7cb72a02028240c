#include "control/flight_envelope.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace iapsim::control {
namespace {

constexpr double kDegrees = 180.0 / M_PI;

// The axis whose tilt is limited, and its angle: z from the vertical (down, NED), or for a 5-DOF
// reference x from the horizontal.
double Tilt_rad(const Eigen::Quaterniond& q_WP, bool five_dof) {
  const Eigen::Matrix3d R = q_WP.toRotationMatrix();
  if (five_dof) return std::asin(std::clamp(std::abs(R(2, 0)), 0.0, 1.0));
  return std::acos(std::clamp(R(2, 2), -1.0, 1.0));
}

// The smallest rotation that brings the tilt down to `max_rad` (so the heading is kept).
Eigen::Quaterniond ClampTilt(const Eigen::Quaterniond& q_WP, bool five_dof, double max_rad) {
  const Eigen::Matrix3d R = q_WP.toRotationMatrix();
  const Eigen::Vector3d axis = five_dof ? Eigen::Vector3d(R.col(0)) : Eigen::Vector3d(R.col(2));
  Eigen::Vector3d horizontal(axis.x(), axis.y(), 0.0);
  if (horizontal.norm() < 1e-9) horizontal = R.col(0);  // straight up or down: tilt toward the body x
  horizontal.z() = 0.0;
  horizontal.normalize();
  const Eigen::Vector3d vertical(0.0, 0.0, axis.z() >= 0.0 ? 1.0 : -1.0);
  // z: max_rad from the vertical; 5-DOF x: max_rad from the horizontal, on the side it pointed
  const Eigen::Vector3d target =
      five_dof
          ? Eigen::Vector3d(std::cos(max_rad) * horizontal + std::sin(max_rad) * vertical)
          : Eigen::Vector3d(std::sin(max_rad) * horizontal + std::cos(max_rad) * Eigen::Vector3d::UnitZ());
  return (Eigen::Quaterniond::FromTwoVectors(axis, target) * q_WP).normalized();
}

std::string Vector(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  return s.str();
}

}  // namespace

FlightEnvelopeConfig ReadFlightEnvelope(bridge::YamlMap& envelope) {
  FlightEnvelopeConfig config;
  const auto read_corner = [&](const std::string& key, Eigen::Vector3d* corner) {
    if (!envelope.Has(key)) return;
    const std::vector<double> values = bridge::ReadNumberList(envelope, key, {3});
    *corner = Eigen::Vector3d(values[0], values[1], values[2]);
  };
  read_corner("geofence_min_m", &config.geofence_min_W_m);
  read_corner("geofence_max_m", &config.geofence_max_W_m);
  if (!(config.geofence_min_W_m.array() < config.geofence_max_W_m.array()).all()) {
    envelope.Fail("geofence_max_m",
                  "must exceed geofence_min_m " + Vector(config.geofence_min_W_m) + " in x, y and z");
  }
  envelope.OptionalInRange("max_speed_mps", &config.max_speed_mps, 1e-3, 1e3);
  double max_tilt_deg = config.max_tilt_rad * kDegrees;
  envelope.OptionalInRange("max_tilt_deg", &max_tilt_deg, 1.0, 90.0);
  config.max_tilt_rad = max_tilt_deg / kDegrees;
  std::string action = "clamp";
  envelope.OptionalChoice("action", &action, {"clamp", "reject"});
  config.action =
      action == "clamp" ? FlightEnvelopeConfig::Action::kClamp : FlightEnvelopeConfig::Action::kReject;
  return config;
}

FlightEnvelope::FlightEnvelope(const FlightEnvelopeConfig& config) : config_(config) {}

std::optional<FlightEnvelope::PoseCommand> FlightEnvelope::Admit(double t_s, const PoseCommand& command,
                                                                 bool five_dof) {
  ++counts_.commands;
  PoseCommand admitted = command;
  const Eigen::Vector3d inside =
      command.p_WP_m.cwiseMax(config_.geofence_min_W_m).cwiseMin(config_.geofence_max_W_m);
  const bool outside = inside != command.p_WP_m;
  admitted.p_WP_m = inside;
  bool too_fast = false;
  if (last_t_s_ && t_s > *last_t_s_) {
    const Eigen::Vector3d step = admitted.p_WP_m - last_p_WP_m_;
    const double reach_m = config_.max_speed_mps * (t_s - *last_t_s_);
    if (step.norm() > reach_m) {
      too_fast = true;
      admitted.p_WP_m = last_p_WP_m_ + step * (reach_m / step.norm());
    }
  }
  const bool too_tilted = Tilt_rad(command.q_WP, five_dof) > config_.max_tilt_rad + 1e-9;
  if (too_tilted) admitted.q_WP = ClampTilt(command.q_WP, five_dof, config_.max_tilt_rad);
  counts_.outside_geofence += outside;
  counts_.too_fast += too_fast;
  counts_.too_tilted += too_tilted;
  if (outside || too_fast || too_tilted) {
    if (config_.action == FlightEnvelopeConfig::Action::kReject) {
      ++counts_.rejected;
      return std::nullopt;
    }
    ++counts_.clamped;
  }
  last_t_s_ = t_s;
  last_p_WP_m_ = admitted.p_WP_m;
  return admitted;
}

std::string FlightEnvelope::Check(const Trajectory& trajectory, double duration_s, double dt_s) const {
  const auto steps = static_cast<int64_t>(std::floor(duration_s / dt_s + 1e-9));
  for (int64_t k = 0; k <= steps; ++k) {
    const double t_s = static_cast<double>(k) * dt_s;
    const PoseReference r = trajectory.Sample(t_s);
    std::ostringstream why;
    why << "leaves the flight envelope at t = " << t_s << " s: ";
    if ((r.p_WP_m.array() < config_.geofence_min_W_m.array()).any() ||
        (r.p_WP_m.array() > config_.geofence_max_W_m.array()).any()) {
      why << "position " << Vector(r.p_WP_m) << " m is outside the geofence "
          << Vector(config_.geofence_min_W_m) << " .. " << Vector(config_.geofence_max_W_m) << " m";
      return why.str();
    }
    if (r.v_WP_W_mps.norm() > config_.max_speed_mps + 1e-9) {
      why << "speed " << r.v_WP_W_mps.norm() << " m/s exceeds max_speed_mps " << config_.max_speed_mps;
      return why.str();
    }
    if (const double tilt = Tilt_rad(r.q_WP, r.five_dof); tilt > config_.max_tilt_rad + 1e-9) {
      why << "tilt " << tilt * kDegrees << " deg exceeds max_tilt_deg " << config_.max_tilt_rad * kDegrees;
      return why.str();
    }
  }
  return "";
}

}  // namespace iapsim::control
