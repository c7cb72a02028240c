#include "vio/trajectory_error.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace iapsim::vio {

Eigen::Isometry3d UmeyamaRigid(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (a.empty() || a.size() != b.size()) return T;
  Eigen::Vector3d mean_a = Eigen::Vector3d::Zero(), mean_b = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < a.size(); ++i) {
    mean_a += a[i];
    mean_b += b[i];
  }
  mean_a /= static_cast<double>(a.size());
  mean_b /= static_cast<double>(b.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // Σ (b − b̄)(a − ā)ᵀ
  for (std::size_t i = 0; i < a.size(); ++i) covariance += (b[i] - mean_b) * (a[i] - mean_a).transpose();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (a.size() >= 3) {
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0)
      S(2, 2) = -1.0;  // a rotation, not a reflection
    R = svd.matrixU() * S * svd.matrixV().transpose();
  }
  T.linear() = R;
  T.translation() = mean_b - R * mean_a;
  return T;
}

AbsoluteTrajectoryError ComputeAte(const std::vector<StampedPosition>& estimate,
                                   const std::vector<StampedPosition>& truth, bool align) {
  AbsoluteTrajectoryError out;
  std::vector<Eigen::Vector3d> a, b;
  for (const StampedPosition& e : estimate) {
    const auto it = std::lower_bound(truth.begin(), truth.end(), e.t_ns,
                                     [](const StampedPosition& p, std::int64_t t) { return p.t_ns < t; });
    if (it == truth.end() || it->t_ns != e.t_ns) {
      ++out.unmatched;
      continue;
    }
    a.push_back(e.p_m);
    b.push_back(it->p_m);
  }
  out.matched = a.size();
  if (a.empty()) return out;
  if (align) out.alignment = UmeyamaRigid(a, b);
  double sum_squares = 0.0, sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double error_m = (out.alignment * a[i] - b[i]).norm();
    sum_squares += error_m * error_m;
    sum += error_m;
    out.max_m = std::max(out.max_m, error_m);
  }
  out.rmse_m = std::sqrt(sum_squares / a.size());
  out.mean_m = sum / a.size();
  return out;
}

}  // namespace iapsim::vio
