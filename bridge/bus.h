#pragma once
// Publish/subscribe bus between iapsim processes. The transports stay behind this interface.
//
// Topology: every node binds one publisher endpoint and connects its subscriber to the endpoints of its
// peers. All of a node's topics leave through that one publisher, so the messages of one node reach a
// subscriber in the order they were sent, across topics (the lockstep protocol relies on it). A ZeroMQ
// publisher may bind a second endpoint for observers (BusOptions::observer_endpoint), which never wait.
//
// Transports, by endpoint (a node may bind one kind and have peers of any kind):
//   shm://NAME        same host, shared memory: a queue per (publisher, subscriber) pair that the subscriber
//                     reads without a system call; Spin looks for messages for `spin` before it sleeps
//   ipc://@NAME       same host, ZeroMQ over abstract unix sockets
//   tcp://HOST:PORT   ZeroMQ over TCP, across hosts
//
// Frames on the wire: [topic '\0'] [meta: version, per-topic sequence, send time, datatype, md5, publisher]
// [payload] (a shared-memory record holds the same three).
//
// Queues and drops: a ZeroMQ connection queues up to `send_hwm` messages at the publisher and `receive_hwm`
// at the subscriber; a shared-memory queue starts at `shm_initial_queue_bytes` and doubles as needed up to
// `shm_max_queue_bytes`. When a subscriber's queue is full:
//   kDropNewest (best effort): that subscriber alone misses the message; it counts the gap in the per-topic
//               sequence as lost, and every other subscriber is unaffected.
//   kBlock (lossless, lockstep): the publisher waits up to `block_timeout` for room, then counts the
//               message as dropped (ZeroMQ: nobody gets it; shared memory: the subscribers that were full
//               miss it and see the gap).

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "bridge/message.h"
#include "bridge/message_limits.h"

namespace iapsim::bridge {

/// A wiring or protocol fault on the bus (type mismatch, bad endpoint). The message names topic and node.
class BusError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class DropPolicy { kDropNewest, kBlock };

struct BusOptions {
  std::string node_name;
  std::string bind_endpoint;                // "ipc://@name", "ipc:///path", "tcp://127.0.0.1:5555" or ":*"
  std::vector<std::string> peer_endpoints;  // publishers of the other nodes
  int send_hwm = 10000;                     // messages queued per subscriber at this publisher
  int receive_hwm = 10000;                  // messages queued per publisher at this subscriber
  DropPolicy drop_policy = DropPolicy::kBlock;
  std::chrono::milliseconds block_timeout{2000};
  // shm peers: Spin polls the queues this long, then sleeps (not while its yields lose the core: Spin)
  std::chrono::microseconds spin{50};
  // shm peers, 0: a sleeping subscriber is woken by its publishers when data arrives (a system call on their
  // side); > 0: it sleeps this long at most and then looks at its queues, and publishers never wake it (for
  // a subscriber that may lag, such as the recorder, so as to cost its publishers nothing)
  std::chrono::microseconds poll_period{0};
  size_t shm_initial_queue_bytes = 64 << 10;  // per subscriber of an shm:// publisher
  size_t shm_max_queue_bytes = 64 << 20;      // a larger message is an error
  // shm: what a subscriber must present to a publisher (the run's secret, bridge/run_secret.h); peers of
  // another user are refused whatever they present
  std::string secret;
  // shm: the run's processes. A blocking publisher waits only for these; another subscriber (`iapsim echo`)
  // is best effort and is dropped when it stops reading. Empty: every subscriber is waited for.
  std::vector<std::string> members;
  // ZeroMQ (ipc, tcp), where a blocking publisher waits for every subscriber of its socket: a second
  // publisher endpoint, for subscribers that are not of the run. Each gets this node's messages best effort
  // (a full queue drops them for it alone), so none can hold the run. Empty: none.
  std::string observer_endpoint;
  // this node is not of the run (`iapsim echo`): with a secret it presents the observer keys, which only
  // observer endpoints accept (shared memory tells it apart by `members`)
  bool observer = false;
  // the largest message per topic: PublishRaw throws BusError on a larger one; Spin discards a larger one
  // from a peer (counted as `oversized`, logged once per publisher and topic) before any callback sees it
  MessageSizeLimits message_limits;
};

struct TopicCounters {
  uint64_t sent = 0;
  uint64_t dropped = 0;  // not sent: a subscriber's queue stayed full (see DropPolicy)
  uint64_t received = 0;
  uint64_t lost = 0;       // gaps in the publisher's sequence seen at this subscriber
  uint64_t oversized = 0;  // received over the topic's size limit (BusOptions::message_limits): discarded
  // this node subscribed to the topic by name or received some of it (what it may have missed: the
  // launcher compares `received` with what its peers published)
  bool subscribed = false;
};

struct BusStats {
  std::map<std::string, TopicCounters> topics;
  uint64_t malformed = 0;  // frames that were not a well-formed iapsim message
  uint64_t sleeps = 0;     // Spin calls that found nothing and slept
  // sleeps that ran to their timeout: a subscriber woken by its publishers (poll_period 0) only times out
  // when nothing was sent to it (the ZeroMQ path cannot tell and counts none)
  uint64_t sleeps_timed_out = 0;
  // shm spins cut short because a yield gave the core to another task (the machine is oversubscribed); each
  // makes the next waits sleep without spinning
  uint64_t contended_spins = 0;
  uint64_t refused_peers = 0;        // shm connections refused: another user, or without the run's secret
  uint64_t dropped_subscribers = 0;  // shm subscribers let go: not of the run, and not reading
};

/// Metadata of a received message.
struct MessageInfo {
  const std::string& topic;
  const std::string& datatype;
  const std::string& md5;
  const std::string& publisher;
  uint64_t sequence;     // per topic and publisher, starting at 0
  int64_t sent_unix_ns;  // the publisher's wall clock (UnixTimeNs) when it sent the message
  /// Numbers the (publisher, topic) pairs this bus has received from 0 up, in order of first message: a
  /// subscriber keeps per-stream state in a vector instead of looking the two names up.
  uint32_t stream;
};

/// Wall-clock time (CLOCK_REALTIME, ns since the Unix epoch): comparable between processes, and between
/// hosts as far as their clocks are synchronised. For latencies, never for simulated time.
int64_t UnixTimeNs();

class Bus {
 public:
  using RawCallback = std::function<void(const uint8_t* data, size_t size, const MessageInfo& info)>;

  explicit Bus(const BusOptions& options);
  ~Bus();
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  const std::string& node_name() const;
  /// The endpoint actually bound (resolves a tcp wildcard port).
  std::string bound_endpoint() const;

  void PublishRaw(const std::string& topic, const TypeInfo& type, const uint8_t* data, size_t size);

  template <class M>
  void Publish(const std::string& topic, const M& message) {
    EncodeInto(message, &scratch_);
    PublishRaw(topic, TypeInfoOf<M>(), scratch_.data(), scratch_.size());
  }

  /// Calls `callback` for each message on `topic`. A message of another type or md5 makes Spin throw.
  template <class M>
  void Subscribe(const std::string& topic, std::function<void(const M&, const MessageInfo&)> callback) {
    auto message = std::make_shared<M>();
    AddSubscription(topic, /*exact=*/true, &TypeInfoOf<M>(),
                    [message, callback, topic](const uint8_t* data, size_t size, const MessageInfo& info) {
                      std::string error;
                      if (!Decode(data, size, message.get(), &error)) {
                        throw BusError("topic '" + topic + "' from '" + info.publisher + "': undecodable " +
                                       info.datatype + ": " + error);
                      }
                      callback(*message, info);
                    });
  }

  /// Every message whose topic starts with `prefix` ("" for all), of any type, undecoded.
  void SubscribeRaw(const std::string& prefix, RawCallback callback);

  /// Every message on `topic` (that name exactly), undecoded; one of another type or md5 than `type` (which
  /// must outlive the bus) makes Spin throw, as with Subscribe.
  void SubscribeSerialized(const std::string& topic, const TypeInfo& type, RawCallback callback);

  /// Until the next call, these peers (node names) get none of this node's messages over shared memory,
  /// whatever they subscribed to: the lockstep clock owner mutes, for a step, the processes not due at it.
  /// ZeroMQ connections are not muted.
  void SetMutedPeers(const std::vector<std::string>& peers);

  /// Waits up to `timeout` for a message, then dispatches everything already queued (at most `max_batch`).
  /// Returns the number of messages dispatched. Throws BusError on a type mismatch.
  int Spin(std::chrono::microseconds timeout, int max_batch = 1000);

  /// Start-up handshake against the slow-joiner problem. A node publishes hellos until told to start;
  /// HandshakeComplete(peers) becomes true once every subscription this node made before the handshake is
  /// live at every peer's publisher.
  void BeginHandshake();
  void PublishHello();
  bool HandshakeComplete(const std::vector<std::string>& peers);
  void EndHandshake();

  const BusStats& stats() const { return stats_; }

 private:
  void AddSubscription(const std::string& topic, bool exact, const TypeInfo* type, RawCallback callback);

  struct Impl;
  std::unique_ptr<Impl> impl_;
  BusStats stats_;
  std::vector<uint8_t> scratch_;
};

}  // namespace iapsim::bridge
