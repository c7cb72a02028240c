#pragma once
// The second-order low-pass of the seed's §VI-E, G(s) = ω_c²/(s² + 2ζω_c s + ω_c²) per component of a
// wrench, discretised exactly for inputs held constant over each step (zero-order hold, through the matrix
// exponential of the state-space form). A physics step's contact wrench is such a held input, so the
// filtered samples equal the continuous filter's output at the sample times, for any ζ, and the DC gain is 1.

#include <Eigen/Core>

namespace iapsim::sensors {

using Vector6d = Eigen::Matrix<double, 6, 1>;

struct WrenchFilterConfig {
  double cutoff_rad_s = 10.0;  ///< ω_c (§VI-E)
  double damping = 1.414;      ///< ζ (§VI-E: overdamped)
};

/// Six independent copies of G(s) (force then torque; the frame is the caller's), starting at rest at zero.
class WrenchFilter {
 public:
  /// dt_s: the fixed step between inputs (> 0); cutoff and damping must be positive.
  WrenchFilter(const WrenchFilterConfig& config, double dt_s);

  /// Feeds the input held over the step that ends now and returns the output now.
  Vector6d Update(const Vector6d& input);
  Vector6d output() const { return state_.row(0).transpose(); }

 private:
  // the state (y, dy/dt) of every component advances by x ← Φx + Γu
  Eigen::Matrix2d Phi_;
  Eigen::Vector2d Gamma_;
  Eigen::Matrix<double, 2, 6> state_ = Eigen::Matrix<double, 2, 6>::Zero();
};

}  // namespace iapsim::sensors
