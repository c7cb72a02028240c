#pragma once
// A one-way link with latency and jitter, realised on a step grid so that lockstep runs stay deterministic
// (issue 19's timing): a message sent at step k arrives at step k + delay + j, j drawn uniformly from
// [0, jitter] per message, both in whole steps, and messages keep their order (one that would overtake the
// message ahead of it arrives with it). The simulated vehicle's command link (physics/simulation.h) and the
// IAP computer's sensor link (control) are both such links.

#include <cstdint>
#include <random>

namespace iapsim::bridge {

class LinkDelay {
 public:
  LinkDelay() = default;
  /// `delay_s` and `jitter_s` are rounded to whole `step_s`; `seed` starts the jitter's stream.
  /// Throws std::invalid_argument for a negative or non-finite delay or jitter, or a step that is not > 0.
  LinkDelay(double delay_s, double jitter_s, double step_s, uint64_t seed);

  /// Zero delay and zero jitter: every message arrives at the step it was sent at.
  bool immediate() const { return delay_steps_ == 0 && jitter_steps_ == 0; }
  int64_t delay_steps() const { return delay_steps_; }
  int64_t jitter_steps() const { return jitter_steps_; }

  /// The step at which a message sent at `sent_step` arrives. Call once per message, in sending order.
  int64_t Arrival(int64_t sent_step);

 private:
  int64_t delay_steps_ = 0;
  int64_t jitter_steps_ = 0;
  int64_t last_arrival_ = INT64_MIN;
  std::mt19937_64 random_;
};

}  // namespace iapsim::bridge
