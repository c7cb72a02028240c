#pragma once
// Overlapping Allan deviation (IEEE Std 952) of a rate signal and the fit of its white-noise and
// random-walk lines, read the way Kalibr's imu.yaml wants them: the noise density is the −1/2-slope line at
// τ = 1 s, the random walk the +1/2-slope line at τ = 3 s.

#include <vector>

namespace iapsim::sensors {

struct AllanPoint {
  double tau_s = 0.0;      ///< averaging time m/rate
  double deviation = 0.0;  ///< σ(τ), in the unit of the samples
  double clusters = 0.0;   ///< samples/m: about the number of independent averages (the estimate's weight)
};

/// σ(τ) for averaging factors m = 1 … (n − 1)/2 spaced `points_per_decade` per decade (each m once), from
/// `samples` taken at `rate_hz`. Needs at least 3 samples.
std::vector<AllanPoint> OverlappingAllanDeviation(const std::vector<double>& samples, double rate_hz,
                                                  int points_per_decade = 10);

/// N and K of σ²(τ) = N²/τ + K²τ/3: white noise plus a random walk, the simulated IMU's noise model. The
/// model is fitted to every point, each weighted by its estimated uncertainty (iteratively, from the fitted
/// curve, so that points that happen to fall low do not pull the fit down). Bias instability (flicker) is
/// not part of the model: on a real IMU it raises K.
struct AllanNoiseFit {
  double noise_density = 0.0;  ///< N: the −1/2 line's σ at τ = 1 s (unit·√s = unit/√Hz)
  double random_walk = 0.0;    ///< K: the +1/2 line's σ at τ = 3 s (unit/√s = unit/s/√Hz)
};
AllanNoiseFit FitWhiteNoiseAndRandomWalk(const std::vector<AllanPoint>& points);

}  // namespace iapsim::sensors
