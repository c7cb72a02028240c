#include "sensors/wrench_filter.h"

#include <stdexcept>
#include <unsupported/Eigen/MatrixFunctions>

namespace iapsim::sensors {

WrenchFilter::WrenchFilter(const WrenchFilterConfig& config, double dt_s) {
  if (!(config.cutoff_rad_s > 0.0) || !(config.damping > 0.0) || !(dt_s > 0.0)) {
    throw std::invalid_argument("WrenchFilter: cutoff_rad_s, damping and dt_s must be positive");
  }
  const double w = config.cutoff_rad_s;
  // ẋ = Ax + Bu with x = (y, ẏ); exp([A B; 0 0]·Δt) = [Φ Γ; 0 1] gives both blocks of the exact ZOH map
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  M(0, 1) = 1.0;
  M(1, 0) = -w * w;
  M(1, 1) = -2.0 * config.damping * w;
  M(1, 2) = w * w;
  const Eigen::Matrix3d E = (M * dt_s).exp();
  Phi_ = E.topLeftCorner<2, 2>();
  Gamma_ = E.topRightCorner<2, 1>();
}

Vector6d WrenchFilter::Update(const Vector6d& input) {
  state_ = Phi_ * state_ + Gamma_ * input.transpose();
  return output();
}

}  // namespace iapsim::sensors
