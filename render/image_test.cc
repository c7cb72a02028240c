// PNG encoding is lossless and stays readable by another decoder (OpenCV's).

#include "render/image.h"

#include <gtest/gtest.h>
#include <libdeflate.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace iapsim::render {
namespace {

TEST(Png, RoundTripIsLossless) {
  Image image{37, 23, {}};      // odd sizes: no row padding assumed
  std::uint32_t state = 12345;  // a fixed-seed LCG: noise-like content that deflate cannot shrink away
  for (int i = 0; i < 37 * 23 * 3; ++i) {
    state = state * 1664525u + 1013904223u;
    image.rgb.push_back(static_cast<std::uint8_t>(state >> 24));
  }
  for (const int level : {0, 1, 9}) {
    const std::vector<std::uint8_t> png = EncodePng(image, level);
    ASSERT_GT(png.size(), 8u);
    EXPECT_EQ(png[1], 'P');
    const Image back = DecodeImage(png, "round trip");
    EXPECT_EQ(back.width, 37);
    EXPECT_EQ(back.height, 23);
    EXPECT_EQ(back.rgb, image.rgb) << "level " << level;
  }
  // a camera-sized image with long repeats (stripes) and smooth gradients: deflate's matches and literals
  Image stripes{640, 480, {}};
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      stripes.rgb.insert(stripes.rgb.end(),
                         {static_cast<std::uint8_t>((u / 8) % 2 ? 200 : 30), static_cast<std::uint8_t>(v / 2),
                          static_cast<std::uint8_t>(u + v)});
    }
  }
  const std::vector<std::uint8_t> png = EncodePng(stripes);
  EXPECT_LT(png.size(), stripes.rgb.size() / 10);
  EXPECT_EQ(DecodeImage(png, "stripes").rgb, stripes.rgb);
  EXPECT_THROW(DecodeImage({1, 2, 3}, "junk"), std::invalid_argument);
  EXPECT_THROW(EncodePng(Image{2, 2, {1, 2, 3}}), std::invalid_argument);
}

// A PNG of `image` with every row under one filter type (RFC 2083 §6), deflated by libdeflate, its data
// split over two IDAT chunks: what other encoders may write.
std::vector<std::uint8_t> PngWithFilter(const Image& image, int filter) {
  const std::size_t row = static_cast<std::size_t>(image.width) * 3;
  std::vector<std::uint8_t> rows;
  for (int v = 0; v < image.height; ++v) {
    rows.push_back(static_cast<std::uint8_t>(filter));
    for (std::size_t i = 0; i < row; ++i) {
      const int x = image.rgb[row * v + i], a = i >= 3 ? image.rgb[row * v + i - 3] : 0;
      const int b = v > 0 ? image.rgb[row * (v - 1) + i] : 0;
      const int c = v > 0 && i >= 3 ? image.rgb[row * (v - 1) + i - 3] : 0;
      const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
      const int predictor[5] = {0, a, b, (a + b) / 2, pa <= pb && pa <= pc ? a : pb <= pc ? b : c};
      rows.push_back(static_cast<std::uint8_t>(x - predictor[filter]));
    }
  }
  libdeflate_compressor* compressor = libdeflate_alloc_compressor(6);
  std::vector<std::uint8_t> zlib(libdeflate_zlib_compress_bound(compressor, rows.size()));
  zlib.resize(libdeflate_zlib_compress(compressor, rows.data(), rows.size(), zlib.data(), zlib.size()));
  libdeflate_free_compressor(compressor);
  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const auto u32 = [&png](std::uint32_t x) {
    for (int shift = 24; shift >= 0; shift -= 8) png.push_back(static_cast<std::uint8_t>(x >> shift));
  };
  const auto chunk = [&](const char* type, const std::vector<std::uint8_t>& data) {
    u32(static_cast<std::uint32_t>(data.size()));
    png.insert(png.end(), type, type + 4);
    png.insert(png.end(), data.begin(), data.end());
    u32(0);  // CRCs are not what the decoder checks: zlib's Adler-32 is
  };
  chunk("IHDR", {0, 0, 0, static_cast<std::uint8_t>(image.width), 0, 0, 0,
                 static_cast<std::uint8_t>(image.height), 8, 2, 0, 0, 0});
  const std::size_t half = zlib.size() / 2;
  chunk("IDAT", std::vector<std::uint8_t>(zlib.begin(), zlib.begin() + half));
  chunk("IDAT", std::vector<std::uint8_t>(zlib.begin() + half, zlib.end()));
  chunk("IEND", {});
  return png;
}

// DecodeImage reads 8-bit RGB PNGs itself (libdeflate), whatever their row filters and IDAT split, as OpenCV
// does; other PNGs (grey) go to OpenCV; a PNG whose data is cut short is an error naming it.
TEST(Png, EveryFilterAndOtherEncodersDecodeAsOpenCvDoes) {
  Image image{29, 17, {}};
  std::uint32_t state = 777;
  for (int v = 0; v < 17; ++v) {
    for (int u = 0; u < 29 * 3; ++u) {  // gradients with noise: every predictor has work to do
      state = state * 1664525u + 1013904223u;
      image.rgb.push_back(static_cast<std::uint8_t>(7 * u + 11 * v + (state >> 29)));
    }
  }
  for (int filter = 0; filter <= 4; ++filter) {
    EXPECT_EQ(DecodeImage(PngWithFilter(image, filter), "filtered").rgb, image.rgb) << "filter " << filter;
  }
  cv::Mat bgr(17, 29, CV_8UC3);
  for (int i = 0; i < 17 * 29; ++i) {
    for (int c = 0; c < 3; ++c) bgr.data[3 * i + c] = image.rgb[3 * i + 2 - c];
  }
  std::vector<std::uint8_t> libpng;  // libpng's adaptive filters
  ASSERT_TRUE(cv::imencode(".png", bgr, libpng, {cv::IMWRITE_PNG_COMPRESSION, 9}));
  EXPECT_EQ(DecodeImage(libpng, "libpng").rgb, image.rgb);
  cv::Mat grey(2, 3, CV_8UC1);
  for (int i = 0; i < 6; ++i) grey.data[i] = static_cast<std::uint8_t>(40 * i);
  std::vector<std::uint8_t> grey_png;
  ASSERT_TRUE(cv::imencode(".png", grey, grey_png));
  const Image from_grey = DecodeImage(grey_png, "grey");
  ASSERT_EQ(from_grey.rgb.size(), 18u);
  EXPECT_EQ(from_grey.rgb[15], 200);
  EXPECT_EQ(from_grey.rgb[17], 200);
  std::vector<std::uint8_t> cut = EncodePng(image);
  cut.resize(cut.size() - 30);
  try {
    DecodeImage(cut, "/cam/image_raw/compressed");
    ADD_FAILURE() << "a truncated PNG decoded";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("/cam/image_raw/compressed: "), std::string::npos) << e.what();
  }
}

TEST(Png, DepthIsMillimetresWithZeroForNoDepth) {
  // 70 m is beyond the 65.535 m that 16-bit millimetres hold: no depth, like +inf
  const DepthImage depth{4, 1, {1.2345f, std::numeric_limits<float>::infinity(), 70.0f, 0.0004f}};
  const DepthImage back = DecodeDepthPng_mm(EncodeDepthPng_mm(depth), "depth");
  ASSERT_EQ(back.width, 4);
  EXPECT_FLOAT_EQ(back.depth_m[0], 1.235f);  // rounded to the millimetre
  EXPECT_TRUE(std::isinf(back.depth_m[1]));
  EXPECT_TRUE(std::isinf(back.depth_m[2]));
  EXPECT_TRUE(std::isinf(back.depth_m[3]));  // rounds to 0 mm: no depth
  EXPECT_THROW(DecodeDepthPng_mm(EncodePng(Image{1, 1, {1, 2, 3}}), "colour"), std::invalid_argument);
}

}  // namespace
}  // namespace iapsim::render
