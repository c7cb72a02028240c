#pragma once
// Standard normal draws for every noise model of iapsim (sensors, flight-controller gyroscopes, turbulence,
// model uncertainty). Boost's normal distribution is a ziggurat (Marsaglia & Tsang 2000, as Boost.Random
// documents it) whose algorithm and tables are in Boost's headers: a seeded run draws the same numbers with
// any standard library (std::normal_distribution's algorithm is the library's own), and a draw costs about
// a quarter of the polar or Box-Muller method's logarithm and square root (the realistic profile draws 24
// per physics step for three sub-aircraft: 18 for the flight controllers' gyroscopes, 6 for the turbulence).

#include <Eigen/Core>
#include <boost/random/normal_distribution.hpp>
#include <random>

namespace iapsim::sensors {

/// One standard normal draw from `random`.
inline double StandardNormal(std::mt19937_64& random) {
  return boost::random::normal_distribution<double>()(random);
}

/// x, y, z drawn in that order by three statements: an Eigen initialiser list would leave the order of the
/// draws unspecified, and a seeded run must repeat to the bit.
inline Eigen::Vector3d Gaussian3(std::mt19937_64& random) {
  Eigen::Vector3d v;
  v.x() = StandardNormal(random);
  v.y() = StandardNormal(random);
  v.z() = StandardNormal(random);
  return v;
}

}  // namespace iapsim::sensors
