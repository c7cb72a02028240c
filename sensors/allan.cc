#include "sensors/allan.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iapsim::sensors {
namespace {

// (N², K²) ≥ 0 minimising Σ w²(N²/τ + K²τ/3 − σ²)²: the unconstrained solution, or the better of the
// one-term fits when it has a negative component
Eigen::Vector2d NonNegativeLeastSquares(const Eigen::MatrixX2d& A, const Eigen::VectorXd& b) {
  const Eigen::Vector2d x = A.colPivHouseholderQr().solve(b);
  if (x.minCoeff() >= 0.0) return x;
  Eigen::Vector2d best = Eigen::Vector2d::Zero();
  double best_residual = b.squaredNorm();
  for (int column = 0; column < 2; ++column) {
    Eigen::Vector2d candidate = Eigen::Vector2d::Zero();
    candidate[column] = std::max(0.0, A.col(column).dot(b) / A.col(column).squaredNorm());
    const double residual = (A * candidate - b).squaredNorm();
    if (residual < best_residual) best = candidate, best_residual = residual;
  }
  return best;
}

}  // namespace

std::vector<AllanPoint> OverlappingAllanDeviation(const std::vector<double>& samples, double rate_hz,
                                                  int points_per_decade) {
  const size_t n = samples.size();
  if (n < 3 || !(rate_hz > 0.0) || points_per_decade < 1) {
    throw std::invalid_argument(
        "OverlappingAllanDeviation: needs 3 or more samples, a positive rate and "
        "points_per_decade >= 1");
  }
  // the integrated signal ("phase") of the mean-free samples: a constant offset cancels in σ(τ) anyway,
  // and removing it keeps the running sum small, so its differences lose no digits
  double mean = 0.0;
  for (double y : samples) mean += y;
  mean /= static_cast<double>(n);
  const double dt_s = 1.0 / rate_hz;
  std::vector<double> phase(n + 1, 0.0);
  for (size_t i = 0; i < n; ++i) phase[i + 1] = phase[i] + (samples[i] - mean) * dt_s;

  const size_t m_max = (n - 1) / 2;
  std::vector<AllanPoint> points;
  size_t previous_m = 0;
  for (int i = 0;; ++i) {
    const size_t m =
        static_cast<size_t>(std::llround(std::pow(10.0, static_cast<double>(i) / points_per_decade)));
    if (m > m_max) break;
    if (m == previous_m) continue;
    previous_m = m;
    const size_t terms = n + 1 - 2 * m;
    double sum = 0.0;
    for (size_t k = 0; k < terms; ++k) {
      const double second_difference = phase[k + 2 * m] - 2.0 * phase[k + m] + phase[k];
      sum += second_difference * second_difference;
    }
    AllanPoint point;
    point.tau_s = static_cast<double>(m) * dt_s;
    point.deviation = std::sqrt(sum / (2.0 * point.tau_s * point.tau_s * static_cast<double>(terms)));
    point.clusters = static_cast<double>(n) / static_cast<double>(m);
    points.push_back(point);
  }
  return points;
}

AllanNoiseFit FitWhiteNoiseAndRandomWalk(const std::vector<AllanPoint>& points) {
  if (points.size() < 2) throw std::invalid_argument("FitWhiteNoiseAndRandomWalk: needs 2 or more points");
  const Eigen::Index count = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixX2d basis(count, 2);
  Eigen::VectorXd variance(count);
  for (Eigen::Index i = 0; i < count; ++i) {
    const AllanPoint& p = points[static_cast<size_t>(i)];
    basis(i, 0) = 1.0 / p.tau_s;
    basis(i, 1) = p.tau_s / 3.0;
    variance[i] = p.deviation * p.deviation;
  }
  Eigen::VectorXd model = variance;
  Eigen::Vector2d x = Eigen::Vector2d::Zero();
  // σ̂²(τ) has a relative standard deviation of about √(2/clusters); weights from the fitted curve, not
  // from σ̂² itself (that would favour the points that came out low), settle in a few rounds
  for (int round = 0; round < 5; ++round) {
    Eigen::VectorXd weight(count);
    for (Eigen::Index i = 0; i < count; ++i) {
      weight[i] = std::sqrt(points[static_cast<size_t>(i)].clusters) / std::max(model[i], 1e-300);
    }
    x = NonNegativeLeastSquares(weight.asDiagonal() * basis, weight.cwiseProduct(variance));
    model = basis * x;
  }
  AllanNoiseFit fit;
  fit.noise_density = std::sqrt(x[0]);
  fit.random_walk = std::sqrt(x[1]);
  return fit;
}

}  // namespace iapsim::sensors
