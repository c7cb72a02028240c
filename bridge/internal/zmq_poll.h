#pragma once
// ZeroMQ helpers shared by the bus and the control channel (internal: never included by public headers).

#include <cerrno>
#include <chrono>
#include <zmq.hpp>

namespace iapsim::bridge::internal {

/// Polls one socket for `events`. A signal (EINTR) counts as "nothing ready": the caller's loop then sees
/// the stop request the signal handler recorded, instead of an exception.
inline bool PollOne(zmq::socket_t& socket, short events, std::chrono::milliseconds timeout) {
  zmq::pollitem_t item{socket.handle(), 0, events, 0};
  try {
    return zmq::poll(&item, 1, timeout) > 0;
  } catch (const zmq::error_t& e) {
    if (e.num() == EINTR) return false;
    throw;
  }
}

}  // namespace iapsim::bridge::internal
