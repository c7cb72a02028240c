#pragma once
// Model mismatch (issue 19): the physics flies a "true" vehicle drawn around its vehicle file, while
// everything that controls it keeps the file's nominal values: the IAP computer (which reads the file
// itself), and each flight controller's inertia feed-forward, mixer, thrust-to-speed inversion and thrust
// curve. A built vehicle differs from its CAD model and data sheets in exactly this way; the regression
// suite's Monte Carlo mode draws many such vehicles to put error bands on a flight.
//
// Each parameter's error is fixed (a number, or three for a vector: a deliberate mismatch), or drawn per
// part from a normal distribution (`{normal: σ}`, truncated at 3σ) or a uniform one (`{uniform: h}`, on
// [−h, h]). Mass, inertia and the rotor constants take relative errors, true = nominal × (1 + e); the
// platform's centre of mass and the wind take absolute ones. Every quantity has its own seeded stream per
// vehicle, so adding one distribution leaves the draws of the others as they were.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "bridge/config.h"

namespace iapsim::physics {

struct SimulationConfig;

/// The error of one parameter: fixed, or a distribution; per axis for vectors (scalars use x).
struct ParameterError {
  enum class Kind { kNone, kFixed, kNormal, kUniform };
  Kind kind = Kind::kNone;
  Eigen::Vector3d value = Eigen::Vector3d::Zero();  // kFixed: the error; kNormal: σ; kUniform: half-width

  bool active() const { return kind != Kind::kNone; }
};

struct UncertaintyConfig {
  bool enabled = false;
  // relative, one draw per rigid part of a vehicle (its platform, each tool, each sub-aircraft); a mass
  // error scales the part's inertia with it (same shape, denser), `inertia` scales it further
  ParameterError mass;
  ParameterError inertia;
  ParameterError platform_com_P_m;  // absolute, per axis of P: the offset of the platform's centre of mass
  // relative, one draw per sub-aircraft (its rotors alike, one batch of propellers and motors): k_f, k_m,
  // and the motor time constant (the first-order motor's, or the electric drive's up and down alike)
  ParameterError thrust_coefficient;
  ParameterError torque_coefficient;
  ParameterError motor_time_constant;
  ParameterError wind_W_mps;  // absolute, per axis: added to the air's mean wind (needs `air:`)
};

/// One drawn parameter, for the run's report: its name ("<vehicle>/<part>/<parameter>", or "air/wind_W_mps"
/// with an axis) and its value in the vehicle file and in the flight.
struct DrawnParameter {
  std::string name;
  double nominal = 0.0;
  double drawn = 0.0;
};

/// Reads the physics params' `uncertainty:` block (keys mass, inertia, platform_com_P_m, thrust_coefficient,
/// torque_coefficient, motor_time_constant, wind_W_mps). Relative errors must keep every value positive: σ
/// at most 0.3, half-widths and fixed errors above −1 and below 1. Throws bridge::ConfigError.
UncertaintyConfig ReadUncertainty(bridge::YamlMap& map);

/// Draws the true vehicles and wind with `seed` and writes them into `config` (each vehicle's model and
/// rigid-body description; each keeps its file's values as the flight controllers' model); returns what
/// was drawn. Does nothing unless `uncertainty.enabled`.
std::vector<DrawnParameter> DrawTrueModel(const UncertaintyConfig& uncertainty, uint64_t seed,
                                          SimulationConfig* config);

}  // namespace iapsim::physics
