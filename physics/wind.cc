#include "physics/wind.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <unsupported/Eigen/MatrixFunctions>

#include "physics/random.h"

namespace iapsim::physics {
namespace {

constexpr double kFeetPerMetre = 1.0 / 0.3048;
// the forming filters' input: white noise of one-sided spectrum 1 per rad/s, i.e. intensity π
constexpr double kNoiseIntensity = M_PI;

}  // namespace

DrydenScales LowAltitudeDryden(double height_m, double w20_mps) {
  const double h_ft = std::max(height_m * kFeetPerMetre, 10.0);
  const double factor = 0.177 + 0.000823 * h_ft;
  DrydenScales scales;
  scales.length_w_m = h_ft / kFeetPerMetre;
  scales.length_u_m = h_ft / std::pow(factor, 1.2) / kFeetPerMetre;
  scales.length_v_m = scales.length_u_m;
  scales.sigma_w_mps = 0.1 * w20_mps;
  scales.sigma_u_mps = scales.sigma_w_mps / std::pow(factor, 0.4);
  scales.sigma_v_mps = scales.sigma_u_mps;
  return scales;
}

double DrydenSpectrumU(const DrydenScales& s, double airspeed_mps, double omega_rad_s) {
  const double x = s.length_u_m * omega_rad_s / airspeed_mps;
  return s.sigma_u_mps * s.sigma_u_mps * 2.0 * s.length_u_m / (M_PI * airspeed_mps) / (1.0 + x * x);
}

namespace {
double TransverseSpectrum(double sigma_mps, double length_m, double airspeed_mps, double omega_rad_s) {
  const double x = length_m * omega_rad_s / airspeed_mps;
  return sigma_mps * sigma_mps * length_m / (M_PI * airspeed_mps) * (1.0 + 3.0 * x * x) /
         ((1.0 + x * x) * (1.0 + x * x));
}
}  // namespace

double DrydenSpectrumV(const DrydenScales& s, double airspeed_mps, double omega_rad_s) {
  return TransverseSpectrum(s.sigma_v_mps, s.length_v_m, airspeed_mps, omega_rad_s);
}

double DrydenSpectrumW(const DrydenScales& s, double airspeed_mps, double omega_rad_s) {
  return TransverseSpectrum(s.sigma_w_mps, s.length_w_m, airspeed_mps, omega_rad_s);
}

DrydenTurbulence::DrydenTurbulence(uint64_t seed) : random_(seed) {}

double DrydenTurbulence::Normal() { return StandardNormal(random_); }

// Order 1: x' = −x/T + n. Order 2: x1' = x2, x2' = −x1/T² − 2 x2/T + n (the denominator (1 + T s)²). The
// state is kept divided by its stationary standard deviation (order 1: sqrt(qT/2); order 2: sqrt(qT³/4) and
// sqrt(qT/4), uncorrelated), so that when the airspeed, and with it T, changes, the gusts keep their
// intensity instead of jumping with the state's units.
void DrydenTurbulence::Update(Discrete* filter, int order, double time_constant_s, double dt_s) {
  // the airspeed, and with it T, changes a little every step: a filter is discretised again (three 4 x 4
  // matrix exponentials a step otherwise) only when T moved by more than 1 %, a 1 % shift of the spectrum
  if (filter->dt_s == dt_s &&
      std::abs(time_constant_s - filter->time_constant_s) <= 0.01 * filter->time_constant_s) {
    return;
  }
  filter->time_constant_s = time_constant_s;
  filter->dt_s = dt_s;
  const double T = time_constant_s, q = kNoiseIntensity;
  Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
  Eigen::Matrix2d G = Eigen::Matrix2d::Zero();  // B q Bᵀ
  Eigen::Vector2d scale;                        // the states' stationary standard deviations
  if (order == 1) {
    A(0, 0) = -1.0 / T;
    A(1, 1) = -1.0;  // an unused, decoupled state keeps the 2 x 2 algebra
    G(0, 0) = q;
    scale << std::sqrt(q * T / 2.0), 1.0;
  } else {
    A << 0.0, 1.0, -1.0 / (T * T), -2.0 / T;
    G(1, 1) = q;
    scale << std::sqrt(q * T * T * T / 4.0), std::sqrt(q * T / 4.0);
  }
  // Van Loan (1978): exp([[−A, G], [0, Aᵀ]] dt) = [[·, F⁻¹Q], [0, Fᵀ]]
  Eigen::Matrix4d M = Eigen::Matrix4d::Zero();
  M.topLeftCorner<2, 2>() = -A * dt_s;
  M.topRightCorner<2, 2>() = G * dt_s;
  M.bottomRightCorner<2, 2>() = A.transpose() * dt_s;
  const Eigen::Matrix4d E = M.exp();
  const Eigen::Matrix2d F = E.bottomRightCorner<2, 2>().transpose();
  Eigen::Matrix2d Q = F * E.topRightCorner<2, 2>();
  const Eigen::Matrix2d to_unit = scale.cwiseInverse().asDiagonal();
  filter->transition = to_unit * F * scale.asDiagonal();
  Q = to_unit * (0.5 * (Q + Q.transpose())) * to_unit;
  if (order == 1) Q(1, 1) = Q(0, 1) = Q(1, 0) = 0.0;
  // lower Cholesky factor; Q is positive semi-definite, so clamp rounding below zero
  Eigen::Matrix2d L = Eigen::Matrix2d::Zero();
  L(0, 0) = std::sqrt(std::max(Q(0, 0), 0.0));
  L(1, 0) = L(0, 0) > 0.0 ? Q(1, 0) / L(0, 0) : 0.0;
  L(1, 1) = std::sqrt(std::max(Q(1, 1) - L(1, 0) * L(1, 0), 0.0));
  filter->noise_factor = L;
}

Eigen::Vector3d DrydenTurbulence::Step(const DrydenScales& s, double airspeed_mps, double dt_s) {
  const double V = airspeed_mps;
  if (!started_) {  // the stationary state: no start-up transient
    // one draw per statement: the order of a constructor's arguments is unspecified, and a seeded run
    // must repeat to the bit with any compiler
    for (Eigen::Vector2d* state : {&state_u_, &state_v_, &state_w_}) {
      (*state)(0) = Normal();
      (*state)(1) = state == &state_u_ ? 0.0 : Normal();
    }
    started_ = true;
  } else {
    Update(&filter_u_, 1, s.length_u_m / V, dt_s);
    Update(&filter_v_, 2, s.length_v_m / V, dt_s);
    Update(&filter_w_, 2, s.length_w_m / V, dt_s);
    for (auto [state, filter] : {std::pair{&state_u_, &filter_u_}, std::pair{&state_v_, &filter_v_},
                                 std::pair{&state_w_, &filter_w_}}) {
      Eigen::Vector2d noise;
      noise(0) = Normal();
      noise(1) = Normal();
      *state = filter->transition * *state + filter->noise_factor * noise;
    }
  }
  // the outputs in the normalised states: H_u = σ_u sqrt(2 L_u/(πV)) / (1 + T s) gives σ_u z;
  // H_v = σ_v sqrt(L_v/(πV)) (1 + √3 T s) / (1 + T s)² gives σ_v (z1 + √3 z2) / 2
  return Eigen::Vector3d(s.sigma_u_mps * state_u_(0),
                         0.5 * s.sigma_v_mps * (state_v_(0) + std::sqrt(3.0) * state_v_(1)),
                         0.5 * s.sigma_w_mps * (state_w_(0) + std::sqrt(3.0) * state_w_(1)));
}

Eigen::Vector3d GustVelocity_W(const DiscreteGust& gust, double t_s) {
  const double t = t_s - gust.start_s;
  const double fall_s = gust.rise_s + gust.hold_s;
  double shape = 0.0;
  if (t <= 0.0 || t >= fall_s + gust.rise_s) {
    shape = 0.0;
  } else if (t < gust.rise_s) {
    shape = 0.5 * (1.0 - std::cos(M_PI * t / gust.rise_s));
  } else if (t <= fall_s) {
    shape = 1.0;
  } else {
    shape = 0.5 * (1.0 + std::cos(M_PI * (t - fall_s) / gust.rise_s));
  }
  return shape * gust.amplitude_W_mps;
}

Eigen::Vector3d DragForce_W(const Eigen::Vector3d& drag_area_B_m2, double density_kgpm3,
                            const Eigen::Quaterniond& q_WB, const Eigen::Vector3d& v_body_W_mps,
                            const Eigen::Vector3d& wind_W_mps) {
  const Eigen::Vector3d v_air_B = q_WB.conjugate() * (wind_W_mps - v_body_W_mps);
  const Eigen::Vector3d force_B = 0.5 * density_kgpm3 * v_air_B.norm() * drag_area_B_m2.cwiseProduct(v_air_B);
  return q_WB * force_B;
}

}  // namespace iapsim::physics
