#pragma once
// The largest message each topic of a bus may carry (bridge/bus.h enforces it on every transport): a
// publisher refuses to send a larger one, a subscriber discards one that reaches it (from a peer with other
// limits) before any callback decodes it. Scenario key: bus.max_message_kib (bridge/scenario.h).

#include <algorithm>
#include <cstddef>
#include <map>
#include <string>

namespace iapsim::bridge {

struct MessageSizeLimits {
  size_t default_bytes = size_t{64} << 20;  // a topic no key covers
  // by topic ("/iap/state"), or by namespace: a key ending in '/' ("/iap/camera/") covers every topic under
  // it; the longest key that covers a topic wins
  std::map<std::string, size_t> topic_bytes;

  size_t For(const std::string& topic) const {
    size_t limit = default_bytes, matched = 0;
    for (const auto& [key, bytes] : topic_bytes) {
      const bool covers = key.back() == '/' ? topic.compare(0, key.size(), key) == 0 : topic == key;
      if (covers && key.size() > matched) {
        limit = bytes;
        matched = key.size();
      }
    }
    return limit;
  }
  size_t Largest() const {
    size_t largest = default_bytes;
    for (const auto& entry : topic_bytes) largest = std::max(largest, entry.second);
    return largest;
  }
};

}  // namespace iapsim::bridge
