#include "bridge/trajectory_error.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <map>

namespace iapsim::bridge {

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

RelativePoseError ComputeRpe(const std::vector<StampedIsometry>& estimate,
                             const std::vector<StampedIsometry>& truth, std::int64_t delta_ns) {
  std::map<std::int64_t, std::pair<Eigen::Isometry3d, Eigen::Isometry3d>> matched;  // stamp -> (P, Q)
  std::map<std::int64_t, Eigen::Isometry3d> truth_at;
  for (const StampedIsometry& q : truth) truth_at[q.t_ns] = q.X;
  for (const StampedIsometry& p : estimate) {
    const auto q = truth_at.find(p.t_ns);
    if (q != truth_at.end()) matched[p.t_ns] = {p.X, q->second};
  }
  RelativePoseError out;
  double sum_translation = 0.0, sum_rotation = 0.0;
  for (const auto& [t_i, poses_i] : matched) {
    const auto j = matched.find(t_i + delta_ns);
    if (j == matched.end()) continue;
    const Eigen::Isometry3d motion_estimate = poses_i.first.inverse() * j->second.first;
    const Eigen::Isometry3d motion_truth = poses_i.second.inverse() * j->second.second;
    const Eigen::Isometry3d E = motion_truth.inverse() * motion_estimate;
    const double angle_deg = Eigen::AngleAxisd(E.rotation()).angle() * 180.0 / M_PI;
    sum_translation += E.translation().squaredNorm();
    sum_rotation += angle_deg * angle_deg;
    ++out.pairs;
  }
  if (out.pairs > 0) {
    out.translation_rmse_m = std::sqrt(sum_translation / out.pairs);
    out.rotation_rmse_deg = std::sqrt(sum_rotation / out.pairs);
  }
  return out;
}

namespace {

std::vector<StampedPosition> Positions(const std::vector<StampedPose>& poses) {
  std::vector<StampedPosition> positions;
  for (const StampedPose& p : poses)
    positions.push_back({p.time_ns, {p.position[0], p.position[1], p.position[2]}});
  return positions;
}

std::vector<StampedIsometry> Isometries(const std::vector<StampedPose>& poses) {
  std::vector<StampedIsometry> out;
  for (const StampedPose& p : poses) {
    StampedIsometry s;
    s.t_ns = p.time_ns;
    s.X.linear() = Eigen::Quaterniond(p.orientation_xyzw[3], p.orientation_xyzw[0], p.orientation_xyzw[1],
                                      p.orientation_xyzw[2])
                       .normalized()
                       .toRotationMatrix();
    s.X.translation() = Eigen::Vector3d(p.position[0], p.position[1], p.position[2]);
    out.push_back(s);
  }
  return out;
}

nlohmann::json AteJson(const AbsoluteTrajectoryError& e) {
  return {{"rmse_m", e.rmse_m}, {"mean_m", e.mean_m}, {"max_m", e.max_m}, {"matched", e.matched}};
}

}  // namespace

nlohmann::json TrajectoryErrors(const std::vector<StampedPose>& estimate,
                                const std::vector<StampedPose>& truth, AbsoluteTrajectoryError* ate,
                                AbsoluteTrajectoryError* ate_aligned) {
  constexpr std::int64_t kRpeDelta_ns = 1'000'000'000;  // the drift per second
  const AbsoluteTrajectoryError as_is = ComputeAte(Positions(estimate), Positions(truth), false);
  const AbsoluteTrajectoryError aligned = ComputeAte(Positions(estimate), Positions(truth), true);
  const RelativePoseError rpe = ComputeRpe(Isometries(estimate), Isometries(truth), kRpeDelta_ns);
  if (ate) *ate = as_is;
  if (ate_aligned) *ate_aligned = aligned;
  return {{"ate", AteJson(as_is)},
          {"ate_aligned", AteJson(aligned)},
          {"rpe_1s",
           {{"translation_rmse_m", rpe.translation_rmse_m},
            {"rotation_rmse_deg", rpe.rotation_rmse_deg},
            {"pairs", rpe.pairs}}}};
}

}  // namespace iapsim::bridge
