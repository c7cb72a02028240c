#pragma once
// The sliding window's residuals for Ceres, with analytic Jacobians (the layout of VINS-Mono/VINS-Fusion,
// Qin et al., the seed's [52]; the IMU terms of Forster et al. 2017, §VI). Parameter blocks:
//   pose        7: p_WI (3), q_WI as Eigen stores it (x, y, z, w); PoseManifold, tangent [δp, δθ] with
//                  q ← q Exp(δθ) (right perturbation, as in vio/so3.h)
//   speed_bias  9: v_WI_W (3), gyroscope bias (3), accelerometer bias (3)
//   inverse depth 1: λ = 1/z of a feature in the left optical frame of the keyframe that first saw it
//   drift       4: another sub-aircraft's odometry drift (VIRPO): δp_W (3) and δψ, its truth being
//                  Rz(δψ) (x − c) + c + δp for a position x it shares, turned about a centre c near it
//                  (a yaw drift grows where the vehicle is, not about W's origin)
// A pose Jacobian is written "lifted": its first six columns are the derivative with respect to the tangent
// [δp, δθ] and the seventh is zero, and PoseManifold's PlusJacobian is [I₆; 0], so Ceres's product of the
// two is the tangent Jacobian. (The derivative with respect to the quaternion's four coordinates is never
// needed, and this saves forming it.)
//
// Only vio/ includes this header (Ceres is heavy); the estimator's public header hides it.

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>

#include "vio/imu_preintegration.h"
#include "vio/state.h"

namespace iapsim::vio {

constexpr int kPoseSize = 7;
constexpr int kPoseTangentSize = 6;
constexpr int kSpeedBiasSize = 9;
constexpr int kDriftSize = 4;

class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseSize; }
  int TangentSize() const override { return kPoseTangentSize; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

/// The pose block's values as a NavState without velocity, and back.
Eigen::Isometry3d PoseFromBlock(const double* pose);
void PoseToBlock(const Eigen::Isometry3d& X_WI, double* pose);

/// The IMU between keyframes i and j: 15 residuals [r_R, r_v, r_p, r_bg, r_ba] (imu_preintegration.h's
/// first nine, then the bias changes), whitened by the preintegration's covariance and the biases' random
/// walk over Δt. Parameters: pose_i, speed_bias_i, pose_j, speed_bias_j. When the optimiser moves the
/// biases more than a first-order correction can follow, call Repropagate on the preintegration (the
/// estimator does) and build the factor again.
class ImuFactor : public ceres::SizedCostFunction<15, kPoseSize, kSpeedBiasSize, kPoseSize, kSpeedBiasSize> {
 public:
  ImuFactor(std::shared_ptr<const ImuPreintegration> preintegration, const sensors::ImuNoise& noise,
            const Eigen::Vector3d& g_W_mps2);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  std::shared_ptr<const ImuPreintegration> preintegration_;
  Eigen::Vector3d g_W_mps2_;
  Eigen::Matrix<double, 15, 15> sqrt_information_;
};

/// A feature first seen at normalised coordinates `anchor` by camera A of keyframe i (inverse depth λ along
/// A's ray) and observed at `target` by camera T of keyframe j ≠ i: the 2 residuals are the normalised
/// reprojection error, scaled by `sqrt_information` (focal length / pixel sigma, so that a residual of 1 is
/// one standard deviation of pixel noise). X_IA, X_IT place the cameras in the IMU frame (the left eye, or
/// the right one for a stereo observation in another keyframe). Parameters: pose_i, pose_j, λ.
class ReprojectionFactor : public ceres::SizedCostFunction<2, kPoseSize, kPoseSize, 1> {
 public:
  ReprojectionFactor(const Eigen::Vector2d& anchor, const Eigen::Vector2d& target,
                     const Eigen::Isometry3d& X_IA, const Eigen::Isometry3d& X_IT, double sqrt_information);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector3d anchor_ray_;
  Eigen::Vector2d target_;
  Eigen::Isometry3d X_IA_, X_IT_;
  double sqrt_information_;
};

/// The same feature in the right eye of its anchor keyframe: the rig alone relates the two eyes, so the
/// only parameter is λ (the right eye sits `baseline_m` along x of the left). 2 residuals as above.
class StereoFactor : public ceres::SizedCostFunction<2, 1> {
 public:
  StereoFactor(const Eigen::Vector2d& left, const Eigen::Vector2d& right, double baseline_m,
               double sqrt_information);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector3d left_ray_;
  Eigen::Vector2d right_;
  double baseline_m_;
  double sqrt_information_;
};

/// A UWB range from the tag at p_IT (in I) to an anchor at p_WA, taken at t_r after keyframe k: the IMU's
/// state at t_r comes from keyframe k's state and the preintegration from t_k to t_r (Forster's prediction),
/// so a range needs no state of its own whatever its rate. 1 residual: (|p_T(t_r) − p_WA| − d) / σ.
/// Parameters: pose_k, speed_bias_k. (The seed's r_uwb, eq. 22.)
class RangeFactor : public ceres::SizedCostFunction<1, kPoseSize, kSpeedBiasSize> {
 public:
  /// What the factor keeps of the preintegration from t_k to t_r: the deltas and bias Jacobians its
  /// residual reads, inline. A window holds hundreds of ranges (four anchors at 50 Hz over 2-3 s), and a
  /// whole ImuPreintegration each (its samples, its 9×9 covariance) had made their evaluation a fifth of
  /// VIO+UWB's time, mostly in cache misses.
  struct SinceKeyframe {
    explicit SinceKeyframe(const ImuPreintegration& preintegration);
    double dt_s;
    ImuBiases linearisation_biases;
    Eigen::Matrix3d delta_R;
    Eigen::Vector3d delta_p_m;
    Eigen::Matrix3d dR_dbg, dp_dbg, dp_dba;  ///< rows of ∂[δφ, δv, δp]/∂b_g and ∂δp/∂b_a
  };

  RangeFactor(const SinceKeyframe& since_keyframe, const Eigen::Vector3d& p_WA_m, double range_m,
              double sigma_m, const Eigen::Vector3d& p_IT_m, const Eigen::Vector3d& g_W_mps2);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  SinceKeyframe since_keyframe_;
  Eigen::Vector3d p_WA_m_;
  double range_m_;
  double sigma_m_;
  Eigen::Vector3d p_IT_m_;
  Eigen::Vector3d g_W_mps2_;
};

/// A prior on one state (the first of the window, when nothing has been marginalised yet): 15 residuals
/// [p − p₀, Log(R R₀ᵀ), v − v₀, b_g − b_g₀, b_a − b_a₀], each divided by its standard deviation. The rotation
/// error is in W's axes, so that its z sigma is the yaw's. Parameters: pose, speed_bias.
class StatePriorFactor : public ceres::SizedCostFunction<15, kPoseSize, kSpeedBiasSize> {
 public:
  StatePriorFactor(const NavState& state, const ImuBiases& biases, const StatePriorSigmas& sigmas);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  NavState state_;
  ImuBiases biases_;
  Eigen::Matrix<double, 15, 1> inverse_sigma_;
};

// --- VIRPO's physical terms (seed eq. 22, Table IX) ----------------------------------------------------

/// r_kp and r_kv of eq. (22) between this sub-aircraft's spherical joint J_i = p_WI + R_WI p_IJ and another
/// sub-aircraft's joint J_o as that one shares it, corrected for its drift about the centre c:
/// J̃_o = Rz(δψ) (J_o − c) + c + δp. Both
/// joints sit on the rigid platform |d_i − d_o| = L apart (seed §III-A), so |J_i − J̃_o| = L, and their
/// relative velocity ω_P × (J_i − J_o) has no component along the link. 2 residuals:
///   (|Δp| − L) / σ_l   and   (Δv · Δp / L) / (σ_ω L),   Δp = J_i − J̃_o, Δv = v_Ji − Rz(δψ) v_Jo,
/// with v_Ji = v_WI + R_WI ((ω_I − b_g) × p_IJ), ω_I the gyroscope at the frame. σ_ω L turns Table IX's rate
/// sigma into a velocity along the link. Parameters: pose_i, speed_bias_i, drift_o.
class KinematicFactor : public ceres::SizedCostFunction<2, kPoseSize, kSpeedBiasSize, kDriftSize> {
 public:
  KinematicFactor(const Eigen::Vector3d& p_IJ_m, const Eigen::Vector3d& w_I_radps, const PeerJoint& other,
                  const Eigen::Vector3d& drift_centre_W_m, double link_m, double sigma_link_m,
                  double sigma_rate_radps);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector3d p_IJ_m_, w_I_radps_;
  PeerJoint other_;
  Eigen::Vector3d from_centre_m_;  ///< J_o − c
  Eigen::Vector3d drift_centre_W_m_;
  double link_m_, sigma_link_m_, sigma_along_link_mps_;
};

/// r_kq of eq. (22): the tilt of R_WI against a flight controller's attitude estimate R̂_WI (the seed feeds
/// the EKF's, §VI-G, Fig. 18). Only the tilt: the EKF's yaw comes from a heading sensor far worse than
/// vision. 3 residuals (R_WIᵀ e_z − R̂_WIᵀ e_z) / σ_att, the gravity direction seen in I (their norm is the
/// tilt error for small angles). Parameter: pose.
class AttitudeFactor : public ceres::SizedCostFunction<3, kPoseSize> {
 public:
  AttitudeFactor(const Eigen::Quaterniond& q_WI_measured, double sigma_rad);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector3d down_I_measured_;
  double sigma_rad_;
};

/// r_drift of eq. (22): a drift block near a value (zero at the start, with Table IX's prior sigmas; its last
/// estimate afterwards, with the continuous ones). 4 residuals (δp − δp₀)/σ_p, (δψ − δψ₀)/σ_ψ. Parameter:
/// drift.
class DriftPriorFactor : public ceres::SizedCostFunction<kDriftSize, kDriftSize> {
 public:
  DriftPriorFactor(const Eigen::Vector4d& drift, double sigma_position_m, double sigma_yaw_rad);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector4d drift_;
  Eigen::Vector4d inverse_sigma_;
};

}  // namespace iapsim::vio
