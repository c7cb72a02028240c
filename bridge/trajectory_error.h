#pragma once
// Absolute trajectory error (Sturm et al., "A Benchmark for the Evaluation of RGB-D SLAM Systems", IROS 2012,
// the TUM benchmark's ATE; evo's `evo_ape`): the RMSE of the position differences between an estimate and the
// ground truth at the same stamps, either as they are (the seed's evaluation: each sub-aircraft's estimate
// starts from the first ground-truth pose, §VI-G) or after the least-squares rigid alignment of the
// estimate onto the truth (Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", IEEE PAMI 13(4), 1991, without scale: stereo VIO has metric scale). And the relative pose error
// over a fixed time (the same benchmark's RPE, evo's `evo_rpe --delta`): the drift per interval, free of
// where the trajectory started.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

#include "bridge/message_format.h"

namespace iapsim::bridge {

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

struct StampedIsometry {
  std::int64_t t_ns = 0;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
};

struct RelativePoseError {
  std::size_t pairs = 0;  ///< (i, j) pairs of matched stamps delta apart
  double translation_rmse_m = 0.0;
  double rotation_rmse_deg = 0.0;
};

/// The rigid transform T minimising Σ |T a_i − b_i|² (Umeyama 1991 without scale); needs ≥ 3 points not on
/// a line for a unique rotation (fewer: the identity rotation).
Eigen::Isometry3d UmeyamaRigid(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b);

/// ATE of `estimate` against `truth` (both sorted by time; stamps matched exactly). `align`: after
/// UmeyamaRigid of the matched positions, else as they are.
AbsoluteTrajectoryError ComputeAte(const std::vector<StampedPosition>& estimate,
                                   const std::vector<StampedPosition>& truth, bool align);

/// RPE over `delta_ns`: for each matched estimate stamp t_i with a matched stamp t_j = t_i + delta_ns, the
/// error E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j) of the estimate's motion P against the truth's Q; RMSE of |trans(E)|
/// and of the angle of rot(E).
RelativePoseError ComputeRpe(const std::vector<StampedIsometry>& estimate,
                             const std::vector<StampedIsometry>& truth, std::int64_t delta_ns);

/// The errors `iapsim vio` and a run's `evaluation.odometry` report of an estimate against the truth (poses
/// of the same body, each sorted by time, stamps matched exactly): {ate, ate_aligned: {rmse_m, mean_m,
/// max_m, matched}, rpe_1s: {translation_rmse_m, rotation_rmse_deg, pairs}}; the two ATEs also through the
/// pointers when given.
nlohmann::json TrajectoryErrors(const std::vector<StampedPose>& estimate,
                                const std::vector<StampedPose>& truth, AbsoluteTrajectoryError* ate = nullptr,
                                AbsoluteTrajectoryError* ate_aligned = nullptr);

}  // namespace iapsim::bridge
