#pragma once
// Wind at a vehicle: a mean wind plus Dryden turbulence, and the quadratic drag of the air on a body.
//
// Turbulence: the Dryden model of MIL-F-8785C §3.7 (the low-altitude form MIL-HDBK-1797 keeps, and the one
// MATLAB's Aerospace Blockset implements as "Dryden Wind Turbulence Model (Continuous)"). The gust velocity
// (u along the mean wind's horizontal direction, v across it, w down) is frozen turbulence carried past the
// vehicle at the airspeed V; with ω the temporal frequency in rad/s, the one-sided spectra are
//   Φ_u(ω) = σ_u² (2 L_u / (π V)) / (1 + (L_u ω / V)²)
//   Φ_v(ω) = σ_v² (L_v / (π V)) (1 + 3 (L_v ω / V)²) / (1 + (L_v ω / V)²)²      (Φ_w: w for v)
// each integrating to σ². Low altitude (h < 1000 ft, h in ft, clamped to at least 10 ft as the handbook's
// curves start there): L_w = h, L_u = L_v = h / (0.177 + 0.000823 h)^1.2, σ_w = 0.1 W20,
// σ_u = σ_v = σ_w / (0.177 + 0.000823 h)^0.4, with W20 the wind speed at 20 ft (light 15 kt, moderate 30 kt,
// severe 45 kt).
//
// Each component is white noise through its forming filter, discretised exactly (the filter's state
// transition and the covariance of the noise it integrates over a step, by Van Loan's method), so the
// spectrum holds for any step and any change of V between steps.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <random>

namespace iapsim::physics {

struct DrydenScales {
  double length_u_m = 0.0, length_v_m = 0.0, length_w_m = 0.0;
  double sigma_u_mps = 0.0, sigma_v_mps = 0.0, sigma_w_mps = 0.0;
};

/// The low-altitude scales and intensities at `height_m` above ground for a wind of `w20_mps` at 20 ft.
DrydenScales LowAltitudeDryden(double height_m, double w20_mps);

/// The one-sided spectra above (m²/s² per rad/s) at ω for airspeed V.
double DrydenSpectrumU(const DrydenScales& scales, double airspeed_mps, double omega_rad_s);
double DrydenSpectrumV(const DrydenScales& scales, double airspeed_mps, double omega_rad_s);
double DrydenSpectrumW(const DrydenScales& scales, double airspeed_mps, double omega_rad_s);

/// One point's turbulence: (u, v, w) in the mean-wind frame, seeded.
class DrydenTurbulence {
 public:
  explicit DrydenTurbulence(uint64_t seed);
  /// Advances by `dt_s` through turbulence of `scales` passing at `airspeed_mps` (> 0) and returns (u, v, w).
  Eigen::Vector3d Step(const DrydenScales& scales, double airspeed_mps, double dt_s);

 private:
  // a forming filter's discrete form for one time constant and step
  struct Discrete {
    double time_constant_s = -1.0, dt_s = -1.0;
    Eigen::Matrix2d transition = Eigen::Matrix2d::Zero();
    Eigen::Matrix2d noise_factor = Eigen::Matrix2d::Zero();  // lower Cholesky factor of the step's noise
  };
  double Normal();
  static void Update(Discrete* filter, int order, double time_constant_s, double dt_s);

  std::mt19937_64 random_;
  Discrete filter_u_, filter_v_, filter_w_;
  Eigen::Vector2d state_u_ = Eigen::Vector2d::Zero(), state_v_ = Eigen::Vector2d::Zero(),
                  state_w_ = Eigen::Vector2d::Zero();
  bool started_ = false;
};

/// A discrete gust: the "1 − cosine" shape of MIL-F-8785C §3.7.4 (MIL-HDBK-1797 keeps it), in time rather
/// than distance since a hovering rotorcraft travels no distance through the air: from `start_s` the gust
/// rises as A/2 (1 − cos(π t / rise_s)) to its amplitude A, holds it for `hold_s`, and falls back the same
/// way. With hold_s = 0 it is the single 1 − cos pulse of the gust load requirements (CS-25.341, FAR 25.341),
/// with rise_s = H / V for a gradient distance H passed at V.
struct DiscreteGust {
  double start_s = 0.0;
  double rise_s = 1.0;
  double hold_s = 0.0;
  Eigen::Vector3d amplitude_W_mps = Eigen::Vector3d::Zero();  // NED
};

/// The gust's velocity at time `t_s`, in W.
Eigen::Vector3d GustVelocity_W(const DiscreteGust& gust, double t_s);

/// The air's force on a body moving at `v_body_W` in wind `wind_W`, both in W, with orientation q_WB: in body
/// axes F_i = ½ ρ (C_d·A)_i |v_air| v_air,i, v_air = wind − v_body: the drag equation (Hoerner, Fluid-Dynamic
/// Drag, 1965) with a drag area per body axis, so a flat frame can be draggier from above than edge-on.
/// Returned in W.
Eigen::Vector3d DragForce_W(const Eigen::Vector3d& drag_area_B_m2, double density_kgpm3,
                            const Eigen::Quaterniond& q_WB, const Eigen::Vector3d& v_body_W_mps,
                            const Eigen::Vector3d& wind_W_mps);

}  // namespace iapsim::physics
