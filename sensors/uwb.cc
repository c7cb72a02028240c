#include "sensors/uwb.h"

#include "sensors/gaussian.h"

namespace iapsim::sensors {

UwbModel::UwbModel(const UwbNoise& noise, uint64_t seed) : noise_(noise), random_(seed) {}

UwbRange UwbModel::Measure(const Eigen::Vector3d& p_WA_m, const Eigen::Vector3d& p_WB_m) {
  // a fixed number of draws per range, in a fixed order, so that changing one probability leaves the other
  // effects of every range as they were
  const double dropout_draw = uniform_(random_);
  const double nlos_draw = uniform_(random_);
  const double outlier_draw = uniform_(random_);
  const double outlier_value = uniform_(random_);
  const double gaussian = StandardNormal(random_);

  UwbRange range;
  range.received = dropout_draw >= noise_.dropout_probability;
  range.nlos = nlos_draw < noise_.nlos_probability;
  range.outlier = outlier_draw < noise_.outlier_probability;
  range.range_m = (p_WB_m - p_WA_m).norm() + noise_.sigma_m * gaussian;
  if (range.nlos) range.range_m += noise_.nlos_bias_m;
  if (range.outlier) range.range_m += noise_.outlier_magnitude_m * (2.0 * outlier_value - 1.0);
  return range;
}

}  // namespace iapsim::sensors
