#pragma once
// Draws that repeat on any standard library: std::normal_distribution's algorithm is the library's own, and
// a seeded run must give the same numbers wherever it runs. The engine, std::mt19937_64, is specified
// exactly.

#include <cmath>
#include <cstdint>
#include <random>

namespace iapsim::physics {

/// A standard normal draw: Box-Muller on the engine's raw bits.
inline double StandardNormal(std::mt19937_64& random) {
  const double u1 = (static_cast<double>(random() >> 11) + 1.0) * 0x1.0p-53;  // (0, 1]
  const double u2 = static_cast<double>(random() >> 11) * 0x1.0p-53;          // [0, 1)
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

/// A uniform draw in [−1, 1).
inline double SymmetricUniform(std::mt19937_64& random) {
  return static_cast<double>(random() >> 11) * 0x1.0p-52 - 1.0;
}

/// The seed of stream `index` of a run seeded `seed`: SplitMix64's increment keeps the streams apart (as
/// the sensors and the command links seed theirs).
inline uint64_t StreamSeed(uint64_t seed, uint64_t index) { return seed + 0x9E3779B97F4A7C15ULL * index; }

}  // namespace iapsim::physics
