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

bool ThrustLimits::Admits(const Eigen::Vector3d& thrust_W_N) const {
  const double magnitude_N = thrust_W_N.norm();
  if (magnitude_N > max_N || magnitude_N < min_N) return false;
  // the angle from up (−z_W), with a margin for rounding at the cone's edge
  return magnitude_N == 0.0 || -thrust_W_N.z() >= magnitude_N * std::cos(max_tilt_rad) - 1e-12 * magnitude_N;
}

Vector6d PartOf(const Vector6d& U_P, const Eigen::Matrix3d& R_WP, WrenchPart part) {
  const Eigen::Vector3d vertical_P = R_WP.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d force_vertical_P = vertical_P * vertical_P.dot(U_P.head<3>());
  Vector6d out = Vector6d::Zero();
  switch (part) {
    case WrenchPart::kVertical:
      out.head<3>() = force_vertical_P;
      break;
    case WrenchPart::kRollPitch:
      out.segment<2>(3) = U_P.segment<2>(3);
      break;
    case WrenchPart::kHorizontal:
      out.head<3>() = U_P.head<3>() - force_vertical_P;
      break;
    case WrenchPart::kYaw:
      out[5] = U_P[5];
      break;
  }
  return out;
}

Eigen::VectorXd AllocateWithinLimits(const Allocation& allocation, const Vector6d& U_P,
                                     const Eigen::Matrix3d& R_WP, const std::vector<ThrustLimits>& limits,
                                     double* kept) {
  const int n = static_cast<int>(limits.size());
  if (allocation.B().cols() != 3 * n) throw std::invalid_argument("one ThrustLimits per sub-aircraft");
  const auto admitted = [&](const Eigen::VectorXd& thrusts_P_N) {
    for (int i = 0; i < n; ++i) {
      if (!limits[i].Admits(R_WP * thrusts_P_N.segment<3>(3 * i))) return false;
    }
    return true;
  };
  Eigen::VectorXd taken = Eigen::VectorXd::Zero(3 * n);
  for (int p = 0; p < kWrenchParts; ++p) {
    const Eigen::VectorXd part = allocation.Allocate(PartOf(U_P, R_WP, static_cast<WrenchPart>(p)));
    double scale = 1.0;
    if (!admitted(taken + part)) {
      // the largest admitted scale: the limits are a convex set but for the minimum thrust, so the admitted
      // scales are [0, s*] when 0 is admitted (40 halvings: s* to 1e-12)
      double low = 0.0, high = 1.0;
      for (int k = 0; k < 40; ++k) {
        const double middle = 0.5 * (low + high);
        (admitted(taken + middle * part) ? low : high) = middle;
      }
      scale = low;
    }
    taken += scale * part;
    kept[p] = scale;
  }
  return taken;
}

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
