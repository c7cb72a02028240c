#include "vio/config.h"

#include <limits>
#include <utility>

namespace iapsim::vio {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

void ReadTracker(bridge::YamlMap& map, TrackerOptions* o) {
  map.OptionalInRange("max_features", &o->max_features, 8, 10000);
  map.OptionalInRange("min_distance_px", &o->min_distance_px, 1.0, 1000.0);
  map.OptionalInRange("corner_quality", &o->corner_quality, 1e-6, 1.0);
  map.OptionalInRange("klt_window_px", &o->klt_window_px, 5, 101);
  map.OptionalInRange("pyramid_levels", &o->pyramid_levels, 0, 8);
  map.OptionalInRange("forward_backward_px", &o->forward_backward_px, 0.01, 100.0);
  map.OptionalInRange("ransac_threshold_px", &o->ransac_threshold_px, 0.01, 100.0);
  map.OptionalInRange("stereo_row_tolerance_px", &o->stereo_row_tolerance_px, 0.01, 100.0);
  map.OptionalInRange("keyframe_parallax_px_at_460", &o->keyframe_parallax_px_at_460, 0.1, 1000.0);
  map.OptionalInRange("keyframe_min_tracked", &o->keyframe_min_tracked, 0, 10000);
  map.Finish();
}

void ReadEstimator(bridge::YamlMap& map, EstimatorOptions* o) {
  map.OptionalInRange("window_keyframes", &o->window_keyframes, 2, 100);
  map.OptionalInRange("pixel_sigma_px", &o->pixel_sigma_px, 1e-3, 100.0);
  map.OptionalInRange("robust_loss_sigmas", &o->robust_loss_sigmas, 1e-3, 1e3);
  map.OptionalInRange("max_iterations", &o->max_iterations, 1, 1000);
  map.OptionalInRange("function_tolerance", &o->function_tolerance, 1e-12, 0.1);
  map.OptionalInRange("min_depth_m", &o->min_depth_m, 1e-3, 1e3);
  map.OptionalInRange("max_depth_m", &o->max_depth_m, o->min_depth_m, 1e6);
  map.OptionalInRange("outlier_px", &o->outlier_px, 0.01, 1e3);
  map.OptionalInRange("range_huber_sigmas", &o->range_huber_sigmas, 0.01, 1e3);
  map.OptionalInRange("min_features", &o->min_features, 0, 10000);
  map.Finish();
}

void ReadPhysical(bridge::YamlMap& map, PhysicalConstraintOptions* o) {
  map.OptionalInRange("sigma_link_m", &o->sigma_link_m, 1e-6, kInfinity);
  map.OptionalInRange("sigma_rate_radps", &o->sigma_rate_radps, 1e-6, kInfinity);
  map.OptionalInRange("sigma_attitude_rad", &o->sigma_attitude_rad, 1e-6, kInfinity);
  map.OptionalInRange("attitude_correlation_s", &o->attitude_correlation_s, 0.0, 1e3);
  map.OptionalInRange("drift_prior_position_m", &o->drift_prior_position_m, 1e-9, kInfinity);
  map.OptionalInRange("drift_prior_yaw_rad", &o->drift_prior_yaw_rad, 1e-9, kInfinity);
  map.OptionalInRange("drift_step_position_m", &o->drift_step_position_m, 1e-9, kInfinity);
  map.OptionalInRange("drift_step_yaw_rad", &o->drift_step_yaw_rad, 1e-9, kInfinity);
  map.OptionalInRange("huber_sigmas", &o->huber_sigmas, 0.01, 1e3);
  map.OptionalInRange("max_peer_extrapolation_s", &o->max_peer_extrapolation_s, 0.0, 10.0);
  map.Finish();
}

}  // namespace

VioConfig ReadVioConfig(bridge::YamlMap& map, VioConfig defaults) {
  VioConfig config = std::move(defaults);
  bridge::YamlMap tracker = map.Map("tracker");
  ReadTracker(tracker, &config.tracker);
  bridge::YamlMap estimator = map.Map("estimator");
  ReadEstimator(estimator, &config.estimator);
  bridge::YamlMap uwb = map.Map("uwb");
  if (uwb.Has("sigma_m")) {
    double sigma_m = config.range_sigma_m.value_or(0.0);
    uwb.OptionalInRange("sigma_m", &sigma_m, 1e-6, 1e3);
    config.range_sigma_m = sigma_m;
  }
  if (uwb.Has("anchors")) {
    const YAML::Node names = uwb.Raw("anchors");
    if (!names.IsSequence()) uwb.Fail("anchors", "expected a list of anchor names, e.g. [anchor1, anchor3]");
    config.anchors.emplace();
    for (const YAML::Node& name : names) {
      if (!name.IsScalar() || name.Scalar().empty()) uwb.FailAt(name, "anchors", "expected an anchor's name");
      config.anchors->push_back(name.Scalar());
    }
    uwb.SetResolved("anchors", names);
  }
  uwb.Finish();
  bridge::YamlMap virpo = map.Map("virpo");
  ReadPhysical(virpo, &config.estimator.physical);
  return config;
}

VioConfig LoadVioConfig(const std::string& path, const std::vector<std::string>& overrides) {
  const std::string file = path.empty() ? "--set" : path;
  YAML::Node root = path.empty() ? YAML::Node(YAML::NodeType::Map) : bridge::LoadYamlFile(path);
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  for (const std::string& assignment : overrides) bridge::ApplyOverride(root, assignment, file);
  bridge::YamlMap map(root, file);
  VioConfig config = ReadVioConfig(map);
  map.Finish();
  return config;
}

}  // namespace iapsim::vio
