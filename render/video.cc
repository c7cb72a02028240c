#include "render/video.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>

namespace iapsim::render {
namespace {

// An RGB image as an OpenCV BGR matrix (OpenCV's channel order).
cv::Mat ToBgr(const Image& image) {
  const cv::Mat rgb(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.rgb.data()));
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

}  // namespace

struct VideoWriter::Impl {
  cv::VideoWriter writer;
  int width = 0;
  int height = 0;
};

VideoWriter::VideoWriter(const std::string& path, double frames_per_s, int width, int height)
    : impl_(std::make_unique<Impl>()), path_(path) {
  impl_->width = width;
  impl_->height = height;
  const std::pair<int, const char*> codecs[] = {{cv::VideoWriter::fourcc('a', 'v', 'c', '1'), "H.264"},
                                                {cv::VideoWriter::fourcc('m', 'p', '4', 'v'), "MPEG-4"}};
  for (const auto& [fourcc, name] : codecs) {
    if (impl_->writer.open(path, cv::CAP_FFMPEG, fourcc, frames_per_s, cv::Size(width, height))) {
      codec_ = name;
      return;
    }
  }
  throw std::runtime_error(path +
                           ": cannot write an MP4 video (no H.264 or MPEG-4 encoder in OpenCV's FFmpeg, "
                           "or the folder is not writable)");
}

VideoWriter::~VideoWriter() { Close(); }

void VideoWriter::Add(const Image& frame) {
  if (frame.width != impl_->width || frame.height != impl_->height) {
    throw std::invalid_argument(path_ + ": a " + std::to_string(frame.width) + "x" +
                                std::to_string(frame.height) + " frame in a " + std::to_string(impl_->width) +
                                "x" + std::to_string(impl_->height) + " video");
  }
  impl_->writer.write(ToBgr(frame));
}

void VideoWriter::Close() { impl_->writer.release(); }

Image ContactSheet(const std::vector<Image>& images, const std::vector<std::string>& labels, int columns,
                   double scale) {
  if (images.empty() || columns < 1 || !(scale > 0.0)) {
    throw std::invalid_argument("ContactSheet: expected images, columns >= 1 and a positive scale");
  }
  const int w = static_cast<int>(images[0].width * scale), h = static_cast<int>(images[0].height * scale);
  const int rows = (static_cast<int>(images.size()) + columns - 1) / columns;
  Image sheet;
  sheet.width = w * std::min(columns, static_cast<int>(images.size()));
  sheet.height = h * rows;
  sheet.rgb.assign(static_cast<std::size_t>(sheet.width) * sheet.height * 3, 0);
  cv::Mat out(sheet.height, sheet.width, CV_8UC3, sheet.rgb.data());
  for (std::size_t i = 0; i < images.size(); ++i) {
    const Image& image = images[i];
    if (image.width != images[0].width || image.height != images[0].height) {
      throw std::invalid_argument("ContactSheet: image " + std::to_string(i) +
                                  " differs in size from the first");
    }
    const cv::Mat rgb(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.rgb.data()));
    cv::Mat cell = out(cv::Rect(static_cast<int>(i) % columns * w, static_cast<int>(i) / columns * h, w, h));
    cv::resize(rgb, cell, cell.size(), 0, 0, cv::INTER_AREA);
    if (i < labels.size()) {
      // dark outline under white text reads on sky and ground alike
      const cv::Point at(8, 22);
      cv::putText(cell, labels[i], at, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
      cv::putText(cell, labels[i], at, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(255, 255, 255), 1,
                  cv::LINE_AA);
    }
  }
  return sheet;
}

}  // namespace iapsim::render
