#include "vio/stereo_tracker.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <stdexcept>
#include <string>

namespace iapsim::vio {
namespace {

// The features of one image: positions, ids and track lengths in step.
struct Features {
  std::vector<cv::Point2f> points;
  std::vector<std::uint64_t> ids;
  std::vector<int> lengths;

  void Keep(const std::vector<bool>& keep) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!keep[i]) continue;
      points[kept] = points[i];
      ids[kept] = ids[i];
      lengths[kept] = lengths[i];
      ++kept;
    }
    points.resize(kept);
    ids.resize(kept);
    lengths.resize(kept);
  }
};

cv::Mat Gray(const render::Image& image, const render::CameraIntrinsics& intrinsics, const char* eye) {
  if (image.width != intrinsics.width || image.height != intrinsics.height ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3) {
    throw std::invalid_argument(std::string("stereo tracker: the ") + eye + " image is " +
                                std::to_string(image.width) + "x" + std::to_string(image.height) +
                                ", the camera model expects " + std::to_string(intrinsics.width) + "x" +
                                std::to_string(intrinsics.height) + " RGB");
  }
  const cv::Mat rgb(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.rgb.data()));
  cv::Mat gray;
  cv::cvtColor(rgb, gray, cv::COLOR_RGB2GRAY);
  return gray;
}

}  // namespace

struct StereoTracker::State {
  StereoRig rig;
  TrackerOptions options;
  std::vector<cv::Mat> previous_pyramid;  // of the previous left image, empty before the first frame
  Features features;
  std::uint64_t next_id = 0;
  std::map<std::uint64_t, cv::Point2f> keyframe_points;
  bool has_keyframe = false;

  std::vector<cv::Mat> Pyramid(const cv::Mat& gray) const {
    std::vector<cv::Mat> pyramid;
    cv::buildOpticalFlowPyramid(gray, pyramid, cv::Size(options.klt_window_px, options.klt_window_px),
                                options.pyramid_levels);
    return pyramid;
  }

  bool Inside(const cv::Point2f& p) const {
    constexpr float kBorder_px = 1.0f;
    return p.x >= kBorder_px && p.y >= kBorder_px && p.x < rig.intrinsics.width - 1 - kBorder_px &&
           p.y < rig.intrinsics.height - 1 - kBorder_px;
  }

  // Lucas-Kanade from one pyramid to the other and back: a point is kept when both directions converge,
  // it lands inside the image and the backward track returns within forward_backward_px of where it began.
  // The backward track starts where the point began, which is its answer if the forward track is right,
  // so it needs no coarse levels: it runs on the full image and one level above it, as VINS-Fusion's
  // reverse check does (feature_tracker.cpp, FLOW_BACK), at half the cost of the full pyramid.
  std::vector<bool> Flow(const std::vector<cv::Mat>& from, const std::vector<cv::Mat>& to,
                         const std::vector<cv::Point2f>& from_points,
                         std::vector<cv::Point2f>* to_points) const {
    std::vector<bool> ok(from_points.size(), false);
    if (from_points.empty()) return ok;
    const cv::Size window(options.klt_window_px, options.klt_window_px);
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
    std::vector<uchar> forward, backward;
    std::vector<float> error;
    cv::calcOpticalFlowPyrLK(from, to, from_points, *to_points, forward, error, window,
                             options.pyramid_levels, criteria);
    std::vector<cv::Point2f> back = from_points;
    cv::calcOpticalFlowPyrLK(to, from, *to_points, back, backward, error, window,
                             std::min(options.pyramid_levels, 1), criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
    for (std::size_t i = 0; i < from_points.size(); ++i) {
      ok[i] = forward[i] && backward[i] && Inside((*to_points)[i]) &&
              cv::norm(back[i] - from_points[i]) <= options.forward_backward_px;
    }
    return ok;
  }
};

StereoTracker::StereoTracker(const StereoRig& rig, const TrackerOptions& options)
    : state_(std::make_unique<State>()) {
  if (!rig.intrinsics.IsValid())
    throw std::invalid_argument("stereo tracker: the camera intrinsics are invalid");
  state_->rig = rig;
  state_->options = options;
}

StereoTracker::~StereoTracker() = default;
StereoTracker::StereoTracker(StereoTracker&&) noexcept = default;
StereoTracker& StereoTracker::operator=(StereoTracker&&) noexcept = default;

void StereoTracker::Reset() {
  state_->previous_pyramid.clear();
  state_->features = Features{};
  state_->keyframe_points.clear();
  state_->has_keyframe = false;
}

StereoFrame StereoTracker::Track(double t_s, const render::Image& left, const render::Image& right) {
  State& s = *state_;
  const TrackerOptions& o = s.options;
  const cv::Mat left_gray = Gray(left, s.rig.intrinsics, "left");
  const std::vector<cv::Mat> left_pyramid = s.Pyramid(left_gray);
  const std::vector<cv::Mat> right_pyramid = s.Pyramid(Gray(right, s.rig.intrinsics, "right"));
  StereoFrame frame;
  frame.t_s = t_s;

  // 1. Frame to frame: forward-backward KLT, then RANSAC on the epipolar geometry of what survived.
  Features& features = s.features;
  if (!s.previous_pyramid.empty() && !features.points.empty()) {
    std::vector<cv::Point2f> tracked;
    std::vector<bool> keep = s.Flow(s.previous_pyramid, left_pyramid, features.points, &tracked);
    frame.rejected_forward_backward = static_cast<int>(std::count(keep.begin(), keep.end(), false));
    std::vector<cv::Point2f> from, to;
    std::vector<std::size_t> index;
    for (std::size_t i = 0; i < keep.size(); ++i) {
      if (!keep[i]) continue;
      from.push_back(features.points[i]);
      to.push_back(tracked[i]);
      index.push_back(i);
    }
    if (from.size() >= 8) {
      std::vector<uchar> inlier;
      const cv::Mat F = cv::findFundamentalMat(from, to, cv::FM_RANSAC, o.ransac_threshold_px, 0.99, inlier);
      if (!F.empty()) {
        for (std::size_t k = 0; k < index.size(); ++k) {
          if (inlier[k]) continue;
          keep[index[k]] = false;
          ++frame.rejected_ransac;
        }
      }
    }
    features.points = tracked;
    features.Keep(keep);
    for (int& length : features.lengths) ++length;
  } else {
    features = Features{};
  }

  // 2. New corners where there is room: the longest tracks claim their neighbourhood first, and a feature
  // inside a longer track's min_distance_px is dropped (it would only duplicate that track).
  {
    std::vector<std::size_t> order(features.points.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return features.lengths[a] > features.lengths[b]; });
    cv::Mat mask(left_gray.size(), CV_8UC1, cv::Scalar(255));
    const int radius = static_cast<int>(o.min_distance_px);
    std::vector<bool> keep(features.points.size(), false);
    for (std::size_t i : order) {
      const cv::Point pixel(cvRound(features.points[i].x), cvRound(features.points[i].y));
      if (mask.at<uchar>(pixel) == 0) continue;
      keep[i] = true;
      cv::circle(mask, pixel, radius, cv::Scalar(0), cv::FILLED);
    }
    features.Keep(keep);
    const int wanted = o.max_features - static_cast<int>(features.points.size());
    if (wanted > 0) {
      std::vector<cv::Point2f> corners;
      cv::goodFeaturesToTrack(left_gray, corners, wanted, o.corner_quality, o.min_distance_px, mask);
      for (const cv::Point2f& corner : corners) {
        features.points.push_back(corner);
        features.ids.push_back(s.next_id++);
        features.lengths.push_back(1);
      }
    }
  }

  // 3. Left to right along the rectified rows: a match must stay on its row and have a disparity ≥ 0.
  std::vector<cv::Point2f> in_right;
  const std::vector<bool> matched = s.Flow(left_pyramid, right_pyramid, features.points, &in_right);

  std::vector<std::size_t> by_id(features.points.size());
  std::iota(by_id.begin(), by_id.end(), 0);
  std::sort(by_id.begin(), by_id.end(),
            [&](std::size_t a, std::size_t b) { return features.ids[a] < features.ids[b]; });
  for (std::size_t i : by_id) {
    TrackedFeature feature;
    feature.id = features.ids[i];
    feature.uv_left = {features.points[i].x, features.points[i].y};
    feature.track_length = features.lengths[i];
    const cv::Point2f d = features.points[i] - in_right[i];
    if (matched[i] && std::abs(d.y) <= o.stereo_row_tolerance_px && d.x >= 0.0f) {
      feature.uv_right = Eigen::Vector2d(in_right[i].x, in_right[i].y);
    }
    frame.features.push_back(feature);
  }

  // 4. Keyframe: the first frame, or enough parallax since the last keyframe, or too few of its features
  // left.
  double parallax_sum_px = 0.0;
  for (std::size_t i = 0; i < features.points.size(); ++i) {
    const auto it = s.keyframe_points.find(features.ids[i]);
    if (it == s.keyframe_points.end()) continue;
    parallax_sum_px += cv::norm(features.points[i] - it->second);
    ++frame.tracked_since_keyframe;
  }
  frame.parallax_px = frame.tracked_since_keyframe > 0 ? parallax_sum_px / frame.tracked_since_keyframe : 0.0;
  const double parallax_threshold_px = o.keyframe_parallax_px_at_460 * s.rig.intrinsics.fx / 460.0;
  frame.keyframe = !s.has_keyframe || frame.tracked_since_keyframe < o.keyframe_min_tracked ||
                   frame.parallax_px >= parallax_threshold_px;
  if (frame.keyframe) {
    s.keyframe_points.clear();
    for (std::size_t i = 0; i < features.points.size(); ++i)
      s.keyframe_points[features.ids[i]] = features.points[i];
    s.has_keyframe = true;
  }
  s.previous_pyramid = left_pyramid;
  return frame;
}

}  // namespace iapsim::vio
