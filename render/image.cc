#include "render/image.h"

#include <libdeflate.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
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

// The PNG container (RFC 2083: signature, IHDR, IDAT, IEND, each chunk's CRC-32) is written here around a
// zlib stream from libdeflate, not through libpng: libpng compresses only with zlib, whose deflate took
// 7.1 ms a 640x480 frame here against 4.9 ms for libdeflate at level 1 (with a 6% smaller file), and the
// render process encodes six of them a frame. Every row takes the sub filter (each byte less the one a
// pixel to its left): one filter instead of trying five per row, and the best of them on rendered images.
std::vector<std::uint8_t> EncodePng(const Image& image, int compression) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3) {
    throw std::invalid_argument("EncodePng: the image has no pixels or the wrong number of bytes");
  }
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * 3;
  const std::size_t filtered_bytes = (row_bytes + 1) * image.height;
  // scratch buffers left uninitialised: zeroing them would cost more than the filter
  const std::unique_ptr<std::uint8_t[]> filtered(new std::uint8_t[filtered_bytes]);
  for (int v = 0; v < image.height; ++v) {
    const std::uint8_t* in = image.Pixel(0, v);
    std::uint8_t* out = &filtered[(row_bytes + 1) * v];
    *out++ = 1;  // filter type: sub
    std::copy(in, in + 3, out);
    for (std::size_t i = 3; i < row_bytes; ++i) out[i] = static_cast<std::uint8_t>(in[i] - in[i - 3]);
  }
  const std::unique_ptr<libdeflate_compressor, void (*)(libdeflate_compressor*)> compressor(
      libdeflate_alloc_compressor(std::clamp(compression, 0, 9)), libdeflate_free_compressor);
  if (!compressor) throw std::runtime_error("EncodePng: libdeflate cannot start");
  const std::size_t bound = libdeflate_zlib_compress_bound(compressor.get(), filtered_bytes);
  const std::unique_ptr<std::uint8_t[]> zlib(new std::uint8_t[bound]);
  const std::size_t zlib_bytes =
      libdeflate_zlib_compress(compressor.get(), filtered.get(), filtered_bytes, zlib.get(), bound);
  if (zlib_bytes == 0) throw std::runtime_error("EncodePng: libdeflate failed");

  std::vector<std::uint8_t> bytes = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  bytes.reserve(bytes.size() + 3 * 12 + 13 + zlib_bytes);
  const auto append_u32 = [&bytes](std::uint32_t value) {  // PNG integers are big-endian
    for (int shift = 24; shift >= 0; shift -= 8) bytes.push_back(static_cast<std::uint8_t>(value >> shift));
  };
  const auto append_chunk = [&](const char* type, const std::uint8_t* data, std::size_t size) {
    append_u32(static_cast<std::uint32_t>(size));
    bytes.insert(bytes.end(), type, type + 4);
    std::uint32_t crc = libdeflate_crc32(0, type, 4);
    if (size > 0) {  // libdeflate_crc32 of a null buffer restarts at 0
      bytes.insert(bytes.end(), data, data + size);
      crc = libdeflate_crc32(crc, data, size);
    }
    append_u32(crc);
  };
  std::uint8_t header[13] = {};
  for (int i = 0; i < 4; ++i) {
    header[i] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(image.width) >> (24 - 8 * i));
    header[4 + i] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(image.height) >> (24 - 8 * i));
  }
  header[8] = 8;  // bits a sample; then colour type 2 (RGB), deflate, adaptive filtering, not interlaced
  header[9] = 2;
  append_chunk("IHDR", header, sizeof(header));
  append_chunk("IDAT", zlib.get(), zlib_bytes);
  append_chunk("IEND", nullptr, 0);
  return bytes;
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

DepthImage DecodeDepthPng_mm(const std::vector<std::uint8_t>& bytes, const std::string& what) {
  const cv::Mat mm = cv::imdecode(bytes, cv::IMREAD_ANYDEPTH);
  if (mm.empty() || mm.type() != CV_16UC1) throw std::invalid_argument(what + ": not a 16-bit depth PNG");
  DepthImage depth{mm.cols, mm.rows, {}};
  depth.depth_m.reserve(static_cast<std::size_t>(mm.cols) * mm.rows);
  for (int v = 0; v < mm.rows; ++v) {
    for (int u = 0; u < mm.cols; ++u) {
      const std::uint16_t d_mm = mm.at<std::uint16_t>(v, u);
      depth.depth_m.push_back(d_mm == 0 ? std::numeric_limits<float>::infinity() : d_mm * 1e-3f);
    }
  }
  return depth;
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
