#pragma once
// Launcher <-> process control messages (start-up barrier, heartbeats, stop, final reports), separate from
// the data bus so that supervision works whatever the data topics do.
//
// Process -> launcher: hello (bus bound), ready (handshake done), heartbeat <sim_ns>, done (clock owner
// finished the run), error <text>, bye <json report>. Launcher -> process: start, stop, alive (to processes
// started elsewhere, which have no PR_SET_PDEATHSIG to follow the launcher: one that hears nothing for its
// hang_timeout_s stops).
//
// Only the run's processes get in: a client authenticates with ZeroMQ's PLAIN mechanism (user name: its
// process name, password: the run's secret, bridge/run_secret.h), checked by the launcher's ZAP handler
// (ZeroMQ RFC 27) before a single message passes. A peer with another secret, another name or no
// credentials at all is refused at the handshake, counted and described (ControlServer::TakeRefusals).
// Over tcp, which may leave the host, the channel is CURVE with the run's keys instead (bridge/bus.h):
// encrypted, the secret never on the wire, a process's name its ZeroMQ routing id.

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace iapsim::bridge {

struct ControlMessage {
  std::string process;  // sender (launcher side only)
  std::string kind;
  std::string body;
};

/// The process side: one per process, identified by its name.
class ControlClient {
 public:
  ControlClient(const std::string& endpoint, const std::string& process, const std::string& secret);
  ~ControlClient();
  /// Queues a message for the launcher (dropped once the launcher has refused this client: Refused).
  void Send(const std::string& kind, const std::string& body = "");
  /// A message from the launcher if one arrives within `timeout`.
  std::optional<ControlMessage> Receive(std::chrono::milliseconds timeout);
  /// Whether the launcher has refused this client's credentials (and never accepted them): its messages
  /// never leave. A client that never got in does not linger 1 s for them at close as it does otherwise.
  bool Refused();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The launcher side.
class ControlServer {
 public:
  /// Accepts the `processes` named, with `secret`.
  ControlServer(const std::string& endpoint, const std::string& secret,
                const std::vector<std::string>& processes);
  ~ControlServer();
  void Send(const std::string& process, const std::string& kind);
  /// A message from an accepted process if one arrives within `timeout` (authenticating peers meanwhile).
  std::optional<ControlMessage> Receive(std::chrono::milliseconds timeout);
  /// Connections refused so far.
  uint64_t refused() const;
  /// What was refused since the last call, one line each (who, from where, why), for the log.
  std::vector<std::string> TakeRefusals();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iapsim::bridge
