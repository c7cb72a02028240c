#pragma once
// `iapsim video` and `iapsim run --video`: a camera's recorded images as an MP4 at sim-time speed, and a
// contact sheet of six moments of it, for a person to watch a flight. The encoding runs in `iapsim_media`
// (tools/media.h): OpenCV's codecs and the renderer's libraries stay out of the `iapsim` program.

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>

namespace iapsim::tools {

struct CameraVideo {
  std::string topic;       // the CompressedImage topic read
  std::string video_path;  // the MP4
  std::string sheet_path;  // six frames spread over the flight, PNG
  std::string codec;
  std::size_t images = 0;  // images in the bag
  std::size_t frames = 0;  // video frames (an image repeats where the renderer skipped frames)
  double frames_per_s = 0.0;
};
nlohmann::json ToJson(const CameraVideo& video);
CameraVideo CameraVideoFromJson(const nlohmann::json& json);

/// Reads the images of `camera` from the bag (an eye's namespace such as iap/platform/chase or
/// /iap/sub1/stereo/left, or its .../image_raw/compressed topic) and writes `video_path` and, next to it,
/// <stem>_frames.png. The video runs at the images' rate (the median stamp step) on their stamps' timeline.
/// Throws std::runtime_error naming the bag and listing its image topics when the camera has none.
CameraVideo WriteCameraVideo(const std::string& bag_path, const std::string& camera,
                             const std::string& video_path);

/// The CompressedImage topic of a camera: /iap/sub1/stereo/left/image_raw/compressed for
/// iap/sub1/stereo/left.
std::string CameraImageTopic(const std::string& camera);

/// <bag's folder>/<camera namespace with '_' for '/'>.mp4, e.g. run/iap_platform_chase.mp4.
std::string DefaultVideoPath(const std::string& bag_path, const std::string& camera);

/// Prints where the video and its sheet went.
void PrintCameraVideo(const CameraVideo& video);

}  // namespace iapsim::tools
