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

class ZapGate {
 public:
  /// Returns "" to accept a peer, else why it is refused. `credentials`: PLAIN's user name and password, or
  /// CURVE's 32-byte public key.
  using Check =
      std::function<std::string(const std::string& mechanism, const std::vector<std::string>& credentials)>;

  /// Binds the context's ZAP endpoint: make it before any socket of `context` binds or connects.
  ZapGate(zmq::context_t& context, Check check);
  /// Counts the failed handshakes of `socket` (a server: after its mechanism is set, before it binds).
  void Watch(zmq::socket_t& socket);
  /// Answers the requests and reads the events that are waiting; never blocks.
  void Serve();
  /// Sockets to poll for, so that a waiting thread can Serve at once.
  zmq::socket_t& zap() { return zap_; }
  zmq::socket_t& monitor() { return monitor_; }

  uint64_t refused() const { return refused_; }
  /// What was refused since the last call, each kind once over the gate's life (a refused peer retries every
  /// few hundred milliseconds).
  std::vector<std::string> TakeRefusals();

 private:
  void Describe(const std::string& refusal);

  zmq::socket_t zap_;
  zmq::socket_t monitor_;
  Check check_;
  uint64_t refused_ = 0;
  std::vector<std::string> refusals_;
  std::set<std::string> described_;
};

/// The CURVE keys of a run (Z85 text), all derived from its secret (bridge/run_secret.h): the run's
/// publishers share one server key pair, its subscribers one client key pair. Only a holder of the secret can
/// complete a handshake, and the traffic is encrypted.
struct CurveKeys {
  std::string server_public, server_secret, client_public, client_secret;
  std::string client_public_raw;  // 32 bytes, as a ZAP request carries it
};
/// Throws std::invalid_argument unless `secret` is 64 hex digits.
CurveKeys RunCurveKeys(const std::string& secret);

}  // namespace iapsim::bridge::internal
