#pragma once
// Procedural textures, generated deterministically (an integer hash of pixel, cell and seed; no library
// random numbers), so a scene looks the same on every machine and run. Each tiles seamlessly. They give
// visual odometry corners and gradients at every scale: value noise over four octaves under every pattern.

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "render/scene.h"

namespace iapsim::render {

struct ProceduralTexture {
  enum class Pattern {
    kChecker,  ///< cells × cells squares of color_a and color_b
    kNoise,    ///< value noise between color_a and color_b (grass, concrete, asphalt), dark specks
    kBricks,   ///< `cells` bricks a row in running bond, colours between color_a and color_b, color_c mortar
    kTiles,    ///< cells × cells floor tiles, each a shade between color_a and color_b, color_c grout
    kFacade,   ///< a wall of color_a with cells × cells windows of glass between color_b and color_c
  };
  Pattern pattern = Pattern::kNoise;
  Eigen::Vector3f color_a = Eigen::Vector3f(0.35f, 0.45f, 0.25f);  ///< sRGB
  Eigen::Vector3f color_b = Eigen::Vector3f(0.25f, 0.32f, 0.18f);
  Eigen::Vector3f color_c = Eigen::Vector3f(0.7f, 0.7f, 0.68f);
  int size_px = 512;  ///< width and height, 16..4096
  int cells = 8;      ///< 1..256, see the patterns
  std::uint32_t seed = 1;
};

/// "checker" | "noise" | "bricks" | "tiles" | "facade"; throws std::invalid_argument otherwise.
ProceduralTexture::Pattern ParsePattern(const std::string& name);
std::string PatternName(ProceduralTexture::Pattern pattern);

/// The texture's pixels; throws std::invalid_argument for a size or cell count out of range.
TextureImage MakeProceduralTexture(const ProceduralTexture& recipe);

}  // namespace iapsim::render
