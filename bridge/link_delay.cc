#include "bridge/link_delay.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iapsim::bridge {

LinkDelay::LinkDelay(double delay_s, double jitter_s, double step_s, uint64_t seed) : random_(seed) {
  if (!(step_s > 0.0) || !std::isfinite(step_s)) throw std::invalid_argument("a link needs a step > 0");
  if (!(delay_s >= 0.0 && jitter_s >= 0.0) || !std::isfinite(delay_s) || !std::isfinite(jitter_s)) {
    throw std::invalid_argument("a link's delay and jitter must be finite and >= 0");
  }
  delay_steps_ = std::llround(delay_s / step_s);
  jitter_steps_ = std::llround(jitter_s / step_s);
}

int64_t LinkDelay::Arrival(int64_t sent_step) {
  // the jitter from the engine's raw output: std::uniform_int_distribution differs between standard
  // libraries, and a run must repeat anywhere (the modulo's bias is below 1e-17 for any jitter in steps)
  const int64_t jitter =
      jitter_steps_ > 0 ? static_cast<int64_t>(random_() % static_cast<uint64_t>(jitter_steps_ + 1)) : 0;
  last_arrival_ = std::max(sent_step + delay_steps_ + jitter, last_arrival_);
  return last_arrival_;
}

}  // namespace iapsim::bridge
