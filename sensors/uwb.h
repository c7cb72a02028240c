#pragma once
// UWB ranging (seed §V-D, after Nguyen et al.): the true distance between two antennas plus Gaussian noise
// (Table VI's r_a^p = 0.7071 read as the standard deviation in metres), with optional outliers, a positive
// non-line-of-sight bias and dropouts. One model serves tag-to-anchor and tag-to-tag ranges.

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace iapsim::sensors {

/// Table VI's r_a^p, the standard deviation of one range (sensors/README.md).
constexpr double kTableViUwbSigma_m = 0.7071;

struct UwbAnchor {
  std::string name;
  Eigen::Vector3d p_WA_m = Eigen::Vector3d::Zero();  ///< antenna position in W (NED)
};

/// Error model of one range. Each effect is drawn independently per range.
struct UwbNoise {
  double sigma_m = kTableViUwbSigma_m;  ///< Gaussian noise, every range
  double outlier_probability = 0.0;
  double outlier_magnitude_m = 0.0;  ///< an outlier adds an error uniform in [−magnitude, +magnitude]
  double nlos_probability = 0.0;
  double nlos_bias_m = 0.0;  ///< a non-line-of-sight range is longer by this much (a detour of the signal)
  double dropout_probability = 0.0;  ///< a dropped range is not received
};

struct UwbConfig {
  std::vector<UwbAnchor> anchors;  ///< fixed anchors (may be empty: tag-to-tag only)
  UwbNoise noise;
  double rate_hz = 200.0;  ///< the seed's sensors run at the ground-truth rate (§V-D), 200 Hz in §VI-G
  bool tag_to_tag = true;  ///< also range between the tags of one vehicle
};

/// One range and what happened to it (the flags are for statistics and tests; a receiver sees range_m only).
struct UwbRange {
  bool received = true;  ///< false: dropped, range_m is meaningless
  double range_m = 0.0;  ///< not clamped at zero: additive Gaussian noise, as in the seed's model
  bool outlier = false;
  bool nlos = false;
};

/// A UWB radio pair with its own seeded random stream.
class UwbModel {
 public:
  UwbModel(const UwbNoise& noise, uint64_t seed);

  /// The measured distance between antennas at p_WA_m and p_WB_m (W).
  UwbRange Measure(const Eigen::Vector3d& p_WA_m, const Eigen::Vector3d& p_WB_m);

 private:
  UwbNoise noise_;
  std::mt19937_64 random_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
};

}  // namespace iapsim::sensors
