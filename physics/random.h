#pragma once
// Draws that repeat on any standard library: the engine, std::mt19937_64, is specified exactly, and the
// normal draws are Boost's ziggurat (sensors/gaussian.h), not std::normal_distribution, whose algorithm is
// the library's own.

#include <cmath>
#include <cstdint>
#include <random>

#include "sensors/gaussian.h"

namespace iapsim::physics {

using sensors::StandardNormal;

/// A uniform draw in [−1, 1).
inline double SymmetricUniform(std::mt19937_64& random) {
  return static_cast<double>(random() >> 11) * 0x1.0p-52 - 1.0;
}

/// The seed of stream `index` of a run seeded `seed`: SplitMix64's increment keeps the streams apart (as
/// the sensors and the command links seed theirs).
inline uint64_t StreamSeed(uint64_t seed, uint64_t index) { return seed + 0x9E3779B97F4A7C15ULL * index; }

}  // namespace iapsim::physics
