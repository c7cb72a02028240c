#include "bridge/control_channel.h"

#include <algorithm>
#include <cstring>
#include <zmq.hpp>

#include "bridge/bus.h"
#include "bridge/internal/zap_gate.h"
#include "bridge/internal/zmq_poll.h"
#include "bridge/run_secret.h"

namespace iapsim::bridge {
namespace {

constexpr char kZapDomain[] = "iapsim";

// tcp may leave the host: there the channel is CURVE with the run's keys (encrypted; the secret never
// travels), elsewhere PLAIN, which names each process (an abstract unix socket never leaves the host)
bool Encrypted(const std::string& endpoint) { return endpoint.rfind("tcp://", 0) == 0; }

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
  zmq::socket_t handshakes;  // the socket's handshake outcomes (internal::MonitorSocket)
  bool accepted = false;
  bool failed = false;  // a handshake failed
  bool denied = false;  // ... because the launcher's ZAP handler said no (ZeroMQ RFC 27's status 400)

  void ReadHandshakes() {
    if (!handshakes) return;  // the constructor failed before it monitored
    for (const uint16_t id : internal::TakeEvents(handshakes)) {
      accepted = accepted || id == ZMQ_EVENT_HANDSHAKE_SUCCEEDED;
      failed = failed || id != ZMQ_EVENT_HANDSHAKE_SUCCEEDED;
      denied = denied || id == ZMQ_EVENT_HANDSHAKE_FAILED_AUTH;
    }
  }
  // A client that never got in has no way to deliver: it does not linger for its messages at close, as it
  // does for a final report to a launcher that let it in or has not answered yet.
  ~Impl() {
    ReadHandshakes();
    if (failed && !accepted) socket.set(zmq::sockopt::linger, 0);
    if (handshakes) zmq_socket_monitor(socket.handle(), nullptr, 0);  // before the socket closes (ZapGate)
  }
};

ControlClient::ControlClient(const std::string& endpoint, const std::string& process,
                             const std::string& secret)
    : impl_(std::make_unique<Impl>()) {
  impl_->socket.set(zmq::sockopt::routing_id, process);
  if (Encrypted(endpoint)) {
    try {
      const internal::CurveKeys keys = internal::RunCurveKeys(secret);
      impl_->socket.set(zmq::sockopt::curve_serverkey, keys.server_public);
      impl_->socket.set(zmq::sockopt::curve_publickey, keys.client_public);
      impl_->socket.set(zmq::sockopt::curve_secretkey, keys.client_secret);
    } catch (const std::invalid_argument& e) {
      throw BusError("process '" + process + "': " + e.what() +
                     " (IAPSIM_RUN_SECRET, or RUN/secret through --run-dir)");
    }
  } else {
    impl_->socket.set(zmq::sockopt::plain_username, process);
    impl_->socket.set(zmq::sockopt::plain_password, secret);
  }
  impl_->socket.set(zmq::sockopt::linger, 1000);  // a final report still leaves after close
  impl_->socket.set(zmq::sockopt::reconnect_ivl, 10);
  impl_->handshakes =
      internal::MonitorSocket(impl_->context, impl_->socket,
                              ZMQ_EVENT_HANDSHAKE_SUCCEEDED | ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL |
                                  ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL | ZMQ_EVENT_HANDSHAKE_FAILED_AUTH);
  try {
    impl_->socket.connect(endpoint);
  } catch (const zmq::error_t& e) {
    throw BusError("process '" + process + "': cannot connect to the launcher at '" + endpoint +
                   "': " + e.what());
  }
}

ControlClient::~ControlClient() = default;

void ControlClient::Send(const std::string& kind, const std::string& body) {
  if (Refused()) return;  // nothing would leave, and a DEALER whose only peer refused it blocks in send
  impl_->socket.send(zmq::buffer(kind), zmq::send_flags::sndmore);
  impl_->socket.send(zmq::buffer(body), zmq::send_flags::none);
}

std::optional<ControlMessage> ControlClient::Receive(std::chrono::milliseconds timeout) {
  if (!internal::PollOne(impl_->socket, ZMQ_POLLIN, timeout)) return std::nullopt;
  return ReadKindAndBody(impl_->socket, ControlMessage{});
}

bool ControlClient::Refused() {
  impl_->ReadHandshakes();
  return impl_->denied && !impl_->accepted;
}

struct ControlServer::Impl {
  // curve_keys: the run's (tcp), or none (PLAIN)
  Impl(const std::string& secret, const std::vector<std::string>& processes,
       const std::optional<internal::CurveKeys>& curve_keys)
      : gate(context, [secret, processes, curve_keys](const internal::ZapRequest& request) {
          if (curve_keys) {
            // CURVE: only a holder of the run's secret has the client key; its name is its routing id
            const bool run_key = request.mechanism == "CURVE" && request.credentials.size() == 1 &&
                                 request.credentials[0] == curve_keys->client_public_raw;
            return run_key ? std::string() : std::string("a peer without the run's keys");
          }
          // PLAIN: the user name is the process's name, the password the run's secret
          const std::vector<std::string>& credentials = request.credentials;
          if (request.mechanism != "PLAIN" || credentials.size() != 2)
            return std::string("a peer with no name and password");
          if (std::find(processes.begin(), processes.end(), credentials[0]) == processes.end()) {
            return "'" + credentials[0] + "' is not a process of this run";
          }
          if (!SameSecret(credentials[1], secret)) return "'" + credentials[0] + "' without the run's secret";
          return std::string();
        }) {}
  zmq::context_t context{1};
  internal::ZapGate gate;  // bound before the server socket exists, so no handshake passes unchecked
  zmq::socket_t socket{context, zmq::socket_type::router};
};

ControlServer::ControlServer(const std::string& endpoint, const std::string& secret,
                             const std::vector<std::string>& processes) {
  const std::optional<internal::CurveKeys> curve_keys =
      Encrypted(endpoint) ? std::optional(internal::RunCurveKeys(secret)) : std::nullopt;
  impl_ = std::make_unique<Impl>(secret, processes, curve_keys);
  impl_->socket.set(zmq::sockopt::linger, 0);
  impl_->socket.set(zmq::sockopt::router_mandatory, 0);  // a process that already exited is not an error
  if (curve_keys) {
    impl_->socket.set(zmq::sockopt::curve_server, 1);
    impl_->socket.set(zmq::sockopt::curve_secretkey, curve_keys->server_secret);
  } else {
    impl_->socket.set(zmq::sockopt::plain_server, 1);
  }
  impl_->socket.set(zmq::sockopt::zap_domain, kZapDomain);
  impl_->gate.Watch(impl_->socket);
  try {
    impl_->socket.bind(endpoint);
  } catch (const zmq::error_t& e) {
    throw BusError("launcher: cannot bind control endpoint '" + endpoint + "': " + e.what());
  }
}

ControlServer::~ControlServer() { impl_->gate.StopWatching(); }  // before the socket closes

void ControlServer::Send(const std::string& process, const std::string& kind) {
  impl_->socket.send(zmq::buffer(process), zmq::send_flags::sndmore | zmq::send_flags::dontwait);
  impl_->socket.send(zmq::buffer(kind), zmq::send_flags::dontwait);
}

std::optional<ControlMessage> ControlServer::Receive(std::chrono::milliseconds timeout) {
  auto& impl = *impl_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    zmq::pollitem_t items[] = {{impl.socket.handle(), 0, ZMQ_POLLIN, 0},
                               {impl.gate.zap().handle(), 0, ZMQ_POLLIN, 0},
                               {impl.gate.monitors().at(0).handle(), 0, ZMQ_POLLIN, 0}};
    const auto left = std::max(
        std::chrono::milliseconds(0),
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
    try {
      if (zmq::poll(items, 3, left) == 0) return std::nullopt;
    } catch (const zmq::error_t& e) {
      if (e.num() == EINTR) return std::nullopt;
      throw;
    }
    impl.gate.Serve();
    if (items[0].revents & ZMQ_POLLIN) {
      zmq::message_t identity;
      if (!impl.socket.recv(identity)) return std::nullopt;
      ControlMessage message;
      message.process = ToString(identity);
      return ReadKindAndBody(impl.socket, message);
    }
  }
}

uint64_t ControlServer::refused() const { return impl_->gate.refused(); }

std::vector<std::string> ControlServer::TakeRefusals() { return impl_->gate.TakeRefusals(); }

}  // namespace iapsim::bridge
