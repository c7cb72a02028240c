#include "vio/estimator.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "vio/factors.h"
#include "vio/marginalisation.h"
#include "vio/so3.h"

namespace iapsim::vio {
namespace {

struct WindowFrame {
  std::uint64_t serial = 0;
  double t_s = 0.0;
  std::array<double, kPoseSize> pose{};
  std::array<double, kSpeedBiasSize> speed_bias{};
  std::shared_ptr<ImuPreintegration> imu;  ///< from the previous window frame; null for the first
  bool keyframe = false;
  Eigen::Vector3d w_I_radps = Eigen::Vector3d::Zero();  ///< the gyroscope at t_s (r_kv's lever arm)
  std::optional<Eigen::Quaterniond> attitude_WI;        ///< the flight controller's R̂_WI at t_s (r_kq)

  NavState State() const {
    const Eigen::Isometry3d X = PoseFromBlock(pose.data());
    return {X.translation(), Eigen::Quaterniond(X.linear()), Eigen::Vector3d(speed_bias.data())};
  }
  ImuBiases Biases() const {
    return {Eigen::Vector3d(speed_bias.data() + 3), Eigen::Vector3d(speed_bias.data() + 6)};
  }
  void Set(const NavState& state, const ImuBiases& biases) {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = state.q_WI.normalized().toRotationMatrix();
    X.translation() = state.p_WI_m;
    PoseToBlock(X, pose.data());
    Eigen::Map<Eigen::Vector3d>{speed_bias.data()} = state.v_WI_W_mps;
    Eigen::Map<Eigen::Vector3d>{speed_bias.data() + 3} = biases.gyroscope_radps;
    Eigen::Map<Eigen::Vector3d>{speed_bias.data() + 6} = biases.accelerometer_mps2;
  }
};

// A feature in normalised coordinates of the left eye and, when matched, of the right.
struct Observation {
  Eigen::Vector2d left;
  std::optional<Eigen::Vector2d> right;
};

struct Track {
  std::map<std::uint64_t, Observation> observations;  ///< by frame serial; the first is the anchor
  double inverse_depth = 0.0;                         ///< 1/z in the anchor's left eye, when has_depth
  bool has_depth = false;
};

struct InitialPrior {
  std::uint64_t serial = 0;
  NavState state;
  ImuBiases biases;
  StatePriorSigmas sigmas;
};

struct PendingRange {
  double t_s = 0.0;
  Eigen::Vector3d p_WA_m = Eigen::Vector3d::Zero();
  double range_m = 0.0;
  double sigma_m = 0.0;
};

// A range attached to a keyframe through the IMU from that keyframe to the range's time.
struct RangeMeasurement {
  std::uint64_t serial = 0;
  RangeFactor::SinceKeyframe since_keyframe;
  PendingRange range;
};

// A residual block to add to a problem or to marginalise.
struct Residual {
  std::unique_ptr<ceres::CostFunction> cost;
  const ceres::LossFunction* loss = nullptr;
  std::vector<double*> parameters;
};

double Milliseconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

// Bias changes beyond which the first-order correction is replaced by integrating again (VINS-Fusion's
// repropagation thresholds are of this order).
constexpr double kRepropagateGyroscope_radps = 0.01;
constexpr double kRepropagateAccelerometer_mps2 = 0.1;

}  // namespace

struct Estimator::Impl {
  StereoRig rig;
  Eigen::Isometry3d X_IR = Eigen::Isometry3d::Identity();
  EstimatorOptions options;
  Eigen::Vector3d g_W;
  std::unique_ptr<ceres::LossFunction> loss;
  std::unique_ptr<ceres::LossFunction> range_loss;
  PoseManifold pose_manifold;

  std::deque<std::unique_ptr<WindowFrame>> window;
  std::map<std::uint64_t, Track> tracks;
  std::set<std::uint64_t> rejected;  ///< outlier feature ids still tracked, not used again
  std::shared_ptr<const MarginalPrior> prior;
  std::optional<InitialPrior> initial_prior;
  std::optional<std::pair<NavState, ImuBiases>> given_initial_state;

  // VIRPO: the attitude estimates, each other sub-aircraft's shared joints by time, and the drift of each
  // one's odometry (a Ceres block: δp, δψ) with its value after the last solve that used it.
  std::deque<std::pair<double, Eigen::Quaterniond>> attitudes;
  std::vector<std::map<double, PeerJoint>> peer_joints;
  std::vector<std::array<double, kDriftSize>> drift;
  std::vector<std::optional<Eigen::Vector4d>> drift_solved;
  std::vector<Eigen::Vector3d> drift_centre;  ///< the peer's latest shared joint at the last solve
  std::unique_ptr<ceres::LossFunction> kinematic_loss;

  std::deque<PendingRange> pending_ranges;
  std::vector<RangeMeasurement> ranges;
  ImuSamples imu;
  std::shared_ptr<ImuPreintegration> since_keyframe;  ///< from the newest keyframe to the last frame
  double last_frame_t_s = -std::numeric_limits<double>::infinity();
  std::uint64_t next_serial = 0;
  int frames_since_start = 0;
  std::optional<Estimate> last_good;
  EstimatorStatistics statistics;

  // --- IMU ---------------------------------------------------------------------------------------------
  sensors::ImuSample SampleAt(double t) const { return InterpolatedSample(imu, t); }

  // Integrates the samples strictly between from_t and to_t, then the sample at to_t.
  void IntegrateTo(ImuPreintegration* pre, double from_t, double to_t) const {
    double t = from_t;
    for (const auto& [sample_t, sample] : imu) {
      if (sample_t <= from_t || sample_t >= to_t) continue;
      pre->Integrate(sample_t - t, sample);
      t = sample_t;
    }
    pre->Integrate(to_t - t, SampleAt(to_t));
  }

  void PruneInputs() {
    // Keep one sample at or before the last frame (the oldest window frame for peers), for interpolation.
    while (imu.size() > 1 && imu[1].first <= last_frame_t_s) imu.pop_front();
    while (attitudes.size() > 1 && attitudes[1].first <= last_frame_t_s) attitudes.pop_front();
    for (auto& joints : peer_joints) {
      while (joints.size() > 1 && std::next(joints.begin())->first <= window.front()->t_s)
        joints.erase(joints.begin());
    }
  }

  // The flight controller's attitude at t: interpolated between the samples around it, else none.
  std::optional<Eigen::Quaterniond> AttitudeAt(double t) const {
    for (std::size_t k = 0; k < attitudes.size(); ++k) {
      if (attitudes[k].first < t) continue;
      if (attitudes[k].first == t) return attitudes[k].second;
      if (k == 0) return std::nullopt;
      const double a = (t - attitudes[k - 1].first) / (attitudes[k].first - attitudes[k - 1].first);
      return attitudes[k - 1].second.slerp(a, attitudes[k].second);
    }
    return std::nullopt;
  }

  // A peer's joint at t: shared at t, interpolated between two shared around it, or carried from the last
  // one by its velocity (see PhysicalConstraintOptions::max_peer_extrapolation_s).
  std::optional<PeerJoint> PeerAt(std::size_t peer, double t) const {
    const std::map<double, PeerJoint>& joints = peer_joints[peer];
    const auto after = joints.lower_bound(t);
    if (after != joints.end() && after->first == t) return after->second;
    if (after != joints.end()) {
      if (after == joints.begin()) return std::nullopt;
      const auto before = std::prev(after);
      const double a = (t - before->first) / (after->first - before->first);
      return PeerJoint{(1.0 - a) * before->second.p_WJ_m + a * after->second.p_WJ_m,
                       (1.0 - a) * before->second.v_WJ_W_mps + a * after->second.v_WJ_W_mps};
    }
    if (joints.empty() || t - joints.rbegin()->first > options.physical.max_peer_extrapolation_s)
      return std::nullopt;
    const PeerJoint& last = joints.rbegin()->second;
    return PeerJoint{last.p_WJ_m + last.v_WJ_W_mps * (t - joints.rbegin()->first), last.v_WJ_W_mps};
  }

  // Ranges up to `t_s` join the newest keyframe through the IMU since it (window.back() is that keyframe and
  // since_keyframe reaches the last frame).
  void AttachRanges(double t_s) {
    while (!pending_ranges.empty() && pending_ranges.front().t_s <= t_s) {
      const PendingRange range = pending_ranges.front();
      pending_ranges.pop_front();
      if (window.empty() || range.t_s < last_frame_t_s) {
        ++statistics.ranges_dropped;
        continue;
      }
      ImuPreintegration to_range = *since_keyframe;
      if (range.t_s > last_frame_t_s) IntegrateTo(&to_range, last_frame_t_s, range.t_s);
      ranges.push_back({window.back()->serial, RangeFactor::SinceKeyframe(to_range), range});
      ++statistics.ranges_used;
    }
  }

  // --- features ----------------------------------------------------------------------------------------
  void AddObservations(std::uint64_t serial, const StereoFrame& frame) {
    // A tracker never gives an id back once it lost it, and ids grow: outliers older than this frame's
    // oldest feature can no longer come, and are forgotten (the set stays small on a long run).
    if (!frame.features.empty())
      rejected.erase(rejected.begin(), rejected.lower_bound(frame.features.front().id));
    for (const TrackedFeature& f : frame.features) {
      if (rejected.count(f.id) != 0) continue;
      Observation observation{rig.Normalised(f.uv_left), std::nullopt};
      if (f.uv_right) observation.right = rig.Normalised(*f.uv_right);
      tracks[f.id].observations[serial] = observation;
    }
  }

  std::map<std::uint64_t, WindowFrame*> FramesBySerial() const {
    std::map<std::uint64_t, WindowFrame*> frames;
    for (const auto& frame : window) frames[frame->serial] = frame.get();
    return frames;
  }

  bool DepthInRange(double depth_m) const {
    return depth_m >= options.min_depth_m && depth_m <= options.max_depth_m;
  }

  // Depth from the anchor's own stereo pair, else from the anchor and the latest other view by linear
  // triangulation at the current poses.
  void Triangulate() {
    const auto frames = FramesBySerial();
    for (auto& [id, track] : tracks) {
      if (track.has_depth) continue;
      const auto& [anchor_serial, anchor] = *track.observations.begin();
      if (anchor.right) {
        const double disparity = anchor.left.x() - anchor.right->x();  // x_l − x_r = b / z
        if (disparity > 0.0 && DepthInRange(rig.baseline_m / disparity)) {
          track.inverse_depth = disparity / rig.baseline_m;
          track.has_depth = true;
          continue;
        }
      }
      if (track.observations.size() < 2) continue;
      const auto& [other_serial, other] = *track.observations.rbegin();
      const Eigen::Isometry3d X_WA = PoseFromBlock(frames.at(anchor_serial)->pose.data()) * rig.X_IL;
      const Eigen::Isometry3d X_WO = PoseFromBlock(frames.at(other_serial)->pose.data()) * rig.X_IL;
      const Eigen::Isometry3d X_OA = X_WO.inverse() * X_WA;
      // z·ray_A expressed in O must be along ray_O: [ray_O]× (R z ray_A + t) = 0, least squares in z.
      const Eigen::Vector3d ray_A(anchor.left.x(), anchor.left.y(), 1.0),
          ray_O(other.left.x(), other.left.y(), 1.0);
      const Eigen::Vector3d a = Skew(ray_O) * X_OA.linear() * ray_A;
      const Eigen::Vector3d b = -Skew(ray_O) * X_OA.translation();
      if (a.norm() < 1e-3) continue;  // too little parallax
      const double depth_m = a.dot(b) / a.squaredNorm();
      if (!DepthInRange(depth_m)) continue;
      track.inverse_depth = 1.0 / depth_m;
      track.has_depth = true;
    }
  }

  bool Usable(const Track& track, const std::map<std::uint64_t, WindowFrame*>& frames) const {
    return track.has_depth && track.observations.size() >= 2 &&
           frames.count(track.observations.begin()->first) != 0;
  }

  double SqrtInformation() const { return rig.intrinsics.fx / options.pixel_sigma_px; }

  // The visual residuals of one track.
  void VisualResiduals(Track& track, const std::map<std::uint64_t, WindowFrame*>& frames,
                       std::vector<Residual>* out) const {
    const auto& [anchor_serial, anchor] = *track.observations.begin();
    double* anchor_pose = frames.at(anchor_serial)->pose.data();
    if (anchor.right) {
      out->push_back(
          {std::make_unique<StereoFactor>(anchor.left, *anchor.right, rig.baseline_m, SqrtInformation()),
           loss.get(),
           {&track.inverse_depth}});
    }
    for (const auto& [serial, observation] : track.observations) {
      if (serial == anchor_serial) continue;
      double* pose = frames.at(serial)->pose.data();
      out->push_back({std::make_unique<ReprojectionFactor>(anchor.left, observation.left, rig.X_IL, rig.X_IL,
                                                           SqrtInformation()),
                      loss.get(),
                      {anchor_pose, pose, &track.inverse_depth}});
      if (observation.right) {
        out->push_back({std::make_unique<ReprojectionFactor>(anchor.left, *observation.right, rig.X_IL, X_IR,
                                                             SqrtInformation()),
                        loss.get(),
                        {anchor_pose, pose, &track.inverse_depth}});
      }
    }
  }

  // r_kq's sigma for window frame i (PhysicalConstraintOptions::attitude_correlation_s): the slice it
  // stands for reaches back to the frame before it; the oldest one's, forward to the next.
  double AttitudeSigma_rad(std::size_t i) const {
    const PhysicalConstraintOptions& physical = options.physical;
    if (physical.attitude_correlation_s <= 0.0 || window.size() < 2) return physical.sigma_attitude_rad;
    const double slice_s = i == 0 ? window[1]->t_s - window[0]->t_s : window[i]->t_s - window[i - 1]->t_s;
    return physical.sigma_attitude_rad *
           std::sqrt(std::max(1.0, 2.0 * physical.attitude_correlation_s / std::max(slice_s, 1e-6)));
  }

  // Every residual of the window; with `oldest_only`, those that touch the oldest frame (for
  // marginalisation).
  std::vector<Residual> Residuals(bool oldest_only) {
    std::vector<Residual> residuals;
    const auto frames = FramesBySerial();
    const WindowFrame& oldest = *window.front();
    if (prior) {
      std::vector<double*> blocks;
      for (const ParameterInfo& block : prior->blocks) blocks.push_back(block.values);
      residuals.push_back({std::make_unique<MarginalPriorFactor>(prior), nullptr, blocks});
    }
    if (initial_prior && frames.count(initial_prior->serial) != 0 &&
        (!oldest_only || initial_prior->serial == oldest.serial)) {
      WindowFrame* frame = frames.at(initial_prior->serial);
      residuals.push_back({std::make_unique<StatePriorFactor>(initial_prior->state, initial_prior->biases,
                                                              initial_prior->sigmas),
                           nullptr,
                           {frame->pose.data(), frame->speed_bias.data()}});
    }
    const std::size_t imu_factors = oldest_only ? std::min<std::size_t>(window.size(), 2) : window.size();
    for (std::size_t i = 1; i < imu_factors; ++i) {
      WindowFrame& a = *window[i - 1];
      WindowFrame& b = *window[i];
      residuals.push_back({std::make_unique<ImuFactor>(b.imu, options.imu_noise, g_W),
                           nullptr,
                           {a.pose.data(), a.speed_bias.data(), b.pose.data(), b.speed_bias.data()}});
    }
    for (auto& [id, track] : tracks) {
      if (!Usable(track, frames)) continue;
      if (oldest_only && track.observations.begin()->first != oldest.serial) continue;
      VisualResiduals(track, frames, &residuals);
    }
    for (std::size_t i = 0; i < window.size(); ++i) {
      const WindowFrame& frame = *window[i];
      if (!frame.attitude_WI || (oldest_only && i != 0)) continue;
      residuals.push_back({std::make_unique<AttitudeFactor>(*frame.attitude_WI, AttitudeSigma_rad(i)),
                           nullptr,
                           {window[i]->pose.data()}});
    }
    for (const RangeMeasurement& m : ranges) {
      const auto frame = frames.find(m.serial);
      if (frame == frames.end() || (oldest_only && m.serial != oldest.serial)) continue;
      residuals.push_back({std::make_unique<RangeFactor>(m.since_keyframe, m.range.p_WA_m, m.range.range_m,
                                                         m.range.sigma_m, options.p_IT_m, g_W),
                           range_loss.get(),
                           {frame->second->pose.data(), frame->second->speed_bias.data()}});
    }
    return residuals;
  }

  // The same drift about another centre: Rz (x − c) + c + δp = Rz (x − c′) + c′ + δp′ with
  // δp′ = δp + (Rz − I)(c′ − c). The solved value that anchors the continuous prior moves with it.
  void MoveDriftCentre(std::size_t peer, const Eigen::Vector3d& centre) {
    const auto move = [&](double* d) {
      const Eigen::Matrix3d Rz = Eigen::AngleAxisd(d[3], Eigen::Vector3d::UnitZ()).toRotationMatrix();
      Eigen::Map<Eigen::Vector3d>{d} += (Rz - Eigen::Matrix3d::Identity()) * (centre - drift_centre[peer]);
    };
    move(drift[peer].data());
    if (drift_solved[peer]) move(drift_solved[peer]->data());
    drift_centre[peer] = centre;
  }

  // r_kp and r_kv of every window frame with each peer that shared its joint then (counted in
  // statistics.kinematic_constraints), and each such peer's drift prior; the peers they involve are marked
  // in `used`. Not marginalised: they tie the window to the other's drift, whose memory from one solve to
  // the next is the continuous prior.
  std::vector<Residual> PhysicalResiduals(std::vector<bool>* used) {
    std::vector<Residual> residuals;
    const PhysicalConstraintOptions& o = options.physical;
    used->assign(peer_joints.size(), false);
    for (std::size_t peer = 0; peer < peer_joints.size(); ++peer) {
      if (peer_joints[peer].empty()) continue;
      MoveDriftCentre(peer, peer_joints[peer].rbegin()->second.p_WJ_m);
      for (const auto& frame : window) {
        const std::optional<PeerJoint> joint = PeerAt(peer, frame->t_s);
        if (!joint) continue;
        residuals.push_back(
            {std::make_unique<KinematicFactor>(o.p_IJ_m, frame->w_I_radps, *joint, drift_centre[peer],
                                               o.link_lengths_m[peer], o.sigma_link_m, o.sigma_rate_radps),
             kinematic_loss.get(),
             {frame->pose.data(), frame->speed_bias.data(), drift[peer].data()}});
        ++statistics.kinematic_constraints;
        (*used)[peer] = true;
      }
      if (!(*used)[peer]) continue;
      residuals.push_back(
          {drift_solved[peer] ? std::make_unique<DriftPriorFactor>(
                                    *drift_solved[peer], o.drift_step_position_m, o.drift_step_yaw_rad)
                              : std::make_unique<DriftPriorFactor>(
                                    Eigen::Vector4d::Zero(), o.drift_prior_position_m, o.drift_prior_yaw_rad),
           nullptr,
           {drift[peer].data()}});
    }
    return residuals;
  }

  void RepropagateWhereBiasesMoved() {
    for (std::size_t i = 1; i < window.size(); ++i) {
      ImuPreintegration& pre = *window[i]->imu;
      const ImuBiases biases = window[i - 1]->Biases();
      if ((biases.gyroscope_radps - pre.linearisation_biases().gyroscope_radps).norm() >
              kRepropagateGyroscope_radps ||
          (biases.accelerometer_mps2 - pre.linearisation_biases().accelerometer_mps2).norm() >
              kRepropagateAccelerometer_mps2) {
        pre.Repropagate(biases);
      }
    }
  }

  // Features of the newest frame that take part in the solve.
  int NewestFeatures() const {
    const auto frames = FramesBySerial();
    int used = 0;
    for (const auto& [id, track] : tracks)
      used += Usable(track, frames) && track.observations.count(window.back()->serial) != 0;
    return used;
  }

  void Solve() {
    const auto start = std::chrono::steady_clock::now();
    RepropagateWhereBiasesMoved();
    std::vector<Residual> residuals = Residuals(false);
    std::vector<bool> peers_used;
    for (Residual& r : PhysicalResiduals(&peers_used)) residuals.push_back(std::move(r));
    for (const auto& frame : window) statistics.attitude_constraints += frame->attitude_WI.has_value();
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    for (const auto& frame : window) {
      problem.AddParameterBlock(frame->pose.data(), kPoseSize, &pose_manifold);
      problem.AddParameterBlock(frame->speed_bias.data(), kSpeedBiasSize);
    }
    for (Residual& r : residuals) {
      problem.AddResidualBlock(r.cost.get(), const_cast<ceres::LossFunction*>(r.loss), r.parameters);
    }
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_SCHUR;
    solver.trust_region_strategy_type = ceres::DOGLEG;
    solver.max_num_iterations = options.max_iterations;
    solver.num_threads = 1;
    solver.function_tolerance = options.function_tolerance;
    solver.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    for (std::size_t peer = 0; peer < drift.size(); ++peer) {
      if (peers_used[peer]) drift_solved[peer] = Eigen::Vector4d(drift[peer].data());
    }
    statistics.solve_ms += Milliseconds(start);
  }

  // Drops features whose depth left the valid range or whose mean reprojection error is above outlier_px.
  // Returns how many of the newest frame's features it dropped.
  int RejectOutliers() {
    const auto frames = FramesBySerial();
    int dropped_in_newest = 0;
    for (auto it = tracks.begin(); it != tracks.end();) {
      Track& track = it->second;
      bool outlier = false;
      if (Usable(track, frames)) {
        outlier = !(track.inverse_depth > 0.0) || !DepthInRange(1.0 / track.inverse_depth);
        if (!outlier) {
          std::vector<Residual> residuals;
          VisualResiduals(track, frames, &residuals);
          double sum_px = 0.0;
          for (const Residual& r : residuals) {
            std::vector<const double*> values(r.parameters.begin(), r.parameters.end());
            Eigen::Vector2d e;
            r.cost->Evaluate(values.data(), e.data(), nullptr);
            sum_px += e.norm() / SqrtInformation() * rig.intrinsics.fx;
          }
          outlier = !residuals.empty() && sum_px / residuals.size() > options.outlier_px;
        }
      }
      if (outlier) {
        dropped_in_newest += track.observations.count(window.back()->serial) != 0;
        rejected.insert(it->first);
        it = tracks.erase(it);
      } else {
        ++it;
      }
    }
    return dropped_in_newest;
  }

  void RemoveFromTracks(std::uint64_t serial) {
    for (auto it = tracks.begin(); it != tracks.end();) {
      Track& track = it->second;
      const bool was_anchor = !track.observations.empty() && track.observations.begin()->first == serial;
      track.observations.erase(serial);
      if (track.observations.empty()) {
        it = tracks.erase(it);
        continue;
      }
      if (was_anchor) track.has_depth = false;  // triangulated again from the new anchor
      ++it;
    }
  }

  void MarginaliseOldest() {
    const auto start = std::chrono::steady_clock::now();
    WindowFrame& oldest = *window.front();
    std::vector<Residual> residuals = Residuals(true);
    std::vector<LinearisedBlock> blocks;
    std::vector<ParameterInfo> parameters;
    std::set<const double*> described;
    auto describe = [&](double* values, int size, bool is_pose) {
      if (described.insert(values).second) parameters.push_back({values, size, is_pose});
    };
    for (const auto& frame : window) {
      describe(frame->pose.data(), kPoseSize, true);
      describe(frame->speed_bias.data(), kSpeedBiasSize, false);
    }
    std::vector<double*> marginalised{oldest.pose.data(), oldest.speed_bias.data()};
    // The features anchored in the oldest keyframe go with it; their depth moves to their next observation.
    std::vector<std::pair<Track*, Eigen::Vector3d>> moved;
    const auto frames = FramesBySerial();
    for (auto& [id, track] : tracks) {
      if (!Usable(track, frames) || track.observations.begin()->first != oldest.serial) continue;
      describe(&track.inverse_depth, 1, false);
      marginalised.push_back(&track.inverse_depth);
      const Observation& anchor = track.observations.begin()->second;
      const Eigen::Vector3d p_L =
          Eigen::Vector3d(anchor.left.x(), anchor.left.y(), 1.0) / track.inverse_depth;
      moved.emplace_back(&track, PoseFromBlock(oldest.pose.data()) * rig.X_IL * p_L);
    }
    for (const Residual& r : residuals) blocks.push_back({r.cost.get(), r.loss, r.parameters});
    prior = std::make_shared<MarginalPrior>(Marginalise(blocks, parameters, marginalised));
    if (initial_prior && initial_prior->serial == oldest.serial) initial_prior.reset();

    const std::uint64_t serial = oldest.serial;
    ranges.erase(std::remove_if(ranges.begin(), ranges.end(),
                                [&](const RangeMeasurement& m) { return m.serial == serial; }),
                 ranges.end());
    window.pop_front();
    window.front()->imu.reset();
    RemoveFromTracks(serial);
    const auto remaining = FramesBySerial();
    for (auto& [track, p_W] : moved) {
      if (track->observations.empty() || remaining.count(track->observations.begin()->first) == 0) continue;
      const Eigen::Isometry3d X_WL =
          PoseFromBlock(remaining.at(track->observations.begin()->first)->pose.data()) * rig.X_IL;
      const double depth_m = (X_WL.inverse() * p_W).z();
      track->has_depth = DepthInRange(depth_m);
      if (track->has_depth) track->inverse_depth = 1.0 / depth_m;
    }
    statistics.marginalisation_ms += Milliseconds(start);
  }

  // --- lifecycle ---------------------------------------------------------------------------------------
  std::unique_ptr<WindowFrame> NewFrame(double t_s) {
    auto frame = std::make_unique<WindowFrame>();
    frame->serial = next_serial++;
    frame->t_s = t_s;
    frame->w_I_radps = SampleAt(t_s).w_I_radps;
    frame->attitude_WI = AttitudeAt(t_s);
    return frame;
  }

  void Start(double t_s, const NavState& state, const ImuBiases& biases, const StatePriorSigmas& sigmas) {
    window.clear();
    tracks.clear();
    rejected.clear();
    ranges.clear();
    prior.reset();
    std::unique_ptr<WindowFrame> frame = NewFrame(t_s);
    frame->keyframe = true;
    frame->Set(state, biases);
    initial_prior = InitialPrior{frame->serial, state, biases, sigmas};
    since_keyframe = std::make_shared<ImuPreintegration>(SampleAt(t_s), biases, options.imu_noise);
    window.push_back(std::move(frame));
    frames_since_start = 0;
    ++statistics.keyframes;
  }

  NavState GravityAligned() const {
    // At rest f = −R_WIᵀ g_W: R_WI maps the mean specific force to "up" (−z in NED); yaw is set to zero.
    Eigen::Vector3d f = Eigen::Vector3d::Zero();
    for (const auto& [t, sample] : imu) f += sample.f_I_mps2;
    const Eigen::Matrix3d R =
        Eigen::Quaterniond::FromTwoVectors(f, -Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const double yaw = std::atan2(R(1, 0), R(0, 0));
    NavState state;
    state.q_WI = Eigen::Quaterniond(Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R);
    return state;
  }

  std::optional<std::string> Failure(const Estimate& now, int dropped) const {
    std::ostringstream why;
    if (now.biases.accelerometer_mps2.norm() > options.max_accelerometer_bias_mps2) {
      why << "accelerometer bias " << now.biases.accelerometer_mps2.norm() << " m/s^2";
    } else if (now.biases.gyroscope_radps.norm() > options.max_gyroscope_bias_radps) {
      why << "gyroscope bias " << now.biases.gyroscope_radps.norm() << " rad/s";
    } else if (!now.state.p_WI_m.allFinite() || !now.state.v_WI_W_mps.allFinite() ||
               !now.state.q_WI.coeffs().allFinite()) {
      why << "a state that is not finite";
    } else if (frames_since_start >= 2 && now.features < options.min_features) {
      why << "only " << now.features << " features agree with the state";
    } else if (2 * dropped > now.features && now.features + dropped >= options.min_features) {
      why << dropped << " of " << now.features + dropped << " features disagree with the state";
    } else if (last_good) {
      const Eigen::Vector3d step = now.state.p_WI_m - last_good->state.p_WI_m;
      const double turn_deg =
          Log(Eigen::Quaterniond(last_good->state.q_WI.conjugate() * now.state.q_WI)).norm() * 180.0 / M_PI;
      if (step.norm() > options.max_step_m) {
        why << "a step of " << step.norm() << " m in one frame";
      } else if (std::abs(step.z()) > options.max_vertical_step_m) {
        why << "a vertical step of " << std::abs(step.z()) << " m in one frame";
      } else if (turn_deg > options.max_rotation_step_deg) {
        why << "a turn of " << turn_deg << " deg in one frame";
      }
    }
    if (why.str().empty()) return std::nullopt;
    return why.str();
  }

  Estimate Newest(bool keyframe, int features) const {
    const WindowFrame& f = *window.back();
    return {
        f.t_s, f.State(), f.Biases(), keyframe, false, features, f.w_I_radps - f.Biases().gyroscope_radps};
  }
};

Estimator::Estimator(const StereoRig& rig, const EstimatorOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (options.window_keyframes < 2) throw std::invalid_argument("estimator: window_keyframes must be >= 2");
  impl_->rig = rig;
  impl_->X_IR = rig.X_IL * Eigen::Translation3d(rig.baseline_m, 0.0, 0.0);
  impl_->options = options;
  impl_->g_W = Eigen::Vector3d(0.0, 0.0, options.gravity_mps2);
  impl_->loss = std::make_unique<ceres::CauchyLoss>(options.robust_loss_sigmas);
  impl_->range_loss = std::make_unique<ceres::HuberLoss>(options.range_huber_sigmas);
  impl_->kinematic_loss = std::make_unique<ceres::HuberLoss>(options.physical.huber_sigmas);
  const std::size_t peers = options.physical.link_lengths_m.size();
  impl_->peer_joints.resize(peers);
  impl_->drift.assign(peers, {0.0, 0.0, 0.0, 0.0});
  impl_->drift_solved.resize(peers);
  impl_->drift_centre.assign(peers, Eigen::Vector3d::Zero());
}

PeerJoint JointOf(const Estimate& estimate, const Eigen::Vector3d& p_IJ_m) {
  const NavState& s = estimate.state;
  return {s.p_WI_m + s.q_WI * p_IJ_m, s.v_WI_W_mps + s.q_WI * estimate.w_I_radps.cross(p_IJ_m)};
}

Estimator::~Estimator() = default;
Estimator::Estimator(Estimator&&) noexcept = default;
Estimator& Estimator::operator=(Estimator&&) noexcept = default;

void Estimator::SetInitialState(const NavState& state, const ImuBiases& biases) {
  impl_->given_initial_state = std::make_pair(state, biases);
}

void Estimator::AddImu(double t_s, const sensors::ImuSample& sample) {
  if (!impl_->imu.empty() && !(t_s > impl_->imu.back().first)) {
    std::ostringstream message;
    message << "estimator: IMU sample at t = " << t_s << " s is not after the previous one ("
            << impl_->imu.back().first << " s)";
    throw std::invalid_argument(message.str());
  }
  impl_->imu.emplace_back(t_s, sample);
}

void Estimator::AddAttitude(double t_s, const Eigen::Quaterniond& q_WI) {
  if ((!impl_->attitudes.empty() && !(t_s > impl_->attitudes.back().first)) || !q_WI.coeffs().allFinite()) {
    std::ostringstream message;
    message << "estimator: the attitude at t = " << t_s << " s must be finite and after the previous one";
    throw std::invalid_argument(message.str());
  }
  impl_->attitudes.emplace_back(t_s, q_WI.normalized());
}

void Estimator::AddPeerJoint(std::size_t peer, double t_s, const PeerJoint& joint) {
  if (peer >= impl_->peer_joints.size()) {
    std::ostringstream message;
    message << "estimator: peer " << peer << " has no link length (options.physical.link_lengths_m has "
            << impl_->peer_joints.size() << ")";
    throw std::invalid_argument(message.str());
  }
  std::map<double, PeerJoint>& joints = impl_->peer_joints[peer];
  if ((!joints.empty() && !(t_s > joints.rbegin()->first)) || !joint.p_WJ_m.allFinite() ||
      !joint.v_WJ_W_mps.allFinite()) {
    std::ostringstream message;
    message << "estimator: peer " << peer << "'s joint at t = " << t_s
            << " s must be finite and after its previous one";
    throw std::invalid_argument(message.str());
  }
  joints.emplace_hint(joints.end(), t_s, joint);
}

void Estimator::AddRange(double t_s, const Eigen::Vector3d& p_WA_m, double range_m, double sigma_m) {
  if (!(sigma_m > 0.0) || !std::isfinite(range_m) || !p_WA_m.allFinite()) {
    std::ostringstream message;
    message << "estimator: the range at t = " << t_s << " s needs a finite range and anchor and sigma_m > 0";
    throw std::invalid_argument(message.str());
  }
  if (!impl_->pending_ranges.empty() && t_s < impl_->pending_ranges.back().t_s) {
    std::ostringstream message;
    message << "estimator: the range at t = " << t_s << " s is older than the previous one ("
            << impl_->pending_ranges.back().t_s << " s)";
    throw std::invalid_argument(message.str());
  }
  impl_->pending_ranges.push_back({t_s, p_WA_m, range_m, sigma_m});
}

Estimate Estimator::AddFrame(const StereoFrame& frame) {
  Impl& s = *impl_;
  if (s.imu.empty() || s.imu.front().first > frame.t_s) {
    std::ostringstream message;
    message << "estimator: no IMU sample at or before the frame at t = " << frame.t_s << " s";
    throw std::invalid_argument(message.str());
  }
  if (!(frame.t_s > s.last_frame_t_s)) {
    std::ostringstream message;
    message << "estimator: the frame at t = " << frame.t_s << " s is not after the previous frame ("
            << s.last_frame_t_s << " s)";
    throw std::invalid_argument(message.str());
  }
  ++s.statistics.frames;

  if (s.window.empty()) {
    if (s.given_initial_state) {
      s.Start(frame.t_s, s.given_initial_state->first, s.given_initial_state->second,
              s.options.given_state_prior);
    } else {
      s.Start(frame.t_s, s.GravityAligned(), {}, s.options.gravity_aligned_prior);
    }
    s.AddObservations(s.window.back()->serial, frame);
    s.Triangulate();
    s.last_frame_t_s = frame.t_s;
    s.AttachRanges(frame.t_s);  // those at the first frame's time join it; earlier ones are dropped
    s.PruneInputs();
    s.last_good = s.Newest(true, 0);
    return *s.last_good;
  }

  // The previous frame, when it was not a keyframe, gives way to this one.
  if (!s.window.back()->keyframe) {
    s.RemoveFromTracks(s.window.back()->serial);
    s.window.pop_back();
  }
  s.AttachRanges(frame.t_s);
  s.IntegrateTo(s.since_keyframe.get(), s.last_frame_t_s, frame.t_s);
  const WindowFrame& keyframe = *s.window.back();
  std::unique_ptr<WindowFrame> newest = s.NewFrame(frame.t_s);
  newest->imu = std::make_shared<ImuPreintegration>(*s.since_keyframe);
  newest->Set(s.since_keyframe->Predict(keyframe.State(), keyframe.Biases(), s.g_W), keyframe.Biases());
  s.window.push_back(std::move(newest));
  s.AddObservations(s.window.back()->serial, frame);
  s.Triangulate();
  s.Solve();
  const int dropped = s.RejectOutliers();
  s.last_frame_t_s = frame.t_s;
  ++s.frames_since_start;

  Estimate estimate = s.Newest(frame.keyframe, s.NewestFeatures());
  if (const auto failure = s.Failure(estimate, dropped)) {
    ++s.statistics.failures;
    std::ostringstream why;
    why << "t = " << frame.t_s << " s: " << *failure;
    s.statistics.last_failure = why.str();
    // Restart from the last good estimate, carried to this frame by the IMU alone.
    ImuPreintegration carry(s.SampleAt(s.last_good->t_s), s.last_good->biases, s.options.imu_noise);
    s.IntegrateTo(&carry, s.last_good->t_s, frame.t_s);
    const NavState carried = carry.Predict(s.last_good->state, s.last_good->biases, s.g_W);
    s.Start(frame.t_s, carried, s.last_good->biases, s.options.reset_prior);
    s.AddObservations(s.window.back()->serial, frame);
    s.Triangulate();
    s.PruneInputs();
    estimate = s.Newest(true, 0);
    estimate.reset = true;
    s.last_good = estimate;
    return estimate;
  }
  if (frame.keyframe) {
    WindowFrame& f = *s.window.back();
    f.keyframe = true;
    ++s.statistics.keyframes;
    s.since_keyframe =
        std::make_shared<ImuPreintegration>(s.SampleAt(frame.t_s), f.Biases(), s.options.imu_noise);
    int keyframes = 0;
    for (const auto& w : s.window) keyframes += w->keyframe ? 1 : 0;
    if (keyframes > s.options.window_keyframes) s.MarginaliseOldest();
  }
  s.PruneInputs();
  s.last_good = estimate;
  return estimate;
}

const EstimatorStatistics& Estimator::statistics() const { return impl_->statistics; }

}  // namespace iapsim::vio
