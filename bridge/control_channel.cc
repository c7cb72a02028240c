#include "bridge/control_channel.h"

#include <zmq.hpp>

#include "bridge/bus.h"
#include "bridge/internal/zmq_poll.h"

namespace iapsim::bridge {
namespace {

std::string ToString(const zmq::message_t& frame) {
  return std::string(static_cast<const char*>(frame.data()), frame.size());
}

// reads the rest of a multipart message as [kind][body]
std::optional<ControlMessage> ReadKindAndBody(zmq::socket_t& socket, ControlMessage message) {
  zmq::message_t frame;
  if (!socket.recv(frame)) return std::nullopt;
  message.kind = ToString(frame);
  while (frame.more()) {
    if (!socket.recv(frame)) return std::nullopt;
    message.body += ToString(frame);
  }
  return message;
}

}  // namespace

struct ControlClient::Impl {
  zmq::context_t context{1};
  zmq::socket_t socket{context, zmq::socket_type::dealer};
};

ControlClient::ControlClient(const std::string& endpoint, const std::string& process)
    : impl_(std::make_unique<Impl>()) {
  impl_->socket.set(zmq::sockopt::routing_id, process);
  impl_->socket.set(zmq::sockopt::linger, 1000);  // a final report still leaves after close
  impl_->socket.set(zmq::sockopt::reconnect_ivl, 10);
  try {
    impl_->socket.connect(endpoint);
  } catch (const zmq::error_t& e) {
    throw BusError("process '" + process + "': cannot connect to the launcher at '" + endpoint +
                   "': " + e.what());
  }
}

ControlClient::~ControlClient() = default;

void ControlClient::Send(const std::string& kind, const std::string& body) {
  impl_->socket.send(zmq::buffer(kind), zmq::send_flags::sndmore);
  impl_->socket.send(zmq::buffer(body), zmq::send_flags::none);
}

std::optional<ControlMessage> ControlClient::Receive(std::chrono::milliseconds timeout) {
  if (!internal::PollOne(impl_->socket, ZMQ_POLLIN, timeout)) return std::nullopt;
  return ReadKindAndBody(impl_->socket, ControlMessage{});
}

struct ControlServer::Impl {
  zmq::context_t context{1};
  zmq::socket_t socket{context, zmq::socket_type::router};
};

ControlServer::ControlServer(const std::string& endpoint) : impl_(std::make_unique<Impl>()) {
  impl_->socket.set(zmq::sockopt::linger, 0);
  impl_->socket.set(zmq::sockopt::router_mandatory, 0);  // a process that already exited is not an error
  try {
    impl_->socket.bind(endpoint);
  } catch (const zmq::error_t& e) {
    throw BusError("launcher: cannot bind control endpoint '" + endpoint + "': " + e.what());
  }
}

ControlServer::~ControlServer() = default;

void ControlServer::Send(const std::string& process, const std::string& kind) {
  impl_->socket.send(zmq::buffer(process), zmq::send_flags::sndmore | zmq::send_flags::dontwait);
  impl_->socket.send(zmq::buffer(kind), zmq::send_flags::dontwait);
}

std::optional<ControlMessage> ControlServer::Receive(std::chrono::milliseconds timeout) {
  if (!internal::PollOne(impl_->socket, ZMQ_POLLIN, timeout)) return std::nullopt;
  zmq::message_t identity;
  if (!impl_->socket.recv(identity)) return std::nullopt;
  ControlMessage message;
  message.process = ToString(identity);
  return ReadKindAndBody(impl_->socket, message);
}

}  // namespace iapsim::bridge
