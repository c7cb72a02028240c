#pragma once
// The estimator's newest frame carried forward by the IMU to its newest sample, as VINS-Mono/-Fusion ([52],
// Qin et al. 2018) publish it ("imu_propagate", fastPredictIMU): a sliding-window estimate exists only at the
// camera's rate (20 Hz in the seed), and a controller that holds it for the 50 ms between frames flies on a
// stale state. Between frames the frame's state is propagated with the bias-corrected samples since
// (ImuPreintegration's midpoint rule and Predict, with the frame's biases); the next frame's estimate
// replaces it. No smoothing, no correction of its own: what the window corrects reaches the propagated
// estimate at the next frame, as a step.

#include <optional>

#include "vio/estimator.h"
#include "vio/imu_preintegration.h"

namespace iapsim::vio {

class ImuPropagator {
 public:
  /// `gravity_mps2` and the noise as the estimator's (EstimatorOptions).
  ImuPropagator(double gravity_mps2, const sensors::ImuNoise& noise);

  /// An IMU sample, in increasing time. Throws std::invalid_argument otherwise.
  void AddImu(double t_s, const sensors::ImuSample& sample);
  /// The estimator's newest frame (Estimator::AddFrame's result): what is propagated from now on. The
  /// samples it needs (one at or before its time, for interpolation) must have been added.
  void SetFrame(const Estimate& frame);
  /// The frame's estimate at the newest sample after it (or the frame itself when there is none), with
  /// that sample's bias-corrected rate; nullopt before the first frame.
  std::optional<Estimate> Latest() const;

 private:
  Eigen::Vector3d g_W_mps2_;
  sensors::ImuNoise noise_;
  ImuSamples samples_;  ///< the last one at or before the frame, and every one after it
  std::optional<Estimate> frame_;
  std::optional<ImuPreintegration> since_frame_;
  double integrated_to_s_ = 0.0;
};

}  // namespace iapsim::vio
