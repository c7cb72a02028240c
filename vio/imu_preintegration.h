#pragma once
// IMU preintegration on the manifold (Forster, Carlone, Dellaert, Scaramuzza, "On-Manifold Preintegration for
// Real-Time Visual-Inertial Odometry", IEEE T-RO 33(1), 2017, §V and appendix), with the midpoint rule of
// VINS-Mono (Qin et al., T-RO 34(4), 2018, the seed's [52]) for the mean: between keyframes i and j the
// measurements become one relative-motion measurement (ΔR_ij, Δv_ij, Δp_ij), its 9×9 covariance and its
// first-order Jacobians with respect to the biases, so that the optimiser can move the biases without
// integrating again.
//
// Frames: W is NED with gravity g_W = (0, 0, +g); I is the IMU frame. The IMU reads the specific force
// f_I = R_WIᵀ (a_W − g_W) and the angular velocity ω_I (sensors/imu.h). Then, with Δt = t_j − t_i,
//   R_j = R_i ΔR_ij,  v_j = v_i + g_W Δt + R_i Δv_ij,  p_j = p_i + v_i Δt + ½ g_W Δt² + R_i Δp_ij.
// Errors are on the right: ΔR = ΔR̄ Exp(δφ), Δv = Δv̄ + δv, Δp = Δp̄ + δp, ordered [δφ, δv, δp].

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <deque>
#include <utility>
#include <vector>

#include "sensors/imu.h"
#include "vio/state.h"

namespace iapsim::vio {

/// A relative motion (ΔR, Δv, Δp) in the frame of I at t_i.
struct ImuDelta {
  Eigen::Matrix3d delta_R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d delta_v_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d delta_p_m = Eigen::Vector3d::Zero();
};

using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix93d = Eigen::Matrix<double, 9, 3>;

/// Timed IMU samples (t in s, increasing).
using ImuSamples = std::deque<std::pair<double, sensors::ImuSample>>;
/// The sample at t: interpolated linearly between the two around it, the first before them, the last held
/// after them (an image between two samples, or after the last one). `samples` must not be empty.
sensors::ImuSample InterpolatedSample(const ImuSamples& samples, double t);

class ImuPreintegration {
 public:
  /// Starts at the sample `first` (taken at t_i), linearised about `biases`, with the IMU's continuous-time
  /// noise densities (only the white-noise densities enter here; the random walks belong to the bias factor).
  ImuPreintegration(const sensors::ImuSample& first, const ImuBiases& biases, const sensors::ImuNoise& noise);

  /// Adds the interval from the previous sample to `sample`, taken dt_s > 0 later: ω̄ = ½(ω_k + ω_{k+1}) −
  /// b_g, ΔR_{k+1} = ΔR_k Exp(ω̄ dt), ā = ½(ΔR_k (f_k − b_a) + ΔR_{k+1} (f_{k+1} − b_a)), Δp_{k+1} = Δp_k +
  /// Δv_k dt + ½ ā dt², Δv_{k+1} = Δv_k + ā dt. The covariance takes the interval's noise as one draw of the
  /// densities over dt (σ²/dt per axis), which gives the continuous-time growth however the samples are
  /// spaced.
  void Integrate(double dt_s, const sensors::ImuSample& sample);
  /// Integrates every stored sample again about `biases` (when the optimiser moved them too far for the
  /// first-order correction).
  void Repropagate(const ImuBiases& biases);

  double dt_s() const { return dt_s_; }
  const ImuBiases& linearisation_biases() const { return biases_; }
  const ImuDelta& delta() const { return delta_; }
  /// Covariance of [δφ, δv, δp].
  const Matrix9d& covariance() const { return covariance_; }
  /// ∂[δφ, δv, δp]/∂b_g and ∂[δφ, δv, δp]/∂b_a at the linearisation biases (the δφ rows of ∂/∂b_a are zero).
  const Matrix93d& jacobian_gyroscope_bias() const { return d_delta_d_bg_; }
  const Matrix93d& jacobian_accelerometer_bias() const { return d_delta_d_ba_; }

  /// The deltas for other biases to first order: ΔR̄ Exp(J^R_g δb_g), Δv̄ + J^v_g δb_g + J^v_a δb_a, and so on.
  ImuDelta Corrected(const ImuBiases& biases) const;
  /// The state at t_j from the state at t_i and the biases over the interval.
  NavState Predict(const NavState& state_i, const ImuBiases& biases, const Eigen::Vector3d& g_W_mps2) const;
  /// [r_R, r_v, r_p]: r_R = Log(ΔR(b)ᵀ R_iᵀ R_j), r_v = R_iᵀ (v_j − v_i − g Δt) − Δv(b),
  /// r_p = R_iᵀ (p_j − p_i − v_i Δt − ½ g Δt²) − Δp(b). Zero when the states agree with the measurement.
  Vector9d Residual(const NavState& state_i, const NavState& state_j, const ImuBiases& biases,
                    const Eigen::Vector3d& g_W_mps2) const;

 private:
  struct Interval {
    double dt_s;
    sensors::ImuSample sample;
  };
  void Reset(const ImuBiases& biases);
  void Propagate(double dt_s, const sensors::ImuSample& previous, const sensors::ImuSample& sample);

  sensors::ImuSample first_;
  sensors::ImuNoise noise_;
  std::vector<Interval> intervals_;
  ImuBiases biases_;
  double dt_s_ = 0.0;
  ImuDelta delta_;
  Matrix9d covariance_ = Matrix9d::Zero();
  Matrix93d d_delta_d_bg_ = Matrix93d::Zero();
  Matrix93d d_delta_d_ba_ = Matrix93d::Zero();
};

}  // namespace iapsim::vio
