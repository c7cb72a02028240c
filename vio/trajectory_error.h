#pragma once
// Absolute trajectory error (Sturm et al., "A Benchmark for the Evaluation of RGB-D SLAM Systems", IROS 2012,
// the TUM benchmark's ATE; evo's `evo_ape`): the RMSE of the position differences between an estimate and the
// ground truth at the same stamps, either as they are (the seed's evaluation: each sub-aircraft's estimate
// starts from the first ground-truth pose, §VI-G) or after the least-squares rigid alignment of the
// estimate onto the truth (Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", IEEE PAMI 13(4), 1991, without scale: stereo VIO has metric scale).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace iapsim::vio {

struct StampedPosition {
  std::int64_t t_ns = 0;
  Eigen::Vector3d p_m = Eigen::Vector3d::Zero();
};

struct AbsoluteTrajectoryError {
  std::size_t matched = 0;    ///< estimate stamps found in the truth
  std::size_t unmatched = 0;  ///< estimate stamps the truth does not have
  double rmse_m = 0.0;
  double mean_m = 0.0;
  double max_m = 0.0;
  Eigen::Isometry3d alignment = Eigen::Isometry3d::Identity();  ///< applied to the estimate
};

/// The rigid transform T minimising Σ |T a_i − b_i|² (Umeyama 1991 without scale); needs ≥ 3 points not on
/// a line for a unique rotation (fewer: the identity rotation).
Eigen::Isometry3d UmeyamaRigid(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b);

/// ATE of `estimate` against `truth` (both sorted by time; stamps matched exactly). `align`: after
/// UmeyamaRigid of the matched positions, else as they are.
AbsoluteTrajectoryError ComputeAte(const std::vector<StampedPosition>& estimate,
                                   const std::vector<StampedPosition>& truth, bool align);

}  // namespace iapsim::vio
