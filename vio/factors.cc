#include "vio/factors.h"

#include <algorithm>
#include <stdexcept>

#include "vio/so3.h"

namespace iapsim::vio {
namespace {

template <int Rows, int Cols>
using RowMajorMap = Eigen::Map<Eigen::Matrix<double, Rows, Cols, Eigen::RowMajor>>;

Eigen::Vector3d Position(const double* pose) { return Eigen::Vector3d(pose[0], pose[1], pose[2]); }
Eigen::Quaterniond Rotation(const double* pose) {
  return Eigen::Quaterniond(pose[6], pose[3], pose[4], pose[5]);
}

// d(x/z, y/z)/dP at P, times the whitening.
Eigen::Matrix<double, 2, 3> ProjectionJacobian(const Eigen::Vector3d& P, double sqrt_information) {
  Eigen::Matrix<double, 2, 3> J;
  const double inv_z = 1.0 / P.z();
  J << inv_z, 0.0, -P.x() * inv_z * inv_z, 0.0, inv_z, -P.y() * inv_z * inv_z;
  return sqrt_information * J;
}

}  // namespace

bool PoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Vector3d p = Position(x) + Eigen::Vector3d(delta[0], delta[1], delta[2]);
  const Eigen::Quaterniond q =
      (Rotation(x) * ExpQuaternion(Eigen::Vector3d(delta[3], delta[4], delta[5]))).normalized();
  Eigen::Map<Eigen::Vector3d>{x_plus_delta} = p;
  Eigen::Map<Eigen::Vector4d>{x_plus_delta + 3} = q.coeffs();
  return true;
}

bool PoseManifold::PlusJacobian(const double*, double* jacobian) const {
  RowMajorMap<kPoseSize, kPoseTangentSize> J(jacobian);
  J.setZero();
  J.topRows<kPoseTangentSize>().setIdentity();
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  Eigen::Map<Eigen::Vector3d>{y_minus_x} = Position(y) - Position(x);
  Eigen::Map<Eigen::Vector3d>{y_minus_x + 3} = Log(Eigen::Quaterniond(Rotation(x).conjugate() * Rotation(y)));
  return true;
}

bool PoseManifold::MinusJacobian(const double*, double* jacobian) const {
  RowMajorMap<kPoseTangentSize, kPoseSize> J(jacobian);
  J.setZero();
  J.leftCols<kPoseTangentSize>().setIdentity();
  return true;
}

Eigen::Isometry3d PoseFromBlock(const double* pose) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Rotation(pose).normalized().toRotationMatrix();
  X.translation() = Position(pose);
  return X;
}

void PoseToBlock(const Eigen::Isometry3d& X_WI, double* pose) {
  Eigen::Map<Eigen::Vector3d>{pose} = X_WI.translation();
  Eigen::Map<Eigen::Vector4d>{pose + 3} = Eigen::Quaterniond(X_WI.linear()).normalized().coeffs();
}

ImuFactor::ImuFactor(std::shared_ptr<const ImuPreintegration> preintegration, const sensors::ImuNoise& noise,
                     const Eigen::Vector3d& g_W_mps2)
    : preintegration_(std::move(preintegration)), g_W_mps2_(g_W_mps2) {
  Eigen::Matrix<double, 15, 15> covariance = Eigen::Matrix<double, 15, 15>::Zero();
  covariance.topLeftCorner<9, 9>() = preintegration_->covariance();
  const double dt = preintegration_->dt_s();
  covariance.block<3, 3>(9, 9).diagonal().setConstant(noise.gyroscope_random_walk *
                                                      noise.gyroscope_random_walk * dt);
  covariance.block<3, 3>(12, 12).diagonal().setConstant(noise.accelerometer_random_walk *
                                                        noise.accelerometer_random_walk * dt);
  // Whitening W with Wᵀ W = Σ⁻¹: for Σ = L Lᵀ (Cholesky), W = L⁻¹.
  const Eigen::LLT<Eigen::Matrix<double, 15, 15>> cholesky(covariance);
  if (!covariance.allFinite() || cholesky.info() != Eigen::Success) {
    throw std::invalid_argument(
        "IMU factor: the preintegrated covariance is not positive definite (every noise density and random "
        "walk "
        "must be > 0, and the interval longer than 0)");
  }
  sqrt_information_ = cholesky.matrixL().solve(Eigen::Matrix<double, 15, 15>::Identity());
}

bool ImuFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const ImuPreintegration& pre = *preintegration_;
  const NavState state_i{Position(parameters[0]), Rotation(parameters[0]), Eigen::Vector3d(parameters[1])};
  const NavState state_j{Position(parameters[2]), Rotation(parameters[2]), Eigen::Vector3d(parameters[3])};
  const ImuBiases biases_i{Eigen::Vector3d(parameters[1] + 3), Eigen::Vector3d(parameters[1] + 6)};
  const Eigen::Vector3d bg_j(parameters[3] + 3), ba_j(parameters[3] + 6);

  Eigen::Matrix<double, 15, 1> r;
  r.head<9>() = pre.Residual(state_i, state_j, biases_i, g_W_mps2_);
  r.segment<3>(9) = bg_j - biases_i.gyroscope_radps;
  r.tail<3>() = ba_j - biases_i.accelerometer_mps2;
  Eigen::Map<Eigen::Matrix<double, 15, 1>>{residuals} = sqrt_information_ * r;
  if (jacobians == nullptr) return true;

  const double dt = pre.dt_s();
  const Eigen::Matrix3d R_i = state_i.q_WI.toRotationMatrix(), R_j = state_j.q_WI.toRotationMatrix();
  const Eigen::Matrix3d R_iT = R_i.transpose();
  const Eigen::Vector3d r_R = r.head<3>();
  const Eigen::Matrix3d Jr_inv = RightJacobianInverse(r_R);
  const Eigen::Vector3d y_v = R_iT * (state_j.v_WI_W_mps - state_i.v_WI_W_mps - g_W_mps2_ * dt);
  const Eigen::Vector3d y_p =
      R_iT * (state_j.p_WI_m - state_i.p_WI_m - state_i.v_WI_W_mps * dt - 0.5 * g_W_mps2_ * dt * dt);
  const Matrix93d& J_bg = pre.jacobian_gyroscope_bias();
  const Matrix93d& J_ba = pre.jacobian_accelerometer_bias();
  const Eigen::Vector3d d_bg = biases_i.gyroscope_radps - pre.linearisation_biases().gyroscope_radps;
  const Eigen::Matrix3d J_R_bg = J_bg.topRows<3>();

  if (jacobians[0] != nullptr) {
    Eigen::Matrix<double, 15, kPoseSize> J = Eigen::Matrix<double, 15, kPoseSize>::Zero();
    J.block<3, 3>(0, 3) = -Jr_inv * R_j.transpose() * R_i;
    J.block<3, 3>(3, 3) = Skew(y_v);
    J.block<3, 3>(6, 0) = -R_iT;
    J.block<3, 3>(6, 3) = Skew(y_p);
    RowMajorMap<15, kPoseSize>{jacobians[0]} = sqrt_information_ * J;
  }
  if (jacobians[1] != nullptr) {
    Eigen::Matrix<double, 15, kSpeedBiasSize> J = Eigen::Matrix<double, 15, kSpeedBiasSize>::Zero();
    J.block<3, 3>(0, 3) = -Jr_inv * Exp(r_R).transpose() * RightJacobian(J_R_bg * d_bg) * J_R_bg;
    J.block<3, 3>(3, 0) = -R_iT;
    J.block<3, 3>(3, 3) = -J_bg.middleRows<3>(3);
    J.block<3, 3>(3, 6) = -J_ba.middleRows<3>(3);
    J.block<3, 3>(6, 0) = -R_iT * dt;
    J.block<3, 3>(6, 3) = -J_bg.bottomRows<3>();
    J.block<3, 3>(6, 6) = -J_ba.bottomRows<3>();
    J.block<3, 3>(9, 3) = -Eigen::Matrix3d::Identity();
    J.block<3, 3>(12, 6) = -Eigen::Matrix3d::Identity();
    RowMajorMap<15, kSpeedBiasSize>{jacobians[1]} = sqrt_information_ * J;
  }
  if (jacobians[2] != nullptr) {
    Eigen::Matrix<double, 15, kPoseSize> J = Eigen::Matrix<double, 15, kPoseSize>::Zero();
    J.block<3, 3>(0, 3) = Jr_inv;
    J.block<3, 3>(6, 0) = R_iT;
    RowMajorMap<15, kPoseSize>{jacobians[2]} = sqrt_information_ * J;
  }
  if (jacobians[3] != nullptr) {
    Eigen::Matrix<double, 15, kSpeedBiasSize> J = Eigen::Matrix<double, 15, kSpeedBiasSize>::Zero();
    J.block<3, 3>(3, 0) = R_iT;
    J.block<3, 3>(9, 3) = Eigen::Matrix3d::Identity();
    J.block<3, 3>(12, 6) = Eigen::Matrix3d::Identity();
    RowMajorMap<15, kSpeedBiasSize>{jacobians[3]} = sqrt_information_ * J;
  }
  return true;
}

ReprojectionFactor::ReprojectionFactor(const Eigen::Vector2d& anchor, const Eigen::Vector2d& target,
                                       const Eigen::Isometry3d& X_IA, const Eigen::Isometry3d& X_IT,
                                       double sqrt_information)
    : anchor_ray_(anchor.x(), anchor.y(), 1.0),
      target_(target),
      X_IA_(X_IA),
      X_IT_(X_IT),
      sqrt_information_(sqrt_information) {}

bool ReprojectionFactor::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const Eigen::Matrix3d R_i = Rotation(parameters[0]).toRotationMatrix();
  const Eigen::Matrix3d R_j = Rotation(parameters[1]).toRotationMatrix();
  const Eigen::Vector3d p_i = Position(parameters[0]), p_j = Position(parameters[1]);
  const double inverse_depth = parameters[2][0];

  const Eigen::Vector3d P_A = anchor_ray_ / inverse_depth;
  const Eigen::Vector3d P_Ii = X_IA_ * P_A;
  const Eigen::Vector3d P_W = R_i * P_Ii + p_i;
  const Eigen::Vector3d P_Ij = R_j.transpose() * (P_W - p_j);
  const Eigen::Vector3d P_T = X_IT_.inverse() * P_Ij;
  Eigen::Map<Eigen::Vector2d>{residuals} = sqrt_information_ * (P_T.head<2>() / P_T.z() - target_);
  if (jacobians == nullptr) return true;

  const Eigen::Matrix<double, 2, 3> reduce = ProjectionJacobian(P_T, sqrt_information_);
  const Eigen::Matrix3d R_TI_R_jW = X_IT_.linear().transpose() * R_j.transpose();
  if (jacobians[0] != nullptr) {
    RowMajorMap<2, kPoseSize> J(jacobians[0]);
    J.setZero();
    J.leftCols<3>() = reduce * R_TI_R_jW;
    J.middleCols<3>(3) = reduce * R_TI_R_jW * R_i * -Skew(P_Ii);
  }
  if (jacobians[1] != nullptr) {
    RowMajorMap<2, kPoseSize> J(jacobians[1]);
    J.setZero();
    J.leftCols<3>() = -reduce * R_TI_R_jW;
    J.middleCols<3>(3) = reduce * X_IT_.linear().transpose() * Skew(P_Ij);
  }
  if (jacobians[2] != nullptr) {
    Eigen::Map<Eigen::Vector2d>{jacobians[2]} =
        reduce * R_TI_R_jW * R_i * X_IA_.linear() * (-anchor_ray_ / (inverse_depth * inverse_depth));
  }
  return true;
}

StereoFactor::StereoFactor(const Eigen::Vector2d& left, const Eigen::Vector2d& right, double baseline_m,
                           double sqrt_information)
    : left_ray_(left.x(), left.y(), 1.0),
      right_(right),
      baseline_m_(baseline_m),
      sqrt_information_(sqrt_information) {}

bool StereoFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double inverse_depth = parameters[0][0];
  const Eigen::Vector3d P_R = left_ray_ / inverse_depth - Eigen::Vector3d(baseline_m_, 0.0, 0.0);
  Eigen::Map<Eigen::Vector2d>{residuals} = sqrt_information_ * (P_R.head<2>() / P_R.z() - right_);
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Vector2d>{jacobians[0]} =
        ProjectionJacobian(P_R, sqrt_information_) * (-left_ray_ / (inverse_depth * inverse_depth));
  }
  return true;
}

RangeFactor::SinceKeyframe::SinceKeyframe(const ImuPreintegration& preintegration)
    : dt_s(preintegration.dt_s()),
      linearisation_biases(preintegration.linearisation_biases()),
      delta_R(preintegration.delta().delta_R),
      delta_p_m(preintegration.delta().delta_p_m),
      dR_dbg(preintegration.jacobian_gyroscope_bias().topRows<3>()),
      dp_dbg(preintegration.jacobian_gyroscope_bias().bottomRows<3>()),
      dp_dba(preintegration.jacobian_accelerometer_bias().bottomRows<3>()) {}

RangeFactor::RangeFactor(const SinceKeyframe& since_keyframe, const Eigen::Vector3d& p_WA_m, double range_m,
                         double sigma_m, const Eigen::Vector3d& p_IT_m, const Eigen::Vector3d& g_W_mps2)
    : since_keyframe_(since_keyframe),
      p_WA_m_(p_WA_m),
      range_m_(range_m),
      sigma_m_(sigma_m),
      p_IT_m_(p_IT_m),
      g_W_mps2_(g_W_mps2) {
  if (!(sigma_m > 0.0)) throw std::invalid_argument("range factor: sigma_m must be > 0");
}

bool RangeFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const SinceKeyframe& pre = since_keyframe_;
  const Eigen::Matrix3d R_k = Rotation(parameters[0]).toRotationMatrix();
  const Eigen::Vector3d v_k(parameters[1]);
  // The preintegration's first-order bias correction (ImuPreintegration::Corrected), of ΔR and Δp only.
  const Eigen::Vector3d d_bg = Eigen::Vector3d(parameters[1] + 3) - pre.linearisation_biases.gyroscope_radps;
  const Eigen::Vector3d d_ba =
      Eigen::Vector3d(parameters[1] + 6) - pre.linearisation_biases.accelerometer_mps2;
  const Eigen::Vector3d dR_correction = pre.dR_dbg * d_bg;
  const Eigen::Matrix3d delta_R = pre.delta_R * Exp(dR_correction);
  const Eigen::Vector3d delta_p = pre.delta_p_m + pre.dp_dbg * d_bg + pre.dp_dba * d_ba;
  const double dt = pre.dt_s;
  const Eigen::Vector3d lever_k = delta_p + delta_R * p_IT_m_;  // the tag from p_k, in I at t_k
  const Eigen::Vector3d p_T = Position(parameters[0]) + v_k * dt + 0.5 * g_W_mps2_ * dt * dt + R_k * lever_k;
  const Eigen::Vector3d to_anchor = p_T - p_WA_m_;
  const double distance = to_anchor.norm();
  residuals[0] = (distance - range_m_) / sigma_m_;
  if (jacobians == nullptr) return true;
  // d r / d p_T, then the chain through p_T's terms (right perturbations, as in ImuFactor).
  const Eigen::RowVector3d dr_dp = to_anchor.transpose() / (std::max(distance, 1e-9) * sigma_m_);
  const Eigen::RowVector3d dr_dp_k = dr_dp * R_k;
  if (jacobians[0] != nullptr) {
    RowMajorMap<1, kPoseSize> J(jacobians[0]);
    J.setZero();
    J.leftCols<3>() = dr_dp;
    J.middleCols<3>(3) = dr_dp_k * -Skew(lever_k);
  }
  if (jacobians[1] != nullptr) {
    // ΔR(b) p_IT = ΔR̄ Exp(J_R_bg δb_g) p_IT: its derivative is −ΔR(b) [p_IT]× J_r(J_R_bg δb_g) J_R_bg.
    const Eigen::Matrix3d d_lever_d_bg =
        pre.dp_dbg - delta_R * Skew(p_IT_m_) * RightJacobian(dR_correction) * pre.dR_dbg;
    RowMajorMap<1, kSpeedBiasSize> J(jacobians[1]);
    J.leftCols<3>() = dr_dp * dt;
    J.middleCols<3>(3) = dr_dp_k * d_lever_d_bg;
    J.rightCols<3>() = dr_dp_k * pre.dp_dba;
  }
  return true;
}

StatePriorFactor::StatePriorFactor(const NavState& state, const ImuBiases& biases,
                                   const StatePriorSigmas& sigmas)
    : state_(state), biases_(biases) {
  inverse_sigma_ << Eigen::Vector3d::Constant(sigmas.position_m), sigmas.tilt_rad, sigmas.tilt_rad,
      sigmas.yaw_rad, Eigen::Vector3d::Constant(sigmas.velocity_mps),
      Eigen::Vector3d::Constant(sigmas.gyroscope_bias_radps),
      Eigen::Vector3d::Constant(sigmas.accelerometer_bias_mps2);
  if (!(inverse_sigma_.array() > 0.0).all())
    throw std::invalid_argument("state prior: every sigma must be > 0");
  inverse_sigma_ = inverse_sigma_.cwiseInverse();
}

bool StatePriorFactor::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Eigen::Matrix3d R = Rotation(parameters[0]).toRotationMatrix();
  Eigen::Matrix<double, 15, 1> r;
  r.head<3>() = Position(parameters[0]) - state_.p_WI_m;
  r.segment<3>(3) = Log(Eigen::Matrix3d(R * state_.q_WI.toRotationMatrix().transpose()));
  r.segment<3>(6) = Eigen::Vector3d(parameters[1]) - state_.v_WI_W_mps;
  r.segment<3>(9) = Eigen::Vector3d(parameters[1] + 3) - biases_.gyroscope_radps;
  r.tail<3>() = Eigen::Vector3d(parameters[1] + 6) - biases_.accelerometer_mps2;
  Eigen::Map<Eigen::Matrix<double, 15, 1>>{residuals} = inverse_sigma_.cwiseProduct(r);
  if (jacobians == nullptr) return true;
  if (jacobians[0] != nullptr) {
    // Log(R Exp(δθ) R₀ᵀ) = Log(Exp(R δθ) Exp(r)) ≈ r + J_l⁻¹(r) R δθ, with J_l⁻¹(r) = J_r⁻¹(r)ᵀ.
    Eigen::Matrix<double, 15, kPoseSize> J = Eigen::Matrix<double, 15, kPoseSize>::Zero();
    J.block<3, 3>(0, 0).setIdentity();
    J.block<3, 3>(3, 3) = RightJacobianInverse(r.segment<3>(3)).transpose() * R;
    RowMajorMap<15, kPoseSize>{jacobians[0]} = inverse_sigma_.asDiagonal() * J;
  }
  if (jacobians[1] != nullptr) {
    Eigen::Matrix<double, 15, kSpeedBiasSize> J = Eigen::Matrix<double, 15, kSpeedBiasSize>::Zero();
    J.bottomRows<9>().setIdentity();
    RowMajorMap<15, kSpeedBiasSize>{jacobians[1]} = inverse_sigma_.asDiagonal() * J;
  }
  return true;
}

KinematicFactor::KinematicFactor(const Eigen::Vector3d& p_IJ_m, const Eigen::Vector3d& w_I_radps,
                                 const PeerJoint& other, const Eigen::Vector3d& drift_centre_W_m,
                                 double link_m, double sigma_link_m, double sigma_rate_radps)
    : p_IJ_m_(p_IJ_m),
      w_I_radps_(w_I_radps),
      other_(other),
      from_centre_m_(other.p_WJ_m - drift_centre_W_m),
      drift_centre_W_m_(drift_centre_W_m),
      link_m_(link_m),
      sigma_link_m_(sigma_link_m),
      sigma_along_link_mps_(sigma_rate_radps * link_m) {
  if (!(link_m > 0.0) || !(sigma_link_m > 0.0) || !(sigma_rate_radps > 0.0))
    throw std::invalid_argument("kinematic factor: link_m, sigma_link_m and sigma_rate_radps must be > 0");
}

bool KinematicFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Matrix3d R = Rotation(parameters[0]).toRotationMatrix();
  const Eigen::Vector3d v_I(parameters[1]);
  const Eigen::Vector3d b_g(parameters[1] + 3);
  const double* drift = parameters[2];
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(drift[3], Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d dRz = Rz * Skew(Eigen::Vector3d::UnitZ());  // d Rz / d ψ
  const Eigen::Vector3d lever_rate = (w_I_radps_ - b_g).cross(p_IJ_m_);
  const Eigen::Vector3d dp = Position(parameters[0]) + R * p_IJ_m_ - Rz * from_centre_m_ - drift_centre_W_m_ -
                             Eigen::Vector3d(drift[0], drift[1], drift[2]);
  const Eigen::Vector3d dv = v_I + R * lever_rate - Rz * other_.v_WJ_W_mps;
  const double distance = std::max(dp.norm(), 1e-9);
  residuals[0] = (distance - link_m_) / sigma_link_m_;
  residuals[1] = dv.dot(dp) / link_m_ / sigma_along_link_mps_;
  if (jacobians == nullptr) return true;
  // Rows: d r / d Δp and d r / d Δv; then the chain through Δp's and Δv's terms.
  const Eigen::RowVector3d r0_dp = dp.transpose() / (distance * sigma_link_m_);
  const double scale1 = 1.0 / (link_m_ * sigma_along_link_mps_);
  const Eigen::RowVector3d r1_dp = scale1 * dv.transpose(), r1_dv = scale1 * dp.transpose();
  if (jacobians[0] != nullptr) {
    RowMajorMap<2, kPoseSize> J(jacobians[0]);
    J.setZero();
    const Eigen::Matrix3d dp_dtheta = -R * Skew(p_IJ_m_), dv_dtheta = -R * Skew(lever_rate);
    J.block<1, 3>(0, 0) = r0_dp;
    J.block<1, 3>(0, 3) = r0_dp * dp_dtheta;
    J.block<1, 3>(1, 0) = r1_dp;
    J.block<1, 3>(1, 3) = r1_dp * dp_dtheta + r1_dv * dv_dtheta;
  }
  if (jacobians[1] != nullptr) {
    RowMajorMap<2, kSpeedBiasSize> J(jacobians[1]);
    J.setZero();
    J.block<1, 3>(1, 0) = r1_dv;
    J.block<1, 3>(1, 3) = r1_dv * R * Skew(p_IJ_m_);  // (ω − b) × p = −[p]× (ω − b)
  }
  if (jacobians[2] != nullptr) {
    RowMajorMap<2, kDriftSize> J(jacobians[2]);
    J.block<1, 3>(0, 0) = -r0_dp;
    const Eigen::Vector3d dp_dpsi = -dRz * from_centre_m_, dv_dpsi = -dRz * other_.v_WJ_W_mps;
    J(0, 3) = r0_dp.dot(dp_dpsi);
    J.block<1, 3>(1, 0) = -r1_dp;
    J(1, 3) = r1_dp.dot(dp_dpsi) + r1_dv.dot(dv_dpsi);
  }
  return true;
}

AttitudeFactor::AttitudeFactor(const Eigen::Quaterniond& q_WI_measured, double sigma_rad)
    : down_I_measured_(q_WI_measured.normalized().conjugate() * Eigen::Vector3d::UnitZ()),
      sigma_rad_(sigma_rad) {
  if (!(sigma_rad > 0.0)) throw std::invalid_argument("attitude factor: sigma_rad must be > 0");
}

bool AttitudeFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Vector3d down_I = Rotation(parameters[0]).normalized().conjugate() * Eigen::Vector3d::UnitZ();
  Eigen::Map<Eigen::Vector3d>{residuals} = (down_I - down_I_measured_) / sigma_rad_;
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    // (R Exp(δθ))ᵀ e_z = Exp(−δθ) Rᵀ e_z ≈ a + [a]× δθ, a = Rᵀ e_z.
    RowMajorMap<3, kPoseSize> J(jacobians[0]);
    J.setZero();
    J.middleCols<3>(3) = Skew(down_I) / sigma_rad_;
  }
  return true;
}

DriftPriorFactor::DriftPriorFactor(const Eigen::Vector4d& drift, double sigma_position_m,
                                   double sigma_yaw_rad)
    : drift_(drift) {
  if (!(sigma_position_m > 0.0) || !(sigma_yaw_rad > 0.0))
    throw std::invalid_argument("drift prior: sigma_position_m and sigma_yaw_rad must be > 0");
  inverse_sigma_ << Eigen::Vector3d::Constant(1.0 / sigma_position_m), 1.0 / sigma_yaw_rad;
}

bool DriftPriorFactor::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  Eigen::Map<Eigen::Vector4d>{residuals} =
      inverse_sigma_.cwiseProduct(Eigen::Vector4d(parameters[0]) - drift_);
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    RowMajorMap<4, 4>{jacobians[0]} = inverse_sigma_.asDiagonal();
  }
  return true;
}

}  // namespace iapsim::vio
