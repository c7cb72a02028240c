#pragma once
// What the IAP computer reads of the vehicle (its state, the contact wrench) over a link with latency and
// jitter (issue 19's timing): a message measured at t_k becomes current at the step it arrives at
// (bridge/link_delay.h: on the clock's step grid, seeded, in order), so a lockstep run stays deterministic.
// Without latency a message is current as soon as it is received.

#include <cstdint>
#include <deque>
#include <utility>

#include "bridge/link_delay.h"

namespace iapsim::control {

template <class Message>
class SensorLink {
 public:
  /// `step_ns`: the clock's step, the grid that stamps lie on.
  SensorLink(const bridge::LinkDelay& link, int64_t step_ns) : link_(link), step_ns_(step_ns) {}

  /// A message measured at `stamp_ns`, in the order they were sent.
  void Push(const Message& message, int64_t stamp_ns) {
    in_flight_.emplace_back(link_.immediate() ? INT64_MIN : link_.Arrival(stamp_ns / step_ns_) * step_ns_,
                            message);
  }
  /// Makes the newest message that has arrived by `now_ns` current; returns whether any has arrived yet.
  bool Advance(int64_t now_ns) {
    while (!in_flight_.empty() && in_flight_.front().first <= now_ns) {
      current_ = std::move(in_flight_.front().second);
      in_flight_.pop_front();
      have_ = true;
    }
    return have_;
  }
  const Message& current() const { return current_; }

 private:
  bridge::LinkDelay link_;
  int64_t step_ns_;
  std::deque<std::pair<int64_t, Message>> in_flight_;  // by arrival time, non-decreasing
  Message current_{};
  bool have_ = false;
};

}  // namespace iapsim::control
