#include "control/allocation.h"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iapsim::control {
namespace {

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

std::vector<Eigen::Vector3d> JointsOf(const model::Vehicle& vehicle) {
  std::vector<Eigen::Vector3d> joints;
  for (const auto& sub : vehicle.sub_aircraft) joints.push_back(sub.joint_P_m);
  return joints;
}

}  // namespace

Allocation::Allocation(const std::vector<Eigen::Vector3d>& joints_P_m) {
  const int n = static_cast<int>(joints_P_m.size());
  if (n < 2) throw std::invalid_argument("an IAP has at least two sub-aircraft");
  B_.resize(6, 3 * n);
  for (int i = 0; i < n; ++i) {
    B_.block<3, 3>(0, 3 * i).setIdentity();
    B_.block<3, 3>(3, 3 * i) = Hat(joints_P_m[i]);
  }
  // B = XY with Y spanning B's row space (r rows): B⁺ = Yᵀ(YYᵀ)⁻¹(XᵀX)⁻¹Xᵀ. From the SVD B = U S Vᵀ with
  // rank r, X = U_r S_r and Y = V_rᵀ give YYᵀ = I and that expression equals V_r S_r⁻¹ U_rᵀ.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(B_, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  rank_ = 0;
  for (int i = 0; i < s.size(); ++i) rank_ += s[i] > 1e-9 * s[0] ? 1 : 0;
  const Eigen::MatrixXd X = svd.matrixU().leftCols(rank_) * s.head(rank_).asDiagonal();
  const Eigen::MatrixXd Y = svd.matrixV().leftCols(rank_).transpose();
  B_pinv_ = Y.transpose() * (Y * Y.transpose()).inverse() * (X.transpose() * X).inverse() * X.transpose();
}

Allocation::Allocation(const model::Vehicle& vehicle) : Allocation(JointsOf(vehicle)) {}

Vector6d HoverWrench(const model::Vehicle& vehicle, const Eigen::Quaterniond& q_WP, double gravity_mps2) {
  const Eigen::Vector3d weight_P = vehicle.TotalMass_kg() * gravity_mps2 * (q_WP.conjugate() * Eigen::Vector3d::UnitZ());
  Vector6d U;
  U << -weight_P, -vehicle.CenterOfMass_P_m().cross(weight_P);
  return U;
}

Eigen::Vector2d RollPitchForThrust(const Eigen::Vector3d& thrust_W, double yaw_rad) {
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  const double norm = thrust_W.norm();
  const double forward = thrust_W.x() * c + thrust_W.y() * s;
  const double roll = std::asin(std::clamp((thrust_W.y() * c - thrust_W.x() * s) / norm, -1.0, 1.0));
  const double pitch =
      std::asin(std::clamp(-forward / std::sqrt(forward * forward + thrust_W.z() * thrust_W.z()), -1.0, 1.0));
  return Eigen::Vector2d(roll, pitch);
}

Eigen::Quaterniond AttitudeFromEuler(double roll_rad, double pitch_rad, double yaw_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()));
}

}  // namespace iapsim::control
