#include "bridge/bus.h"

#include <iapsim_msgs/Hello.h>
#include <poll.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstring>
#include <optional>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <zmq.hpp>

#include "bridge/internal/shm_transport.h"
#include "bridge/internal/zap_gate.h"
#include "bridge/internal/zmq_poll.h"

namespace iapsim::bridge {
namespace {

constexpr uint8_t kWireVersion = 3;
// the meta frame's flags: the subscriber missed this topic's messages before this one by the publisher's
// schedule (SetMutedPeers), not by loss
constexpr uint8_t kResyncFlag = 1;
constexpr char kHelloTopic[] = "/iapsim/hello";
constexpr char kConfirmTopic[] = "/iapsim/hello_confirm";
// the largest message a ZeroMQ publisher takes from a peer: a subscription (a topic prefix)
constexpr size_t kMaxSubscriptionBytes = 64 << 10;
// ZAP domains of a ZeroMQ node's two publisher sockets
constexpr char kMemberDomain[] = "iapsim";
constexpr char kObserverDomain[] = "iapsim-observers";

// the meta frame's part that changes from message to message: version, flags, sequence, send time
constexpr size_t kMetaFixedBytes = 18;

// meta frame: u8 version | u64 sequence | i64 sent_unix_ns | u16 n + datatype | 32 md5 chars | u16 n +
// publisher
void AppendU16String(std::string* out, const std::string& s) {
  const uint16_t n = static_cast<uint16_t>(s.size());
  out->append(reinterpret_cast<const char*>(&n), 2);
  out->append(s);
}

bool ReadU16String(const uint8_t*& p, const uint8_t* end, std::string* s) {
  if (end - p < 2) return false;
  uint16_t n;
  std::memcpy(&n, p, 2);
  p += 2;
  if (end - p < n) return false;
  s->assign(reinterpret_cast<const char*>(p), n);
  p += n;
  return true;
}

struct Meta {
  uint8_t flags = 0;
  uint64_t sequence = 0;
  int64_t sent_unix_ns = 0;
  std::string datatype;
  std::string md5;
  std::string publisher;
};

bool ParseMeta(const uint8_t* p, size_t size, Meta* meta) {
  const uint8_t* end = p + size;
  if (end - p < static_cast<std::ptrdiff_t>(kMetaFixedBytes) || p[0] != kWireVersion) return false;
  meta->flags = p[1];
  std::memcpy(&meta->sequence, p + 2, 8);
  std::memcpy(&meta->sent_unix_ns, p + 10, 8);
  p += kMetaFixedBytes;
  if (!ReadU16String(p, end, &meta->datatype)) return false;
  if (end - p < 32) return false;
  meta->md5.assign(reinterpret_cast<const char*>(p), 32);
  p += 32;
  return ReadU16String(p, end, &meta->publisher) && p == end;
}

// A shared-memory record holds the three frames: u32 topic size | u32 meta size | topic | meta | payload.
constexpr size_t kRecordPrefixBytes = 8;

struct Subscription {
  std::string topic;  // exact topic, or prefix
  bool exact;
  const TypeInfo* type;  // nullptr: any type
  Bus::RawCallback callback;
};

}  // namespace

struct Bus::Impl {
  BusOptions options;
  BusStats* stats = nullptr;  // the Bus's
  zmq::context_t context{1};
  std::optional<internal::ZapGate> zap;  // with a secret: the ZeroMQ publisher's authentication
  zmq::socket_t publisher{context, zmq::socket_type::xpub};
  zmq::socket_t observers;  // BusOptions::observer_endpoint (an XPUB), when bound
  zmq::socket_t subscriber{context, zmq::socket_type::sub};
  std::vector<std::string> observer_joins;  // where observers joined from, until logged
  int observed_prefixes = 0;  // topic prefixes observers subscribed to: none, nothing to send them
  std::unique_ptr<internal::ShmPublisher> shm_publisher;    // when bound to shm://
  std::unique_ptr<internal::ShmSubscriber> shm_subscriber;  // when some peers are shm://
  bool zmq_peers = false;
  std::vector<std::string> prefixes;  // subscribed prefix bytes, repeated as often as subscribed
  std::chrono::steady_clock::time_point next_maintenance{}, next_accept{};
  std::vector<pollfd> poll_fds;
  std::vector<zmq::pollitem_t> poll_items;
  std::vector<Subscription> subscriptions;
  // what a message costs to count is one hash lookup: per topic published, its next sequence number and its
  // counters; per (publisher '\0' topic) received, the sequence expected next and the topic's counters
  struct Sequence {
    uint64_t next = 0;
    TopicCounters* counters = nullptr;  // a node of BusStats::topics: its address never changes
    uint32_t stream = 0;                // received: MessageInfo::stream
    size_t max_bytes = 0;               // the topic's size limit
    bool oversized_logged = false;      // received: a discarded message was logged
    // published: the meta frame, made once per type; each message writes its sequence and send time in
    const TypeInfo* meta_type = nullptr;
    std::string meta;
  };
  std::unordered_map<std::string, Sequence> published;
  std::unordered_map<std::string, Sequence> received;
  // A received stream as its frames name it: the topic frame and the meta frame after its per-message part
  // (datatype, md5, publisher), parsed once. A message whose bytes match a known key costs one hash of
  // them: no parsing, no copies of its names, and the subscriptions it goes to found before.
  struct Stream {
    std::string topic, datatype, md5, publisher;  // what MessageInfo refers to
    Sequence* sequence = nullptr;                 // of (publisher, topic): a type change keeps counting it
    struct Match {
      size_t subscription;  // in subscriptions, which only grow
      bool wrong_type;
    };
    std::vector<Match> matches;
    size_t subscriptions_matched = 0;  // subscriptions.size() when `matches` was made
  };
  std::unordered_map<std::string, Stream> streams;
  std::string stream_key;  // its storage reused from message to message
  std::set<std::string> hello_from, confirm_from;
  bool confirm_subscribed = false;
  int spins_since_drain = 0;
  // contention-aware spinning (see Spin): waits left to sleep through without spinning, and how many the
  // next contended spin buys
  int spinless_waits_left = 0, spin_backoff = 0;
  Meta meta;  // of a message on a stream not seen before

  void Subscribe(const std::string& prefix_bytes) {
    subscriber.set(zmq::sockopt::subscribe, prefix_bytes);
    prefixes.push_back(prefix_bytes);
    if (shm_subscriber) shm_subscriber->SetSubscriptions(prefixes);
  }
  void Unsubscribe(const std::string& prefix_bytes) {
    subscriber.set(zmq::sockopt::unsubscribe, prefix_bytes);
    auto it = std::find(prefixes.begin(), prefixes.end(), prefix_bytes);
    if (it != prefixes.end()) prefixes.erase(it);
    if (shm_subscriber) shm_subscriber->SetSubscriptions(prefixes);
  }

  int DrainQueued(BusStats& stats, int max_batch) {
    int dispatched = 0;
    if (shm_subscriber) {
      try {
        shm_subscriber->Drain(max_batch, [&](const uint8_t* record, size_t size) {
          if (DispatchRecord(stats, record, size)) ++dispatched;
        });
      } catch (const BusError&) {
        throw;
      } catch (const std::runtime_error& e) {
        throw BusError("node '" + options.node_name + "': " + e.what());
      }
    }
    if (zmq_peers && dispatched < max_batch) dispatched += DrainZmq(stats, max_batch - dispatched);
    return dispatched;
  }

  bool DispatchRecord(BusStats& stats, const uint8_t* record, size_t size) {
    uint32_t sizes[2];
    if (size < kRecordPrefixBytes) return Malformed(stats);
    std::memcpy(sizes, record, kRecordPrefixBytes);
    if (sizes[0] > size - kRecordPrefixBytes || sizes[1] > size - kRecordPrefixBytes - sizes[0]) {
      return Malformed(stats);
    }
    const uint8_t* topic_bytes = record + kRecordPrefixBytes;
    const uint8_t* meta_bytes = topic_bytes + sizes[0];
    const uint8_t* payload = meta_bytes + sizes[1];
    return Dispatch(stats, reinterpret_cast<const char*>(topic_bytes), sizes[0], meta_bytes, sizes[1],
                    payload, size - kRecordPrefixBytes - sizes[0] - sizes[1]);
  }

  int DrainZmq(BusStats& stats, int max_batch) {
    int dispatched = 0;
    zmq::message_t topic_frame, meta_frame, payload;
    while (dispatched < max_batch && subscriber.recv(topic_frame, zmq::recv_flags::dontwait)) {
      // read the whole multipart message before judging it, so a bad one never desynchronises the stream
      bool complete =
          topic_frame.more() && subscriber.recv(meta_frame) && meta_frame.more() && subscriber.recv(payload);
      while (subscriber.get(zmq::sockopt::rcvmore)) {
        zmq::message_t rest;
        (void)subscriber.recv(rest);
        complete = false;
      }
      if (!complete) {
        Malformed(stats);
        continue;
      }
      if (Dispatch(stats, static_cast<const char*>(topic_frame.data()), topic_frame.size(),
                   static_cast<const uint8_t*>(meta_frame.data()), meta_frame.size(),
                   static_cast<const uint8_t*>(payload.data()), payload.size())) {
        ++dispatched;
      }
    }
    return dispatched;
  }

  bool Malformed(BusStats& stats) {
    ++stats.malformed;
    return false;
  }

  // One message to the subscriptions it matches; false for handshake traffic and malformed messages.
  bool Dispatch(BusStats& stats, const char* topic_bytes, size_t topic_size, const uint8_t* meta_bytes,
                size_t meta_size, const uint8_t* payload, size_t payload_size) {
    if (topic_size == 0 || topic_bytes[topic_size - 1] != '\0' || meta_size < kMetaFixedBytes ||
        meta_bytes[0] != kWireVersion) {
      return Malformed(stats);
    }
    stream_key.assign(topic_bytes, topic_size)
        .append(reinterpret_cast<const char*>(meta_bytes) + kMetaFixedBytes, meta_size - kMetaFixedBytes);
    auto found = streams.find(stream_key);
    if (found == streams.end()) {
      if (!ParseMeta(meta_bytes, meta_size, &meta)) return Malformed(stats);
      const std::string_view topic(topic_bytes, topic_size - 1);
      // handshake traffic is handled here and never reaches subscribers
      if (topic == kHelloTopic || topic == kConfirmTopic) {
        (topic == kHelloTopic ? hello_from : confirm_from).insert(meta.publisher);
        return false;
      }
      found = streams.emplace(stream_key, NewStream(stats, std::string(topic))).first;
    }
    Stream& stream = found->second;
    Sequence& expected = *stream.sequence;
    const uint8_t flags = meta_bytes[1];
    uint64_t sequence;
    int64_t sent_unix_ns;
    std::memcpy(&sequence, meta_bytes + 2, 8);
    std::memcpy(&sent_unix_ns, meta_bytes + 10, 8);
    if (sequence > expected.next && !(flags & kResyncFlag))
      expected.counters->lost += sequence - expected.next;
    expected.next = sequence + 1;
    // a peer with other limits (or none): never decoded, so it cannot make this process allocate for it
    if (payload_size > expected.max_bytes) {
      ++expected.counters->oversized;
      if (!expected.oversized_logged) {
        expected.oversized_logged = true;
        spdlog::warn(
            "node '{}': discarded a message of {} bytes on '{}' from '{}': over the topic's limit of {} "
            "bytes",
            options.node_name, payload_size, stream.topic, stream.publisher, expected.max_bytes);
      }
      return false;
    }
    ++expected.counters->received;

    if (stream.subscriptions_matched != subscriptions.size()) Match(stream);
    const MessageInfo info{stream.topic, stream.datatype, stream.md5,     stream.publisher,
                           sequence,     sent_unix_ns,    expected.stream};
    for (const Stream::Match& match : stream.matches) {
      const Subscription& sub = subscriptions[match.subscription];
      if (match.wrong_type) {
        throw BusError("topic '" + stream.topic + "': node '" + options.node_name + "' expects " +
                       sub.type->datatype + " (md5 " + sub.type->md5 + ") but '" + stream.publisher +
                       "' sends " + stream.datatype + " (md5 " + stream.md5 + ")");
      }
      sub.callback(payload, payload_size, info);
    }
    return true;
  }

  // The stream of `meta` on `topic`, counted with its (publisher, topic)'s sequence.
  Stream NewStream(BusStats& stats, std::string topic) {
    Stream stream;
    std::string key = meta.publisher + '\0' + topic;
    auto found = received.find(key);
    if (found == received.end()) {
      Sequence sequence;
      sequence.next = meta.sequence;
      sequence.counters = &stats.topics[topic];
      sequence.counters->subscribed = true;
      sequence.stream = static_cast<uint32_t>(received.size());
      sequence.max_bytes = options.message_limits.For(topic);
      found = received.emplace(std::move(key), std::move(sequence)).first;
    }
    stream.sequence = &found->second;
    stream.topic = std::move(topic);
    stream.datatype = meta.datatype;
    stream.md5 = meta.md5;
    stream.publisher = meta.publisher;
    return stream;
  }

  // The subscriptions a stream goes to, in the order they were made.
  void Match(Stream& stream) const {
    stream.matches.clear();
    for (size_t i = 0; i < subscriptions.size(); ++i) {
      const Subscription& sub = subscriptions[i];
      const std::string& topic = stream.topic;
      const bool match = sub.exact ? sub.topic == topic : topic.compare(0, sub.topic.size(), sub.topic) == 0;
      if (!match) continue;
      const bool wrong_type =
          sub.type && (sub.type->datatype != stream.datatype || sub.type->md5 != stream.md5);
      stream.matches.push_back({i, wrong_type});
    }
    stream.subscriptions_matched = subscriptions.size();
  }

  // shared memory: takes new subscribers and (re)connects to publishers, a few system calls each, so at
  // most every millisecond unless `now`
  void Maintain(bool now) {
    const auto t = std::chrono::steady_clock::now();
    if (!now && t < next_maintenance) return;
    next_maintenance = t + std::chrono::milliseconds(1);
    if (shm_publisher) shm_publisher->Accept();
    if (shm_subscriber) shm_subscriber->Maintain();
    ReportConnectionEvents();
  }
  // refusals and dropped subscribers, each logged once, and their counts
  void ReportConnectionEvents() {
    std::vector<std::string> events;
    stats->refused_peers = 0;
    if (zap) {
      zap->Serve();
      for (std::string& e : zap->TakeRefusals()) events.push_back("refused " + std::move(e));
      stats->refused_peers = zap->refused();
    }
    if (shm_publisher) {
      for (std::string& e : shm_publisher->TakeEvents()) events.push_back(std::move(e));
      stats->refused_peers += shm_publisher->refused();
      stats->dropped_subscribers = shm_publisher->dropped_subscribers();
    }
    if (shm_subscriber) {
      for (std::string& e : shm_subscriber->TakeEvents()) events.push_back(std::move(e));
      stats->refused_peers += shm_subscriber->refused();
    }
    for (const std::string& e : events) spdlog::warn("node '{}': {}", options.node_name, e);
    for (const std::string& address : observer_joins) {
      spdlog::info("node '{}': an observer joined{}; it gets messages best effort and never holds this node",
                   options.node_name, address.empty() ? "" : " from " + address);
    }
    observer_joins.clear();
  }
  // a process that only publishes takes its subscribers too
  void AcceptSubscribers() {
    const auto t = std::chrono::steady_clock::now();
    if (t < next_accept) return;
    next_accept = t + std::chrono::milliseconds(1);
    shm_publisher->Accept();
    ReportConnectionEvents();
  }

  // subscription notices arrive on the XPUB sockets: the publisher's are only drained to bound their queue;
  // the observers' tell whether anyone watches (an XPUB passes on the first subscription to a prefix and,
  // when the last subscriber of it leaves or disconnects, its unsubscription)
  void DrainSubscriptionNotices() {
    zmq::message_t notice;
    while (publisher.recv(notice, zmq::recv_flags::dontwait)) {
    }
    while (observers && observers.recv(notice, zmq::recv_flags::dontwait)) {
      if (notice.size() == 0) continue;
      if (static_cast<const uint8_t*>(notice.data())[0] == 1) {
        ++observed_prefixes;
      } else if (observed_prefixes > 0) {
        --observed_prefixes;
      }
    }
  }
};

Bus::Bus(const BusOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
  impl_->stats = &stats_;
  auto& pub = impl_->publisher;
  auto& sub = impl_->subscriber;
  pub.set(zmq::sockopt::sndhwm, options.send_hwm);
  // kBlock: a full queue makes send fail (EAGAIN) so we can wait; kDropNewest: ZeroMQ drops per subscriber,
  // so only the slow one misses messages and sees them as gaps in the sequence
  pub.set(zmq::sockopt::xpub_nodrop, options.drop_policy == DropPolicy::kBlock ? 1 : 0);
  pub.set(zmq::sockopt::linger, 500);
  sub.set(zmq::sockopt::rcvhwm, options.receive_hwm);
  sub.set(zmq::sockopt::linger, 0);
  sub.set(zmq::sockopt::reconnect_ivl, 10);  // peers may bind after we connect: retry quickly
  // what a peer may send: subscriptions to a publisher (a topic name), messages up to the largest queue and
  // the largest topic limit to a subscriber; a larger one drops the connection instead of growing this
  // process's memory
  pub.set(zmq::sockopt::maxmsgsize, int64_t{kMaxSubscriptionBytes});
  sub.set(zmq::sockopt::maxmsgsize,
          static_cast<int64_t>(std::min(options.shm_max_queue_bytes, options.message_limits.Largest())));
  const bool shm_publisher = internal::IsShmEndpoint(options.bind_endpoint);
  // shared memory tells observers apart by name; ZeroMQ by the socket they connect to
  if (!shm_publisher && !options.observer_endpoint.empty()) {
    auto& observers = impl_->observers = zmq::socket_t(impl_->context, zmq::socket_type::xpub);
    observers.set(zmq::sockopt::sndhwm, options.send_hwm);
    observers.set(zmq::sockopt::xpub_nodrop, 0);
    observers.set(zmq::sockopt::linger, 0);
    observers.set(zmq::sockopt::maxmsgsize, int64_t{kMaxSubscriptionBytes});
  }
  if (!options.secret.empty()) {
    // a run's ZeroMQ connections (ipc and tcp) use CURVE with the keys of its secret: a peer without them is
    // refused at the handshake (and counted), and nothing travels in clear. The run's processes present
    // one client key, observers another: each is accepted at its own publisher socket only.
    try {
      const internal::CurveKeys keys = internal::RunCurveKeys(options.secret);
      impl_->zap.emplace(impl_->context, [impl = impl_.get(), keys](const internal::ZapRequest& request) {
        const bool client =
            request.credentials.size() == 1 && request.credentials[0] == keys.client_public_raw;
        const bool observer =
            request.credentials.size() == 1 && request.credentials[0] == keys.observer_public_raw;
        if (request.mechanism != "CURVE" || !(client || observer))
          return std::string("a peer without the run's keys");
        if (request.domain == kObserverDomain) {
          impl->observer_joins.push_back(request.address);
          return std::string();
        }
        if (observer)
          return std::string("an observer at a run process's endpoint (observers have their own)");
        return std::string();
      });
      const auto serve = [&](zmq::socket_t& socket, const char* domain) {
        socket.set(zmq::sockopt::curve_server, 1);
        socket.set(zmq::sockopt::curve_secretkey, keys.server_secret);
        socket.set(zmq::sockopt::zap_domain, domain);
        impl_->zap->Watch(socket);
      };
      serve(pub, kMemberDomain);
      if (impl_->observers) serve(impl_->observers, kObserverDomain);
      sub.set(zmq::sockopt::curve_serverkey, keys.server_public);
      sub.set(zmq::sockopt::curve_publickey, options.observer ? keys.observer_public : keys.client_public);
      sub.set(zmq::sockopt::curve_secretkey, options.observer ? keys.observer_secret : keys.client_secret);
    } catch (const std::exception& e) {
      throw BusError("node '" + options.node_name + "': " + e.what());
    }
  }
  std::string binding = options.bind_endpoint;
  try {
    if (shm_publisher) {
      impl_->shm_publisher = std::make_unique<internal::ShmPublisher>(
          internal::ShmPublisher::Options{options.bind_endpoint, options.shm_initial_queue_bytes,
                                          options.shm_max_queue_bytes, options.secret, options.members});
    } else {
      pub.bind(options.bind_endpoint);
      if (impl_->observers) {
        binding = options.observer_endpoint;
        impl_->observers.bind(options.observer_endpoint);
      }
    }
  } catch (const std::exception& e) {
    throw BusError("node '" + options.node_name + "': cannot bind publisher to '" + binding +
                   "': " + e.what());
  }
  std::vector<std::string> shm_peers;
  for (const auto& endpoint : options.peer_endpoints) {
    if (internal::IsShmEndpoint(endpoint)) {
      shm_peers.push_back(endpoint);
      continue;
    }
    try {
      sub.connect(endpoint);
      impl_->zmq_peers = true;
    } catch (const zmq::error_t& e) {
      throw BusError("node '" + options.node_name + "': cannot connect to '" + endpoint + "': " + e.what());
    }
  }
  if (!shm_peers.empty()) {
    try {
      impl_->shm_subscriber =
          std::make_unique<internal::ShmSubscriber>(options.node_name, shm_peers, options.secret);
    } catch (const std::exception& e) {
      throw BusError("node '" + options.node_name + "': " + e.what());
    }
    impl_->Maintain(/*now=*/true);
  }
}

Bus::~Bus() {
  if (impl_ && impl_->zap) impl_->zap->StopWatching();  // before the watched sockets close
}

int64_t UnixTimeNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const std::string& Bus::node_name() const { return impl_->options.node_name; }

std::string Bus::bound_endpoint() const {
  if (impl_->shm_publisher) return impl_->options.bind_endpoint;
  return impl_->publisher.get(zmq::sockopt::last_endpoint);
}

void Bus::PublishRaw(const std::string& topic, const TypeInfo& type, const uint8_t* data, size_t size) {
  auto& impl = *impl_;
  auto found = impl.published.find(topic);
  if (found == impl.published.end()) {
    Impl::Sequence sequence;
    sequence.counters = &stats_.topics[topic];
    sequence.max_bytes = impl.options.message_limits.For(topic);
    found = impl.published.emplace(topic, std::move(sequence)).first;
  }
  if (size > found->second.max_bytes) {
    throw BusError("node '" + impl.options.node_name + "', topic '" + topic + "': a message of " +
                   std::to_string(size) + " bytes is over the topic's limit of " +
                   std::to_string(found->second.max_bytes) + " bytes (the scenario's bus.max_message_kib)");
  }
  auto& counters = *found->second.counters;
  uint64_t& sequence = found->second.next;

  std::string& meta = found->second.meta;
  if (found->second.meta_type != &type) {  // [version][flags][sequence][send time][datatype][md5][publisher]
    found->second.meta_type = &type;
    meta.assign(1, static_cast<char>(kWireVersion));
    meta.append(17, '\0');
    AppendU16String(&meta, type.datatype);
    meta.append(type.md5);
    AppendU16String(&meta, impl.options.node_name);
  }
  const int64_t sent_unix_ns = UnixTimeNs();
  std::memcpy(&meta[2], &sequence, 8);
  std::memcpy(&meta[10], &sent_unix_ns, 8);

  const bool block = impl.options.drop_policy == DropPolicy::kBlock;
  if (impl.shm_publisher) {
    impl.AcceptSubscribers();
    const uint32_t sizes[2] = {static_cast<uint32_t>(topic.size() + 1), static_cast<uint32_t>(meta.size())};
    const internal::ByteSpan parts[] = {{sizes, kRecordPrefixBytes},
                                        {topic.c_str(), topic.size() + 1},
                                        {meta.data(), meta.size()},
                                        {data, size}};
    bool delivered;
    try {
      delivered = impl.shm_publisher->Publish(std::string_view(topic.c_str(), topic.size() + 1), parts, 4,
                                              block, impl.options.block_timeout, &meta[1], kResyncFlag);
    } catch (const std::runtime_error& e) {
      throw BusError("node '" + impl.options.node_name + "', topic '" + topic + "': " + e.what());
    }
    // best effort: a subscriber that misses a message counts the gap itself, as with ZeroMQ
    if (!delivered && block) {
      ++counters.dropped;
      spdlog::warn("node '{}': dropped a message on '{}': {} did not read for {} ms", impl.options.node_name,
                   topic, impl.shm_publisher->stalled(), impl.options.block_timeout.count());
    } else {
      ++counters.sent;
    }
    ++sequence;
    return;
  }
  // the topic frame ends in '\0' so that subscribing to "/a" does not also match "/ab"
  zmq::const_buffer topic_frame(topic.c_str(), topic.size() + 1);
  std::optional<std::chrono::steady_clock::time_point> deadline;  // read the clock only when a queue is full
  while (true) {
    const auto sent = impl.publisher.send(topic_frame, zmq::send_flags::sndmore | zmq::send_flags::dontwait);
    if (sent) break;
    if (!deadline) deadline = std::chrono::steady_clock::now() + impl.options.block_timeout;
    const bool can_wait = block && std::chrono::steady_clock::now() < *deadline;
    if (!can_wait) {
      ++counters.dropped;
      ++sequence;  // the gap tells subscribers that something was lost
      return;
    }
    impl.DrainSubscriptionNotices();
    internal::PollOne(impl.publisher, ZMQ_POLLOUT, std::chrono::milliseconds(10));
  }
  // the remaining parts of a multipart message are never refused once the first part was accepted
  impl.publisher.send(zmq::buffer(meta), zmq::send_flags::sndmore);
  impl.publisher.send(zmq::const_buffer(data, size), zmq::send_flags::none);
  // never refused (no XPUB_NODROP): a full queue drops the message for its observer alone. Without
  // observers, not even copied into the socket (a 0.9 MB image would cost milliseconds)
  if (impl.observed_prefixes > 0) {
    impl.observers.send(topic_frame, zmq::send_flags::sndmore | zmq::send_flags::dontwait);
    impl.observers.send(zmq::buffer(meta), zmq::send_flags::sndmore);
    impl.observers.send(zmq::const_buffer(data, size), zmq::send_flags::none);
  }
  ++counters.sent;
  ++sequence;
}

void Bus::SetMutedPeers(const std::vector<std::string>& peers) {
  if (impl_->shm_publisher) impl_->shm_publisher->SetMuted(peers);
}

void Bus::AddSubscription(const std::string& topic, bool exact, const TypeInfo* type, RawCallback callback) {
  impl_->subscriptions.push_back(Subscription{topic, exact, type, std::move(callback)});
  if (exact) stats_.topics[topic].subscribed = true;
  impl_->Subscribe(exact ? std::string(topic.c_str(), topic.size() + 1) : topic);
}

void Bus::SubscribeRaw(const std::string& prefix, RawCallback callback) {
  AddSubscription(prefix, /*exact=*/false, nullptr, std::move(callback));
}

void Bus::SubscribeSerialized(const std::string& topic, const TypeInfo& type, RawCallback callback) {
  AddSubscription(topic, /*exact=*/true, &type, std::move(callback));
}

int Bus::Spin(std::chrono::microseconds timeout, int max_batch) {
  auto& impl = *impl_;
  impl.Maintain(/*now=*/false);
  // a ZeroMQ publisher's subscription notices: now and then, as each read is a system call (about 20 us in
  // a VM)
  if (!impl.shm_publisher && ++impl.spins_since_drain >= 64) {
    impl.DrainSubscriptionNotices();
    impl.spins_since_drain = 0;
  }
  int dispatched = impl.DrainQueued(stats_, max_batch);
  if (dispatched > 0) return dispatched;

  // shared memory: a message arrives without a system call, so look for one a little while before sleeping
  // (a wake-up costs ~25 us in a VM), yielding between looks. Spinning pays only while the core has nothing
  // else to run: a yield that took a time slice gave the core to another task, and on an oversubscribed
  // machine spinning processes are CPU-bound to the scheduler and wait for each other's time slices (a
  // lockstep step took 4.6 ms, against 0.15 ms sleeping, with three busy loops on two cores) while a sleeper
  // is woken at once by wake-up preemption. So a contended spin ends in sleep and doubles the number of waits
  // that then sleep without spinning (1, 2, 4 ... 4096); a spin that yielded without losing the core
  // halves it. (Under load, with a 50 us threshold, about half the spins were contended: resetting the
  // back-off on an uncontended one kept spinning, 0.8 s for 2,000 steps against 0.4 s; halving settles at
  // long back-offs.)
  using SteadyClock = std::chrono::steady_clock;
  const auto start = SteadyClock::now();
  if (impl.shm_subscriber && impl.options.spin.count() > 0) {
    if (impl.spinless_waits_left > 0) {
      --impl.spinless_waits_left;
    } else {
      // a time slice: a busy loop held the core 1-10 ms; the recorder's batches, that share it with spinners
      // in every recorded run and for which spinning still pays, hold it under 1 ms
      constexpr auto kContendedYield = std::chrono::milliseconds(1);
      constexpr int kMaxSpinBackoff = 4096;
      const auto spin_end = start + std::min(timeout, impl.options.spin);
      auto now = start;
      bool yielded = false, contended = false;
      while (now < spin_end && !contended) {
        if (impl.shm_subscriber->HasData()) {
          if (yielded) impl.spin_backoff /= 2;  // a message at the first look says nothing about the core
          return impl.DrainQueued(stats_, max_batch);
        }
        std::this_thread::yield();
        yielded = true;
        const auto before = now;
        now = SteadyClock::now();
        contended = now - before > kContendedYield;
      }
      if (contended) {
        impl.spin_backoff = std::clamp(2 * impl.spin_backoff, 1, kMaxSpinBackoff);
        impl.spinless_waits_left = impl.spin_backoff;
        ++stats_.contended_spins;
      } else if (yielded) {
        impl.spin_backoff /= 2;
      }
    }
  }
  auto left =
      std::max(std::chrono::microseconds(0),
               timeout - std::chrono::duration_cast<std::chrono::microseconds>(SteadyClock::now() - start));
  const bool announce = impl.options.poll_period.count() == 0;
  if (!announce) left = std::min(left, impl.options.poll_period);
  auto& fds = impl.poll_fds;
  fds.clear();
  if (!impl.shm_subscriber || impl.shm_subscriber->PrepareSleep(&fds, announce)) {
    if (impl.shm_publisher) fds.push_back({impl.shm_publisher->listen_fd(), POLLIN, 0});
    bool event = true;  // ZeroMQ's poll does not say which descriptor woke it
    if (impl.zmq_peers) {
      auto& items = impl.poll_items;
      items.assign(1, zmq::pollitem_t{impl.subscriber.handle(), 0, ZMQ_POLLIN, 0});
      for (const auto& fd : fds) items.push_back(zmq::pollitem_t{nullptr, fd.fd, ZMQ_POLLIN, 0});
      try {
        zmq::poll(items.data(), items.size(), std::chrono::duration_cast<std::chrono::milliseconds>(left));
      } catch (const zmq::error_t& e) {
        if (e.num() != EINTR) throw;  // a signal: the caller's loop sees the stop request
      }
    } else {
      const timespec wait{static_cast<time_t>(left.count() / 1000000),
                          static_cast<long>(left.count() % 1000000) * 1000};
      event = ppoll(fds.data(), fds.size(), &wait, nullptr) != 0;
    }
    ++stats_.sleeps;
    if (!event) ++stats_.sleeps_timed_out;
    if (impl.shm_subscriber && announce) impl.shm_subscriber->WakeUp();
    // a socket's news (a subscriber, a bigger queue, a hang-up) is taken at once; after a timeout, as
    // often as ever (a polling subscriber wakes hundreds of times a second)
    impl.Maintain(/*now=*/event);
  }
  return impl.DrainQueued(stats_, max_batch);
}

void Bus::BeginHandshake() {
  // phase 1: hellos prove the connection to each peer is up (and with it every subscription made so far
  // was sent, in some order); phase 2 subscribes to confirms on the live connection, after all of them
  impl_->Subscribe(std::string(kHelloTopic) + '\0');
}

void Bus::PublishHello() {
  iapsim_msgs::Hello hello;
  hello.node = impl_->options.node_name;
  Publish(kHelloTopic, hello);
  Publish(kConfirmTopic, hello);
  // handshake traffic is not counted (nor numbered: receivers handle it before they look at sequences)
  for (const char* topic : {kHelloTopic, kConfirmTopic}) {
    stats_.topics.erase(topic);
    impl_->published.erase(topic);
  }
}

bool Bus::HandshakeComplete(const std::vector<std::string>& peers) {
  auto& impl = *impl_;
  for (const auto& peer : peers) {
    if (!impl.hello_from.count(peer)) return false;
  }
  if (!impl.confirm_subscribed) {
    impl.Subscribe(std::string(kConfirmTopic) + '\0');
    impl.confirm_subscribed = true;
  }
  for (const auto& peer : peers) {
    if (!impl.confirm_from.count(peer)) return false;
  }
  return true;
}

void Bus::EndHandshake() {
  impl_->Unsubscribe(std::string(kHelloTopic) + '\0');
  if (impl_->confirm_subscribed) impl_->Unsubscribe(std::string(kConfirmTopic) + '\0');
}

}  // namespace iapsim::bridge
