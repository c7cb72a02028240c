#pragma once
// Launcher <-> process control messages (start-up barrier, heartbeats, stop, final reports), separate from
// the data bus so that supervision works whatever the data topics do.
//
// Process -> launcher: hello (bus bound), ready (handshake done), heartbeat <sim_ns>, done (clock owner
// finished the run), error <text>, bye <json report>. Launcher -> process: start, stop.

#include <chrono>
#include <memory>
#include <optional>
#include <string>

namespace iapsim::bridge {

struct ControlMessage {
  std::string process;  // sender (launcher side only)
  std::string kind;
  std::string body;
};

/// The process side: one per process, identified by its name.
class ControlClient {
 public:
  ControlClient(const std::string& endpoint, const std::string& process);
  ~ControlClient();
  void Send(const std::string& kind, const std::string& body = "");
  /// A message from the launcher if one arrives within `timeout`.
  std::optional<ControlMessage> Receive(std::chrono::milliseconds timeout);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The launcher side.
class ControlServer {
 public:
  explicit ControlServer(const std::string& endpoint);
  ~ControlServer();
  void Send(const std::string& process, const std::string& kind);
  std::optional<ControlMessage> Receive(std::chrono::milliseconds timeout);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iapsim::bridge
