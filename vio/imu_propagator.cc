#include "vio/imu_propagator.h"

#include <stdexcept>
#include <string>

namespace iapsim::vio {

ImuPropagator::ImuPropagator(double gravity_mps2, const sensors::ImuNoise& noise)
    : g_W_mps2_(0.0, 0.0, gravity_mps2), noise_(noise) {}

void ImuPropagator::AddImu(double t_s, const sensors::ImuSample& sample) {
  if (!samples_.empty() && t_s <= samples_.back().first) {
    throw std::invalid_argument("ImuPropagator: IMU sample at " + std::to_string(t_s) +
                                " s is not after the previous one at " +
                                std::to_string(samples_.back().first) + " s");
  }
  samples_.emplace_back(t_s, sample);
  if (!frame_) return;  // all kept: the first frame may come at any of them
  since_frame_->Integrate(t_s - integrated_to_s_, sample);
  integrated_to_s_ = t_s;
}

void ImuPropagator::SetFrame(const Estimate& frame) {
  if (samples_.empty()) throw std::invalid_argument("ImuPropagator: a frame before any IMU sample");
  while (samples_.size() > 1 && samples_[1].first <= frame.t_s) samples_.pop_front();
  frame_ = frame;
  since_frame_.emplace(InterpolatedSample(samples_, frame.t_s), frame.biases, noise_);
  integrated_to_s_ = frame.t_s;
  for (const auto& [t_s, sample] : samples_) {
    if (t_s <= frame.t_s) continue;
    since_frame_->Integrate(t_s - integrated_to_s_, sample);
    integrated_to_s_ = t_s;
  }
}

std::optional<Estimate> ImuPropagator::Latest() const {
  if (!frame_) return std::nullopt;
  if (integrated_to_s_ <= frame_->t_s) return frame_;
  Estimate latest = *frame_;
  latest.t_s = integrated_to_s_;
  latest.state = since_frame_->Predict(frame_->state, frame_->biases, g_W_mps2_);
  latest.w_I_radps = samples_.back().second.w_I_radps - frame_->biases.gyroscope_radps;
  latest.keyframe = false;
  latest.reset = false;
  return latest;
}

}  // namespace iapsim::vio
