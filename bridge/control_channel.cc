#include "bridge/control_channel.h"

#include <algorithm>
#include <cstring>
#include <set>
#include <zmq.hpp>

#include "bridge/bus.h"
#include "bridge/internal/zmq_poll.h"
#include "bridge/run_secret.h"

namespace iapsim::bridge {
namespace {

// ZeroMQ's fixed endpoint for the ZAP handler of a context (RFC 27)
constexpr char kZapEndpoint[] = "inproc://zeromq.zap.01";
constexpr char kMonitorEndpoint[] = "inproc://iapsim-control-monitor";
constexpr char kZapDomain[] = "iapsim";

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

std::vector<std::string> ReadFrames(zmq::socket_t& socket) {
  std::vector<std::string> frames;
  zmq::message_t frame;
  do {
    if (!socket.recv(frame)) break;
    frames.push_back(ToString(frame));
  } while (frame.more());
  return frames;
}

}  // namespace

struct ControlClient::Impl {
  zmq::context_t context{1};
  zmq::socket_t socket{context, zmq::socket_type::dealer};
};

ControlClient::ControlClient(const std::string& endpoint, const std::string& process,
                             const std::string& secret)
    : impl_(std::make_unique<Impl>()) {
  impl_->socket.set(zmq::sockopt::routing_id, process);
  impl_->socket.set(zmq::sockopt::plain_username, process);
  impl_->socket.set(zmq::sockopt::plain_password, secret);
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
  zmq::socket_t zap{context, zmq::socket_type::rep};
  zmq::socket_t socket{context, zmq::socket_type::router};
  zmq::socket_t monitor{context, zmq::socket_type::pair};
  std::string secret;
  std::vector<std::string> processes;
  uint64_t refused = 0;
  std::vector<std::string> refusals;
  std::set<std::string> described;  // a refused peer retries every few hundred ms: each is described once

  void Describe(const std::string& refusal) {
    if (described.insert(refusal).second) refusals.push_back(refusal);
  }

  // One ZAP request: PLAIN credentials of a connecting peer, accepted when they are a process's name and the
  // run's secret. The refusal itself is counted from the monitor's handshake-failure event.
  void Authenticate() {
    const std::vector<std::string> request = ReadFrames(zap);
    // version, request id, domain, address, routing id, mechanism, credentials...
    if (request.size() < 6) return;
    std::string status = "400", text = "unknown mechanism";
    if (request[5] == "PLAIN" && request.size() == 8) {
      const std::string& name = request[6];
      const bool known = std::find(processes.begin(), processes.end(), name) != processes.end();
      if (!known) {
        text = "'" + name + "' is not a process of this run";
      } else if (!SameSecret(request[7], secret)) {
        text = "'" + name + "' without the run's secret";
      } else {
        status = "200";
        text = "OK";
      }
    }
    if (status != "200") Describe(text);
    const std::string reply[] = {"1.0", request[1], status, text, status == "200" ? request[6] : "", ""};
    for (size_t i = 0; i < std::size(reply); ++i) {
      zap.send(zmq::buffer(reply[i]),
               i + 1 < std::size(reply) ? zmq::send_flags::sndmore : zmq::send_flags::none);
    }
  }

  // A handshake that failed: a refused ZAP request, another mechanism (no credentials), a broken greeting.
  void OnMonitorEvent() {
    const std::vector<std::string> event = ReadFrames(monitor);
    if (event.empty() || event[0].size() < 2) return;
    uint16_t id;
    std::memcpy(&id, event[0].data(), 2);
    ++refused;
    if (id == ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL) {
      Describe("a peer without credentials (another security mechanism)");
    } else if (id != ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) {
      Describe("a peer whose handshake failed");
    }
  }
};

ControlServer::ControlServer(const std::string& endpoint, const std::string& secret,
                             const std::vector<std::string>& processes)
    : impl_(std::make_unique<Impl>()) {
  impl_->secret = secret;
  impl_->processes = processes;
  // the handler is bound before the server socket exists, so no handshake can pass unchecked
  impl_->zap.set(zmq::sockopt::linger, 0);
  impl_->zap.bind(kZapEndpoint);
  impl_->socket.set(zmq::sockopt::linger, 0);
  impl_->socket.set(zmq::sockopt::router_mandatory, 0);  // a process that already exited is not an error
  impl_->socket.set(zmq::sockopt::plain_server, 1);
  impl_->socket.set(zmq::sockopt::zap_domain, kZapDomain);
  if (zmq_socket_monitor(impl_->socket.handle(), kMonitorEndpoint,
                         ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                             ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) != 0) {
    throw BusError(std::string("launcher: cannot monitor the control socket: ") + zmq_strerror(zmq_errno()));
  }
  impl_->monitor.connect(kMonitorEndpoint);
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
  auto& impl = *impl_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    zmq::pollitem_t items[] = {{impl.socket.handle(), 0, ZMQ_POLLIN, 0},
                               {impl.zap.handle(), 0, ZMQ_POLLIN, 0},
                               {impl.monitor.handle(), 0, ZMQ_POLLIN, 0}};
    const auto left = std::max(
        std::chrono::milliseconds(0),
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
    try {
      if (zmq::poll(items, 3, left) == 0) return std::nullopt;
    } catch (const zmq::error_t& e) {
      if (e.num() == EINTR) return std::nullopt;
      throw;
    }
    if (items[1].revents & ZMQ_POLLIN) impl.Authenticate();
    if (items[2].revents & ZMQ_POLLIN) impl.OnMonitorEvent();
    if (items[0].revents & ZMQ_POLLIN) {
      zmq::message_t identity;
      if (!impl.socket.recv(identity)) return std::nullopt;
      ControlMessage message;
      message.process = ToString(identity);
      return ReadKindAndBody(impl.socket, message);
    }
  }
}

uint64_t ControlServer::refused() const { return impl_->refused; }

std::vector<std::string> ControlServer::TakeRefusals() {
  std::vector<std::string> refusals;
  refusals.swap(impl_->refusals);
  return refusals;
}

}  // namespace iapsim::bridge
