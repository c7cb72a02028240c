// PNG encoding is lossless and stays readable by another decoder (OpenCV's).

#include "render/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

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
