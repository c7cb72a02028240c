#pragma once
// Rendered images and their encoding. Rows are stored top row first (camera.h's pixel convention).

#include <cstdint>
#include <string>
#include <vector>

namespace iapsim::render {

/// 8-bit sRGB colour, 3 bytes a pixel in R, G, B order.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;

  const std::uint8_t* Pixel(int u, int v) const {
    return &rgb[(static_cast<std::size_t>(v) * width + u) * 3];
  }
};

/// Depth along the optical axis z_C in metres, one float a pixel; +infinity where nothing was drawn
/// (ROS REP 118's "too far").
struct DepthImage {
  int width = 0;
  int height = 0;
  std::vector<float> depth_m;

  float At(int u, int v) const { return depth_m[static_cast<std::size_t>(v) * width + u]; }
};

/// PNG bytes of an image. `compression` is the deflate level: 0 (stored, largest), 1 (fastest) to 9.
std::vector<std::uint8_t> EncodePng(const Image& image, int compression = 1);
/// 16-bit PNG of a depth image in millimetres (0 where there is no depth or beyond 65.535 m), the
/// 16UC1 encoding of ROS depth images.
std::vector<std::uint8_t> EncodeDepthPng_mm(const DepthImage& depth, int compression = 1);
/// The inverse of EncodeDepthPng_mm: metres, +infinity where the PNG holds 0. Throws std::invalid_argument
/// naming `what` when the bytes are not a 16-bit single-channel image.
DepthImage DecodeDepthPng_mm(const std::vector<std::uint8_t>& bytes, const std::string& what);
/// Decodes PNG (or any format OpenCV reads) bytes into RGB; throws std::invalid_argument naming `what`.
Image DecodeImage(const std::vector<std::uint8_t>& bytes, const std::string& what);
/// Reads an image file into RGB; throws std::invalid_argument naming the file when it cannot.
Image ReadImageFile(const std::string& path);
/// Writes PNG bytes of an image to a file; throws std::runtime_error naming the file on failure.
void WritePng(const Image& image, const std::string& path);

}  // namespace iapsim::render
