#include "render/image.h"

#include <libdeflate.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
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

std::uint32_t ReadU32(const std::uint8_t* p) {  // PNG integers are big-endian
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

// An 8-bit RGB, non-interlaced PNG (what EncodePng writes and most encoders write of a colour image) decoded
// with libdeflate: OpenCV's libpng inflates with zlib, 11.4 ms a rendered 640x480 frame here against 3.8 ms
// for libdeflate and the filters, and the vio runner decodes six images a frame. Rows may use any of the five
// filters (RFC 2083 §6). Returns nothing for any other PNG (grey, palette, 16-bit, interlaced): OpenCV reads
// those. Throws std::invalid_argument naming `what` for a PNG it cannot read.
std::optional<Image> DecodeRgbPng(const std::vector<std::uint8_t>& bytes, const std::string& what) {
  static const std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 8 + 25 || !std::equal(kSignature, kSignature + 8, bytes.begin()) ||
      ReadU32(&bytes[8]) != 13 || std::memcmp(&bytes[12], "IHDR", 4) != 0) {
    return std::nullopt;
  }
  const std::uint8_t* header = &bytes[16];
  const std::uint32_t width = ReadU32(header), height = ReadU32(header + 4);
  // 8 bits a sample, colour type 2 (RGB), deflate, the one filter method, not interlaced
  if (header[8] != 8 || header[9] != 2 || header[10] != 0 || header[11] != 0 || header[12] != 0) {
    return std::nullopt;
  }
  if (width == 0 || height == 0 || width > (1u << 15) || height > (1u << 15)) {
    throw std::invalid_argument(what + ": a PNG of " + std::to_string(width) + "x" + std::to_string(height) +
                                " pixels");
  }
  std::vector<std::uint8_t> zlib;  // the IDAT chunks' data, in order
  for (std::size_t at = 8 + 25; at + 12 <= bytes.size();) {
    const std::uint32_t length = ReadU32(&bytes[at]);
    if (length > bytes.size() - at - 12) throw std::invalid_argument(what + ": a truncated PNG chunk");
    if (std::memcmp(&bytes[at + 4], "IDAT", 4) == 0) {
      zlib.insert(zlib.end(), bytes.begin() + at + 8, bytes.begin() + at + 8 + length);
    } else if (std::memcmp(&bytes[at + 4], "IEND", 4) == 0) {
      break;
    }
    at += 12 + length;
  }
  const std::size_t row_bytes = std::size_t{width} * 3;
  std::vector<std::uint8_t> filtered((row_bytes + 1) * height);
  const std::unique_ptr<libdeflate_decompressor, void (*)(libdeflate_decompressor*)> decompressor(
      libdeflate_alloc_decompressor(), libdeflate_free_decompressor);
  if (!decompressor) throw std::runtime_error("DecodeImage: libdeflate cannot start");
  // the exact size, and zlib's Adler-32 of the data checked
  if (libdeflate_zlib_decompress(decompressor.get(), zlib.data(), zlib.size(), filtered.data(),
                                 filtered.size(), nullptr) != LIBDEFLATE_SUCCESS) {
    throw std::invalid_argument(what + ": a PNG whose image data does not inflate to " +
                                std::to_string(width) + "x" + std::to_string(height) + " RGB pixels");
  }
  Image image{static_cast<int>(width), static_cast<int>(height),
              std::vector<std::uint8_t>(row_bytes * height)};
  const std::vector<std::uint8_t> zero_row(row_bytes, 0);
  for (std::uint32_t v = 0; v < height; ++v) {
    const std::uint8_t filter = filtered[(row_bytes + 1) * v];
    const std::uint8_t* in = &filtered[(row_bytes + 1) * v + 1];
    std::uint8_t* out = &image.rgb[row_bytes * v];
    const std::uint8_t* up = v > 0 ? out - row_bytes : zero_row.data();
    switch (filter) {
      case 0:  // none
        std::copy(in, in + row_bytes, out);
        break;
      case 1:  // sub: the byte a pixel to the left
        std::copy(in, in + 3, out);
        for (std::size_t i = 3; i < row_bytes; ++i) out[i] = static_cast<std::uint8_t>(in[i] + out[i - 3]);
        break;
      case 2:  // up
        for (std::size_t i = 0; i < row_bytes; ++i) out[i] = static_cast<std::uint8_t>(in[i] + up[i]);
        break;
      case 3:  // average of left and up
        for (std::size_t i = 0; i < row_bytes; ++i) {
          const int left = i >= 3 ? out[i - 3] : 0;
          out[i] = static_cast<std::uint8_t>(in[i] + ((left + up[i]) >> 1));
        }
        break;
      case 4:  // Paeth: whichever of left, up and up-left is closest to left + up - up-left
        for (std::size_t i = 0; i < row_bytes; ++i) {
          const int a = i >= 3 ? out[i - 3] : 0, b = up[i], c = i >= 3 ? up[i - 3] : 0;
          const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
          out[i] = static_cast<std::uint8_t>(in[i] + (pa <= pb && pa <= pc ? a : pb <= pc ? b : c));
        }
        break;
      default:
        throw std::invalid_argument(what + ": a PNG row with filter type " + std::to_string(filter) +
                                    " (0-4 exist)");
    }
  }
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
  if (std::optional<Image> image = DecodeRgbPng(bytes, what)) return std::move(*image);
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
