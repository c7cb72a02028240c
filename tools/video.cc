#include "tools/video.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "tools/media.h"

namespace iapsim::tools {
namespace {

constexpr char kImageSuffix[] = "/image_raw/compressed";

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

}  // namespace

nlohmann::json ToJson(const CameraVideo& video) {
  return {{"topic", video.topic},
          {"video", video.video_path},
          {"sheet", video.sheet_path},
          {"codec", video.codec},
          {"images", video.images},
          {"frames", video.frames},
          {"frames_per_s", video.frames_per_s}};
}

CameraVideo CameraVideoFromJson(const nlohmann::json& json) {
  CameraVideo video;
  video.topic = json.at("topic").get<std::string>();
  video.video_path = json.at("video").get<std::string>();
  video.sheet_path = json.at("sheet").get<std::string>();
  video.codec = json.at("codec").get<std::string>();
  video.images = json.at("images").get<std::size_t>();
  video.frames = json.at("frames").get<std::size_t>();
  video.frames_per_s = json.at("frames_per_s").get<double>();
  return video;
}

CameraVideo WriteCameraVideo(const std::string& bag_path, const std::string& camera,
                             const std::string& video_path) {
  return CameraVideoFromJson(RunMedia({"video", bag_path, camera, video_path}));
}

std::string CameraImageTopic(const std::string& camera) {
  std::string topic = camera.empty() || camera[0] != '/' ? "/" + camera : camera;
  return EndsWith(topic, kImageSuffix) ? topic : topic + kImageSuffix;
}

std::string DefaultVideoPath(const std::string& bag_path, const std::string& camera) {
  std::string name = CameraImageTopic(camera);
  name = name.substr(1, name.size() - 1 - std::string(kImageSuffix).size());
  std::replace(name.begin(), name.end(), '/', '_');
  return (std::filesystem::path(bag_path).parent_path() / (name + ".mp4")).string();
}

void PrintCameraVideo(const CameraVideo& video) {
  std::printf("  %s  %zu images of %s, %zu frames at %.1f fps (%s)\n", video.video_path.c_str(), video.images,
              video.topic.c_str(), video.frames, video.frames_per_s, video.codec.c_str());
  std::printf("  %s  six moments of it\n", video.sheet_path.c_str());
}

}  // namespace iapsim::tools
