#pragma once
// Three standard normal draws for a sensor model's vector noise.

#include <Eigen/Core>
#include <random>

namespace iapsim::sensors {

/// x, y, z drawn in that order by three statements: an Eigen initialiser list would leave the order of the
/// draws unspecified, and a seeded run must repeat to the bit.
inline Eigen::Vector3d Gaussian3(std::mt19937_64& random, std::normal_distribution<double>& normal) {
  Eigen::Vector3d v;
  v.x() = normal(random);
  v.y() = normal(random);
  v.z() = normal(random);
  return v;
}

}  // namespace iapsim::sensors
