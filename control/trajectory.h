#pragma once
// Reference trajectories for the IAP trackers (seed §IV-A, §VI-A..D): the nominal platform pose p̄, R̄ and
// its derivatives at any time. Every source gives velocities and accelerations that are the exact time
// derivatives of its position and attitude, because the trackers (10) and (16) feed them forward.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>

#include "bridge/config.h"

namespace iapsim::control {

/// The nominal platform motion at one instant. Positions and linear derivatives in W (NED); the angular
/// rate ω̄ = (R̄ᵀ dR̄/dt)^∨ and its derivative in the nominal platform frame (FRD), as in equation (10).
struct PoseReference {
  Eigen::Vector3d p_WP_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_WP_W_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_WP_W_mps2 = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_WP = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_WP_P_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d dw_WP_P_radps2 = Eigen::Vector3d::Zero();
  /// True for 5-DOF references (§VI-D): only the position and the x axis R̄e1 are meant, the roll about
  /// x is free. Fully-actuated trackers follow the whole attitude anyway.
  bool five_dof = false;
};

/// A reference as ZYX Euler angles (roll φ, pitch θ, yaw ψ; R = Rz(ψ)Ry(θ)Rx(φ)) and their first two time
/// derivatives, converted to the attitude, ω̄ and dω̄/dt of a PoseReference.
PoseReference ReferenceFromEuler(const Eigen::Vector3d& p_WP_m, const Eigen::Vector3d& v_WP_W_mps,
                                 const Eigen::Vector3d& a_WP_W_mps2, const Eigen::Vector3d& rpy_rad,
                                 const Eigen::Vector3d& rpy_rate_radps, const Eigen::Vector3d& rpy_accel_radps2);

/// A reference over time t (s from the start of the flight). Before 0 and after duration_s() it holds the
/// pose at the nearest end, at rest.
class Trajectory {
 public:
  virtual ~Trajectory() = default;
  virtual PoseReference Sample(double t_s) const = 0;
  virtual double duration_s() const = 0;
};

/// Reads a trajectory section (`type:` waypoints | poses | spiral | circle | figure_eight | file, see the
/// README) from a scenario. Relative file names resolve against `scenario_file`'s folder, then the working
/// folder. Throws bridge::ConfigError naming the file, key and line.
std::unique_ptr<Trajectory> ReadTrajectory(bridge::YamlMap& params, const std::string& scenario_file);

}  // namespace iapsim::control
