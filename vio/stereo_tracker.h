#pragma once
// The visual front end of one stereo pair (the design of VINS-Fusion's feature tracker, Qin et al.; the
// seed's [52] is its monocular predecessor): Shi-Tomasi corners kept apart by a minimum spacing, pyramidal
// Lucas-Kanade tracking from frame to frame with a forward-backward check and a fundamental-matrix RANSAC
// over the survivors, left-to-right matching of every feature along the rectified rows, and keyframe
// selection by the mean parallax since the last keyframe and by the number of features still tracked.
// OpenCV does the image work; nothing of it appears in this header.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "render/image.h"
#include "vio/stereo_rig.h"

namespace iapsim::vio {

/// Defaults are VINS-Fusion's (euroc_stereo_imu_config.yaml, for 752×480 images): 150 features 30 px apart,
/// a 21 px KLT window on 4 pyramid levels, 0.5 px forward-backward, 1 px RANSAC, keyframes at 10 px of
/// parallax for a 460 px focal length (scaled here by the rig's focal length).
struct TrackerOptions {
  int max_features = 150;
  double min_distance_px = 30.0;
  double corner_quality = 0.01;  ///< Shi-Tomasi: the weakest corner kept, relative to the strongest
  int klt_window_px = 21;
  int pyramid_levels = 3;  ///< levels above the full image
  double forward_backward_px = 0.5;
  double ransac_threshold_px = 1.0;
  double stereo_row_tolerance_px = 1.5;  ///< |v_left − v_right| of a match in the rectified pair
  double keyframe_parallax_px_at_460 = 10.0;
  int keyframe_min_tracked = 20;  ///< fewer features tracked since the last keyframe: a new keyframe
};

struct TrackedFeature {
  std::uint64_t id = 0;  ///< the same id for as long as the feature is tracked; never reused
  Eigen::Vector2d uv_left = Eigen::Vector2d::Zero();
  std::optional<Eigen::Vector2d> uv_right;  ///< when matched in the right image
  int track_length = 1;                     ///< frames seen, this one included
};

struct StereoFrame {
  double t_s = 0.0;
  std::vector<TrackedFeature> features;  ///< in increasing id
  bool keyframe = false;
  double parallax_px = 0.0;        ///< mean since the last keyframe, over the features seen in both
  int tracked_since_keyframe = 0;  ///< of the last keyframe's features, how many this frame still has
  int rejected_forward_backward = 0;
  int rejected_ransac = 0;
};

class StereoTracker {
 public:
  explicit StereoTracker(const StereoRig& rig, const TrackerOptions& options = {});
  ~StereoTracker();
  StereoTracker(StereoTracker&&) noexcept;
  StereoTracker& operator=(StereoTracker&&) noexcept;

  /// Tracks the previous frame's features into this pair, matches them left to right, and adds new corners
  /// where the image has room. Throws std::invalid_argument when an image's size is not the rig's.
  StereoFrame Track(double t_s, const render::Image& left, const render::Image& right);
  /// Forgets every feature and the last keyframe: the next frame starts fresh (after an estimator reset).
  void Reset();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace iapsim::vio
