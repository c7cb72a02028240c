#pragma once
// ZeroMQ authentication for the control channel and the ZeroMQ transports of the bus (internal: never
// included by public headers). A ZapGate is the ZAP handler (ZeroMQ RFC 27) of one context: each peer's
// credentials are checked before a single message passes, and a monitor counts every failed handshake
// (a peer with the wrong credentials, or with none: another security mechanism).

#include <cstdint>
#include <functional>
#include <set>
#include <string>
#include <vector>
#include <zmq.hpp>

namespace iapsim::bridge::internal {

/// What a peer presents at its handshake.
struct ZapRequest {
  std::string domain;   // the server socket's ZAP domain
  std::string address;  // the peer's (tcp: its IP address; ipc: empty)
  std::string mechanism;
  std::vector<std::string> credentials;  // PLAIN's user name and password, or CURVE's 32-byte public key
};

class ZapGate {
 public:
  /// Returns "" to accept a peer, else why it is refused.
  using Check = std::function<std::string(const ZapRequest& request)>;

  /// Binds the context's ZAP endpoint: make it before any socket of `context` binds or connects.
  ZapGate(zmq::context_t& context, Check check);
  /// Counts the failed handshakes of `socket` (a server: after its mechanism is set, before it binds).
  void Watch(zmq::socket_t& socket);
  /// Stops the monitors: call it before a watched socket closes. libzmq 4.3.4 may deadlock the closing of
  /// a socket whose monitor still runs (its own tests unregister the monitor first, libzmq commit 66094678),
  /// the likelier while refused peers keep failing their handshakes (most likely why a launcher hung 600 s
  /// in CI, 2026-11-28; not reproduced on demand).
  void StopWatching();
  /// Answers the requests and reads the events that are waiting; never blocks.
  void Serve();
  /// Sockets to poll for, so that a waiting thread can Serve at once: the ZAP endpoint, and a monitor per
  /// watched socket.
  zmq::socket_t& zap() { return zap_; }
  std::vector<zmq::socket_t>& monitors() { return monitors_; }

  uint64_t refused() const { return refused_; }
  /// What was refused since the last call, each kind once over the gate's life (a refused peer retries every
  /// few hundred milliseconds).
  std::vector<std::string> TakeRefusals();

 private:
  void Describe(const std::string& refusal);

  zmq::context_t& context_;
  zmq::socket_t zap_;
  std::vector<zmq::socket_t> monitors_;  // PAIR sockets: one per watched socket
  std::vector<void*> watched_;           // the watched sockets' handles
  Check check_;
  uint64_t refused_ = 0;
  std::vector<std::string> refusals_;
  std::set<std::string> described_;
};

/// A PAIR socket of `context` that receives the `events` (ZMQ_EVENT_* bits) of `socket`. Stop it with
/// zmq_socket_monitor(socket, nullptr, 0) before `socket` closes (ZapGate::StopWatching says why).
zmq::socket_t MonitorSocket(zmq::context_t& context, zmq::socket_t& socket, int events);
/// The ids (ZMQ_EVENT_*) of the events waiting on a MonitorSocket, oldest first; never blocks.
std::vector<uint16_t> TakeEvents(zmq::socket_t& monitor);

/// The CURVE keys of a run (Z85 text), all derived from its secret (bridge/run_secret.h): the run's
/// publishers share one server key pair, its processes' subscribers one client key pair, and subscribers
/// that are not of the run (`iapsim echo`) another. Only a holder of the secret can complete a handshake,
/// and the traffic is encrypted.
struct CurveKeys {
  std::string server_public, server_secret, client_public, client_secret, observer_public, observer_secret;
  std::string client_public_raw, observer_public_raw;  // 32 bytes, as a ZAP request carries them
};
/// Throws std::invalid_argument unless `secret` is 64 hex digits.
CurveKeys RunCurveKeys(const std::string& secret);

}  // namespace iapsim::bridge::internal
