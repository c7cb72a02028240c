#include "render/image.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace iapsim::render {
namespace {

std::vector<std::uint8_t> Encode(const cv::Mat& mat, int compression) {
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", mat, bytes, {cv::IMWRITE_PNG_COMPRESSION, compression})) {
    throw std::runtime_error("PNG encoding failed");
  }
  return bytes;
}

Image FromBgr(const cv::Mat& bgr) {
  Image image;
  image.width = bgr.cols;
  image.height = bgr.rows;
  image.rgb.resize(static_cast<std::size_t>(bgr.cols) * bgr.rows * 3);
  cv::Mat rgb(bgr.rows, bgr.cols, CV_8UC3, image.rgb.data());
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return image;
}

}  // namespace

std::vector<std::uint8_t> EncodePng(const Image& image, int compression) {
  // OpenCV writes BGR: swap into a scratch image (a copy of 0.9 MB at 640x480, small next to the deflate)
  const cv::Mat rgb(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.rgb.data()));
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  return Encode(bgr, compression);
}

std::vector<std::uint8_t> EncodeDepthPng_mm(const DepthImage& depth, int compression) {
  cv::Mat mm(depth.height, depth.width, CV_16UC1);
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const float d_mm = depth.At(u, v) * 1000.0f;
      mm.at<std::uint16_t>(v, u) =
          (std::isfinite(d_mm) && d_mm <= 65535.0f) ? static_cast<std::uint16_t>(std::lround(d_mm)) : 0;
    }
  }
  return Encode(mm, compression);
}

Image DecodeImage(const std::vector<std::uint8_t>& bytes, const std::string& what) {
  const cv::Mat bgr = cv::imdecode(bytes, cv::IMREAD_COLOR);
  if (bgr.empty()) throw std::invalid_argument(what + ": not an image OpenCV can decode (PNG, JPEG, ...)");
  return FromBgr(bgr);
}

Image ReadImageFile(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw std::invalid_argument(path + ": no such image file");
  const cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
  if (bgr.empty()) throw std::invalid_argument(path + ": not an image OpenCV can read (PNG, JPEG, ...)");
  return FromBgr(bgr);
}

void WritePng(const Image& image, const std::string& path) {
  const std::vector<std::uint8_t> bytes = EncodePng(image, 6);
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error(path + ": cannot write the PNG file");
}

}  // namespace iapsim::render
