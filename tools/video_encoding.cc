#include <sensor_msgs/CompressedImage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "bridge/bag.h"
#include "bridge/eigen_msgs.h"
#include "bridge/message.h"
#include "render/image.h"
#include "render/video.h"
#include "tools/media.h"

namespace iapsim::tools {
namespace {

constexpr int kSheetImages = 6;

sensor_msgs::CompressedImage DecodeImageMessage(const bridge::BagMessage& m) {
  sensor_msgs::CompressedImage image;
  std::string error;
  if (!bridge::Decode(m.bytes, &image, &error)) throw std::runtime_error(m.topic + ": " + error);
  return image;
}

}  // namespace

CameraVideo EncodeCameraVideo(const std::string& bag_path, const std::string& camera,
                              const std::string& video_path) {
  CameraVideo out;
  out.topic = CameraImageTopic(camera);
  out.video_path = video_path;
  const std::filesystem::path path(video_path);
  out.sheet_path = (path.parent_path() / (path.stem().string() + "_frames.png")).string();

  const bridge::BagReader bag(bag_path);
  std::vector<int64_t> stamps_ns;
  bag.ForEach({out.topic}, [&](const bridge::BagMessage& m) {
    stamps_ns.push_back(bridge::ToNanoseconds(DecodeImageMessage(m).header.stamp));
    return true;
  });
  if (stamps_ns.empty()) {
    std::string available;
    for (const bridge::BagTopicInfo& t : bag.Topics()) {
      if (t.datatype == "sensor_msgs/CompressedImage") available += "\n  " + t.topic;
    }
    throw std::runtime_error(
        bag_path + ": no images on " + out.topic + "; the bag's image topics:" +
        (available.empty() ? std::string(" none (was a render process recorded?)") : available));
  }
  out.images = stamps_ns.size();
  std::vector<double> steps_s;
  for (size_t i = 1; i < stamps_ns.size(); ++i)
    steps_s.push_back(static_cast<double>(stamps_ns[i] - stamps_ns[i - 1]) * 1e-9);
  double step_s = 0.05;  // one image: a still of 20 Hz
  if (!steps_s.empty()) {
    std::nth_element(steps_s.begin(), steps_s.begin() + static_cast<long>(steps_s.size() / 2), steps_s.end());
    step_s = std::max(steps_s[steps_s.size() / 2], 1e-3);
  }
  out.frames_per_s = 1.0 / step_s;

  // the sheet's moments: images spread evenly over the recording
  std::vector<size_t> sheet_indices;
  for (int i = 0; i < kSheetImages; ++i) {
    sheet_indices.push_back(static_cast<size_t>(
        std::lround(static_cast<double>(i) * static_cast<double>(out.images - 1) / (kSheetImages - 1))));
  }
  std::vector<render::Image> sheet;
  std::vector<std::string> labels;

  // the video runs on the stamps' timeline: frame j shows the newest image stamped at or before t0 + j·step
  std::unique_ptr<render::VideoWriter> writer;
  render::Image current;
  const int64_t t0_ns = stamps_ns.front();
  const auto emit_until = [&](double t_s) {
    while (static_cast<double>(out.frames) * step_s < t_s - 0.5 * step_s) {
      writer->Add(current);
      ++out.frames;
    }
  };
  size_t index = 0;
  bag.ForEach({out.topic}, [&](const bridge::BagMessage& m) {
    const sensor_msgs::CompressedImage message = DecodeImageMessage(m);
    const double t_s = static_cast<double>(bridge::ToNanoseconds(message.header.stamp) - t0_ns) * 1e-9;
    if (writer) emit_until(t_s);
    current =
        render::DecodeImage(message.data, bag_path + " " + out.topic + " image " + std::to_string(index));
    if (!writer) {
      writer =
          std::make_unique<render::VideoWriter>(video_path, out.frames_per_s, current.width, current.height);
      out.codec = writer->codec();
    }
    if (std::count(sheet_indices.begin(), sheet_indices.end(), index)) {
      sheet.push_back(current);
      char label[32];
      std::snprintf(label, sizeof(label), "t = %.2f s", bridge::ToNanoseconds(message.header.stamp) * 1e-9);
      labels.push_back(label);
    }
    ++index;
    return true;
  });
  emit_until(static_cast<double>(stamps_ns.back() - t0_ns) * 1e-9 + step_s);
  writer->Close();
  render::WritePng(render::ContactSheet(sheet, labels, 3, 0.5), out.sheet_path);
  return out;
}

}  // namespace iapsim::tools
