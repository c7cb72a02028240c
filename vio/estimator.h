#pragma once
// The sliding-window visual-inertial estimator of one sub-aircraft (the seed's VINS baseline, [52]; stereo
// as VINS-Fusion): a window of keyframes plus the newest frame, each with pose, velocity and biases; features
// as inverse depths in the left eye of their first keyframe; IMU, reprojection and stereo residuals solved by
// Ceres; the oldest keyframe marginalised into a prior when the window is full; a frame that is not a
// keyframe stays only until the next frame replaces it (its IMU interval then continues from the last
// keyframe). Initialisation from a given state (the paper ties each sub-aircraft's frame to the first
// ground-truth pose) or from gravity (roll and pitch from the accelerometer, yaw and position zero), and
// failure detection with a reset from the last good estimate (VINS-Fusion's checks).
//
// The modes of seed §VI-G come from what is fed: images and IMU alone are VINS; with AddRange, VINS+UWB; with
// AddAttitude and the other sub-aircraft's shared joints (AddPeerJoint), VIRPO (eq. 22): each window frame
// gets r_kq against the flight controller's attitude and, per other sub-aircraft with a shared joint at that
// time, r_kp and r_kv through the platform's geometry, with a drift of the other's odometry (position and
// yaw, about where it is) estimated alongside under Table IX's prior and continuous sigmas.
//
// Deterministic: one thread, iteration limits only (no time limits), so the same inputs give the same
// estimates bit for bit.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sensors/imu.h"
#include "vio/state.h"
#include "vio/stereo_rig.h"
#include "vio/stereo_tracker.h"

namespace iapsim::vio {

/// VIRPO's physical terms (seed eq. 22), with Table IX's sigmas.
struct PhysicalConstraintOptions {
  Eigen::Vector3d p_IJ_m = Eigen::Vector3d::Zero();  ///< this sub-aircraft's spherical joint in I
  /// |d_i − d_o| to each other sub-aircraft (seed §III-A), indexed as AddPeerJoint's `peer`
  std::vector<double> link_lengths_m;
  double sigma_link_m = 0.04;        ///< σ_l
  double sigma_rate_radps = 0.1;     ///< σ_ω
  double sigma_attitude_rad = 0.01;  ///< σ_att
  /// The attitude estimate's error is not white: a gravity-referenced filter's tilt error is a slow bias
  /// (the accelerometer sees every sustained acceleration), correlated over seconds. Frames closer than
  /// that see the same error, so each frame's r_kq counts for the time slice since the window frame before
  /// it: its variance is σ_att² · max(1, 2τ/Δt), so that the frames of a span T ≫ τ together carry the
  /// variance of the error's mean over it, σ_att² 2τ/T for a first-order Gauss-Markov error (the integral
  /// of its autocorrelation σ² e^(−|u|/τ) is 2τσ²). 0: white, the seed's form.
  double attitude_correlation_s = 0.0;
  double drift_prior_position_m = 0.05;  ///< σ_drift,position^prior: at the first solve with a peer
  double drift_prior_yaw_rad = 0.1;      ///< σ_drift,yaw^prior
  double drift_step_position_m = 0.01;   ///< σ_drift,position^continuous: from one solve to the next
  double drift_step_yaw_rad = 0.04;      ///< σ_drift,yaw^continuous
  double huber_sigmas = 3.0;             ///< Huber loss on whitened r_kp and r_kv (a peer may fail)
  /// A window frame between two shared joints is constrained by their interpolation, one after the last
  /// shared joint (a peer solving the same instant has not shared it yet) by the last one carried by its
  /// velocity, up to this long.
  double max_peer_extrapolation_s = 0.1;
};

struct EstimatorOptions {
  int window_keyframes = 10;  ///< VINS's WINDOW_SIZE
  double pixel_sigma_px = 1.5;
  double robust_loss_sigmas = 1.0;  ///< Cauchy loss scale on whitened reprojection residuals
  int max_iterations = 8;           ///< VINS's NUM_ITERATIONS
  /// A solve ends when an iteration changes the cost by less than this fraction (Ceres's
  /// function_tolerance, its default 1e-6). Each frame's solve starts from the last one's, so the tail of
  /// iterations a tighter tolerance adds move the estimate by less than the noise: on the recorded
  /// figure-eight and pilot flights 1e-5 cut about one iteration in four and took the VIRPO runner on the
  /// pilot flight from 0.87-0.99x to 1.07-1.08x real time, every ATE within 1 mm (vio/README.md).
  double function_tolerance = 1e-5;
  double min_depth_m = 0.2;
  double max_depth_m = 80.0;
  double outlier_px = 3.0;  ///< a feature whose mean reprojection error exceeds this is dropped
  Eigen::Vector3d p_IT_m = Eigen::Vector3d::Zero();  ///< the UWB tag in the IMU frame
  double range_huber_sigmas = 3.0;                   ///< Huber loss on whitened UWB range residuals
  double gravity_mps2 = 9.81;
  sensors::ImuNoise imu_noise = sensors::TableViNoise();
  StatePriorSigmas given_state_prior{};  ///< around a state from SetInitialState
  /// Around a gravity-aligned start: position and yaw fix the gauge, the tilt and velocity are loose.
  StatePriorSigmas gravity_aligned_prior{1e-3, 0.05, 1e-3, 0.5, 0.01, 0.1};
  /// Around the last good estimate after a failure: that estimate carried to the frame by the IMU alone
  /// sets position and yaw; its velocity may be what failed, so it is held loosely.
  StatePriorSigmas reset_prior{1e-3, 0.02, 1e-3, 10.0, 0.01, 0.1};
  /// Failure checks on the newest estimate against the previous one (VINS-Fusion's failureDetection), and
  /// the images' verdict on the state: more than a third of the newest frame's features dropped as outliers
  /// in one solve, or fewer than `min_features` left in it (from the third frame after a start on).
  int min_features = 10;
  double max_accelerometer_bias_mps2 = 2.5;
  double max_gyroscope_bias_radps = 1.0;
  double max_step_m = 5.0;
  double max_vertical_step_m = 1.0;
  double max_rotation_step_deg = 50.0;
  PhysicalConstraintOptions physical;
};

struct Estimate {
  double t_s = 0.0;
  NavState state;
  ImuBiases biases;
  bool keyframe = false;
  bool reset =
      false;  ///< a failure was detected at this frame: the estimator restarted from the last good estimate
  int features = 0;                                     ///< features in this frame's solve
  Eigen::Vector3d w_I_radps = Eigen::Vector3d::Zero();  ///< the gyroscope at the frame, less the bias
};

/// The joint of a sub-aircraft whose IMU has this estimate, as it shares it with the others (VIRPO).
PeerJoint JointOf(const Estimate& estimate, const Eigen::Vector3d& p_IJ_m);

struct EstimatorStatistics {
  int frames = 0;
  int keyframes = 0;
  int failures = 0;
  std::string last_failure;
  int ranges_used = 0;
  int ranges_dropped = 0;         ///< older than the frame before them, or before the first frame
  int attitude_constraints = 0;   ///< r_kq blocks over all solves
  int kinematic_constraints = 0;  ///< r_kp/r_kv pairs over all solves
  double solve_ms = 0.0;          ///< totals
  double marginalisation_ms = 0.0;
};

class Estimator {
 public:
  explicit Estimator(const StereoRig& rig, const EstimatorOptions& options = {});
  ~Estimator();
  Estimator(Estimator&&) noexcept;
  Estimator& operator=(Estimator&&) noexcept;

  /// The state at the first frame (before it arrives). Without it the estimator aligns with gravity.
  void SetInitialState(const NavState& state, const ImuBiases& biases = {});
  /// An IMU sample, in increasing time. Throws std::invalid_argument otherwise.
  void AddImu(double t_s, const sensors::ImuSample& sample);
  /// A UWB range (`vio_uwb`, seed Tables VII, X, XI) from the tag (EstimatorOptions::p_IT_m) to an anchor at
  /// p_WA_m, with its standard deviation. The anchors are in W, so the estimator's frame must be W: give
  /// SetInitialState. The range joins the newest keyframe at the next frame, through the IMU between them; a
  /// range older than the last frame is dropped (counted).
  void AddRange(double t_s, const Eigen::Vector3d& p_WA_m, double range_m, double sigma_m);
  /// The flight controller's attitude estimate of the IMU, R̂_WI (VIRPO's r_kq), in increasing time: a
  /// frame between two samples gets their interpolation. Throws std::invalid_argument otherwise.
  void AddAttitude(double t_s, const Eigen::Quaterniond& q_WI);
  /// Another sub-aircraft's joint as it shared it at t_s (VIRPO's r_kp, r_kv), in increasing time per peer;
  /// `peer` indexes PhysicalConstraintOptions::link_lengths_m. Throws std::invalid_argument otherwise.
  void AddPeerJoint(std::size_t peer, double t_s, const PeerJoint& joint);
  /// A tracked stereo frame, after the IMU samples up to its time (a sample after it is used to interpolate;
  /// without one the last sample is held). Throws std::invalid_argument when no IMU sample came before it or
  /// its time is not after the previous frame's. A failure restarts the window at this frame, with its
  /// features, from the last good estimate (the returned estimate says `reset`); the tracker goes on.
  Estimate AddFrame(const StereoFrame& frame);

  const EstimatorStatistics& statistics() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iapsim::vio
