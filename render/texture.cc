#include "render/texture.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iapsim::render {
namespace {

using Pattern = ProceduralTexture::Pattern;

// lowbias32 (Chris Wellons): a well-mixed 32-bit hash, identical on every platform
std::uint32_t Hash(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

// a number in [0, 1) for the lattice point (i, j) of a layer
float Random(int i, int j, std::uint32_t seed) {
  const std::uint32_t h =
      Hash(static_cast<std::uint32_t>(i) ^ Hash(static_cast<std::uint32_t>(j) ^ Hash(seed)));
  return static_cast<float>(h >> 8) / 16777216.0f;
}

// value noise with `period` lattice cells across the texture, so it tiles; (x, y) in [0, 1)
float ValueNoise(float x, float y, int period, std::uint32_t seed) {
  const float fx = x * period, fy = y * period;
  const int i = static_cast<int>(std::floor(fx)), j = static_cast<int>(std::floor(fy));
  float tx = fx - i, ty = fy - j;
  tx = tx * tx * (3.0f - 2.0f * tx);  // smoothstep: no creases at lattice lines
  ty = ty * ty * (3.0f - 2.0f * ty);
  const auto at = [&](int a, int b) {
    return Random(((a % period) + period) % period, ((b % period) + period) % period, seed);
  };
  const float top = at(i, j) + (at(i + 1, j) - at(i, j)) * tx;
  const float bottom = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * tx;
  return top + (bottom - top) * ty;
}

// four octaves, in [0, 1)
float Fractal(float x, float y, int period, std::uint32_t seed) {
  float sum = 0.0f, weight = 0.5f, total = 0.0f;
  for (int octave = 0; octave < 4; ++octave) {
    sum += weight * ValueNoise(x, y, period << octave, seed + 101u * octave);
    total += weight;
    weight *= 0.5f;
  }
  return sum / total;
}

Eigen::Vector3f Mix(const Eigen::Vector3f& a, const Eigen::Vector3f& b, float t) { return a + (b - a) * t; }

Eigen::Vector3f Shade(const ProceduralTexture& r, float x, float y) {
  const int n = r.cells;
  const float grain = Fractal(x, y, 8, r.seed);  // every pattern carries texture at every scale
  switch (r.pattern) {
    case Pattern::kChecker: {
      const int cx = static_cast<int>(x * n), cy = static_cast<int>(y * n);
      return ((cx + cy) % 2 == 0 ? r.color_a : r.color_b) * (0.9f + 0.2f * grain);
    }
    case Pattern::kNoise: {
      const float t = Fractal(x, y, std::max(n, 1), r.seed + 7u);
      Eigen::Vector3f c = Mix(r.color_a, r.color_b, std::clamp(1.6f * t - 0.3f, 0.0f, 1.0f));
      // sparse dark specks: pebbles, stains
      const int px = static_cast<int>(x * r.size_px / 4), py = static_cast<int>(y * r.size_px / 4);
      if (Random(px, py, r.seed + 13u) < 0.02f) c *= 0.55f;
      return c * (0.85f + 0.3f * grain);
    }
    case Pattern::kBricks: {
      const int rows = n * 2;  // bricks about twice as long as tall
      const float fy = y * rows;
      const int row = static_cast<int>(fy);
      const float fx = x * n + (row % 2 == 0 ? 0.0f : 0.5f);
      const int column = static_cast<int>(std::floor(fx));
      const float u = fx - column, v = fy - row;
      const float mortar_u = 0.06f, mortar_v = 0.12f;
      if (u < mortar_u || v < mortar_v) return r.color_c * (0.8f + 0.3f * grain);
      const float tone = Random(((column % n) + n) % n, row, r.seed + 17u);
      return Mix(r.color_a, r.color_b, tone) * (0.8f + 0.35f * grain);
    }
    case Pattern::kTiles: {
      const float fx = x * n, fy = y * n;
      const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
      const float u = fx - cx, v = fy - cy;
      if (u < 0.04f || v < 0.04f) return r.color_c * (0.85f + 0.2f * grain);
      const float tone = Random(cx, cy, r.seed + 23u);
      return Mix(r.color_a, r.color_b, tone) * (0.85f + 0.25f * grain);
    }
    case Pattern::kFacade: {
      const float fx = x * n, fy = y * n;
      const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
      const float u = fx - cx, v = fy - cy;
      const bool window = u > 0.2f && u < 0.8f && v > 0.25f && v < 0.8f;
      if (!window) return r.color_a * (0.8f + 0.35f * grain);
      // glass: a shade per window, a lit window now and then, a sill-line darker at its bottom
      const float tone = Random(cx, cy, r.seed + 29u);
      Eigen::Vector3f glass = Mix(r.color_b, r.color_c, tone * tone);
      if (v > 0.72f) glass *= 0.6f;
      return glass * (0.9f + 0.2f * grain);
    }
  }
  return r.color_a;
}

}  // namespace

ProceduralTexture::Pattern ParsePattern(const std::string& name) {
  for (const Pattern p :
       {Pattern::kChecker, Pattern::kNoise, Pattern::kBricks, Pattern::kTiles, Pattern::kFacade}) {
    if (PatternName(p) == name) return p;
  }
  throw std::invalid_argument("unknown texture pattern '" + name +
                              "' (checker, noise, bricks, tiles, facade)");
}

std::string PatternName(Pattern pattern) {
  switch (pattern) {
    case Pattern::kChecker:
      return "checker";
    case Pattern::kNoise:
      return "noise";
    case Pattern::kBricks:
      return "bricks";
    case Pattern::kTiles:
      return "tiles";
    case Pattern::kFacade:
      return "facade";
  }
  return "?";
}

TextureImage MakeProceduralTexture(const ProceduralTexture& recipe) {
  if (recipe.size_px < 16 || recipe.size_px > 4096)
    throw std::invalid_argument("texture size_px must be in [16, 4096]");
  if (recipe.cells < 1 || recipe.cells > 256)
    throw std::invalid_argument("texture cells must be in [1, 256]");
  TextureImage image;
  image.width = image.height = recipe.size_px;
  image.source = PatternName(recipe.pattern) + " texture (seed " + std::to_string(recipe.seed) + ")";
  image.rgb.resize(static_cast<std::size_t>(recipe.size_px) * recipe.size_px * 3);
  const float inverse = 1.0f / recipe.size_px;
  std::size_t i = 0;
  for (int y = 0; y < recipe.size_px; ++y) {
    for (int x = 0; x < recipe.size_px; ++x) {
      // sample at the pixel's centre
      const Eigen::Vector3f c = Shade(recipe, (x + 0.5f) * inverse, (y + 0.5f) * inverse);
      for (int k = 0; k < 3; ++k)
        image.rgb[i++] = static_cast<std::uint8_t>(std::lround(std::clamp(c[k], 0.0f, 1.0f) * 255.0f));
    }
  }
  return image;
}

}  // namespace iapsim::render
