#pragma once
// The estimator's settings as a user gives them (`iapsim vio --config FILE --set KEY=VALUE`, and the vio
// process's params): the front end, the sliding window and VIRPO's sigmas, every key optional with the
// defaults of TrackerOptions, EstimatorOptions and PhysicalConstraintOptions (seed Table IX). What the run
// itself fixes (cameras, IMU mounting and noise, anchors, the platform's geometry) comes from its scenario,
// not from here.
//
//   tracker:   {max_features, min_distance_px, corner_quality, klt_window_px, pyramid_levels,
//               forward_backward_px, ransac_threshold_px, stereo_row_tolerance_px,
//               keyframe_parallax_px_at_460, keyframe_min_tracked}
//   estimator: {window_keyframes, pixel_sigma_px, robust_loss_sigmas, max_iterations, function_tolerance,
//               min_depth_m, max_depth_m, outlier_px, range_huber_sigmas, min_features}
//   uwb:       {sigma_m,      range sigma (default: the sensor's own, from the scenario)
//               anchors}      the names of the anchors to range to (default: all of the scenario's)
//   virpo:     {sigma_link_m, sigma_rate_radps, sigma_attitude_rad, attitude_correlation_s,
//               drift_prior_position_m, drift_prior_yaw_rad, drift_step_position_m,
//               drift_step_yaw_rad, huber_sigmas, max_peer_extrapolation_s}

#include <optional>
#include <string>
#include <vector>

#include "bridge/config.h"
#include "vio/estimator.h"
#include "vio/stereo_tracker.h"

namespace iapsim::vio {

struct VioConfig {
  TrackerOptions tracker;
  EstimatorOptions estimator;  ///< imu_noise, p_IT_m and the physical geometry are the run's, set later
  std::optional<double> range_sigma_m;
  std::optional<std::vector<std::string>> anchors;  ///< a subset of the scenario's, by name
};

/// Reads the keys above from `map` over `defaults` (each checked; the caller finishes the map, so that
/// unknown keys are errors naming the file and line).
VioConfig ReadVioConfig(bridge::YamlMap& map, VioConfig defaults = {});

/// Loads `path` (empty: the defaults) with `overrides` ("estimator.window_keyframes=8") applied. Throws
/// bridge::ConfigError naming the file and key.
VioConfig LoadVioConfig(const std::string& path, const std::vector<std::string>& overrides);

}  // namespace iapsim::vio
