#include "bridge/bus.h"

#include <iapsim_msgs/Hello.h>
#include <spdlog/spdlog.h>

#include <cstring>
#include <zmq.hpp>

#include "bridge/internal/zmq_poll.h"

namespace iapsim::bridge {
namespace {

constexpr uint8_t kWireVersion = 2;
constexpr char kHelloTopic[] = "/iapsim/hello";
constexpr char kConfirmTopic[] = "/iapsim/hello_confirm";

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
  uint64_t sequence = 0;
  int64_t sent_unix_ns = 0;
  std::string datatype;
  std::string md5;
  std::string publisher;
};

bool ParseMeta(const zmq::message_t& frame, Meta* meta) {
  auto p = static_cast<const uint8_t*>(frame.data());
  const uint8_t* end = p + frame.size();
  if (end - p < 17 || p[0] != kWireVersion) return false;
  std::memcpy(&meta->sequence, p + 1, 8);
  std::memcpy(&meta->sent_unix_ns, p + 9, 8);
  p += 17;
  if (!ReadU16String(p, end, &meta->datatype)) return false;
  if (end - p < 32) return false;
  meta->md5.assign(reinterpret_cast<const char*>(p), 32);
  p += 32;
  return ReadU16String(p, end, &meta->publisher) && p == end;
}

struct Subscription {
  std::string topic;  // exact topic, or prefix
  bool exact;
  const TypeInfo* type;  // nullptr: any type
  Bus::RawCallback callback;
};

}  // namespace

struct Bus::Impl {
  BusOptions options;
  zmq::context_t context{1};
  zmq::socket_t publisher{context, zmq::socket_type::xpub};
  zmq::socket_t subscriber{context, zmq::socket_type::sub};
  std::vector<Subscription> subscriptions;
  std::map<std::string, uint64_t> next_sequence;                 // per topic, at this publisher
  std::map<std::pair<std::string, std::string>, uint64_t> seen;  // (publisher, topic) -> next expected
  std::set<std::string> hello_from, confirm_from;
  bool confirm_subscribed = false;
  int spins_since_drain = 0;
  std::string meta_buffer;

  void Subscribe(const std::string& prefix_bytes) { subscriber.set(zmq::sockopt::subscribe, prefix_bytes); }
  void Unsubscribe(const std::string& prefix_bytes) {
    subscriber.set(zmq::sockopt::unsubscribe, prefix_bytes);
  }

  // subscription notices arrive on the XPUB socket; they are only drained to bound its queue
  void DrainSubscriptionNotices() {
    zmq::message_t notice;
    while (publisher.recv(notice, zmq::recv_flags::dontwait)) {
    }
  }
};

Bus::Bus(const BusOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
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
  try {
    pub.bind(options.bind_endpoint);
  } catch (const zmq::error_t& e) {
    throw BusError("node '" + options.node_name + "': cannot bind publisher to '" + options.bind_endpoint +
                   "': " + e.what());
  }
  for (const auto& endpoint : options.peer_endpoints) {
    try {
      sub.connect(endpoint);
    } catch (const zmq::error_t& e) {
      throw BusError("node '" + options.node_name + "': cannot connect to '" + endpoint + "': " + e.what());
    }
  }
}

Bus::~Bus() = default;

int64_t UnixTimeNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const std::string& Bus::node_name() const { return impl_->options.node_name; }

std::string Bus::bound_endpoint() const { return impl_->publisher.get(zmq::sockopt::last_endpoint); }

void Bus::PublishRaw(const std::string& topic, const TypeInfo& type, const uint8_t* data, size_t size) {
  auto& impl = *impl_;
  auto& counters = stats_.topics[topic];
  uint64_t& sequence = impl.next_sequence[topic];

  std::string& meta = impl.meta_buffer;
  meta.clear();
  meta.push_back(static_cast<char>(kWireVersion));
  meta.append(reinterpret_cast<const char*>(&sequence), 8);
  const int64_t sent_unix_ns = UnixTimeNs();
  meta.append(reinterpret_cast<const char*>(&sent_unix_ns), 8);
  AppendU16String(&meta, type.datatype);
  meta.append(type.md5);
  AppendU16String(&meta, impl.options.node_name);

  // the topic frame ends in '\0' so that subscribing to "/a" does not also match "/ab"
  zmq::const_buffer topic_frame(topic.c_str(), topic.size() + 1);
  const auto deadline = std::chrono::steady_clock::now() + impl.options.block_timeout;
  while (true) {
    const auto sent = impl.publisher.send(topic_frame, zmq::send_flags::sndmore | zmq::send_flags::dontwait);
    if (sent) break;
    const bool can_wait =
        impl.options.drop_policy == DropPolicy::kBlock && std::chrono::steady_clock::now() < deadline;
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
  ++counters.sent;
  ++sequence;
}

void Bus::AddSubscription(const std::string& topic, bool exact, const TypeInfo* type, RawCallback callback) {
  impl_->subscriptions.push_back(Subscription{topic, exact, type, std::move(callback)});
  impl_->Subscribe(exact ? std::string(topic.c_str(), topic.size() + 1) : topic);
}

void Bus::SubscribeRaw(const std::string& prefix, RawCallback callback) {
  AddSubscription(prefix, /*exact=*/false, nullptr, std::move(callback));
}

int Bus::Spin(std::chrono::microseconds timeout, int max_batch) {
  auto& impl = *impl_;
  // syscalls are the cost of a message here (about 20 us each in a VM): subscription notices are drained
  // now and then, and the socket is polled only when nothing is queued already
  if (++impl.spins_since_drain >= 64) {
    impl.DrainSubscriptionNotices();
    impl.spins_since_drain = 0;
  }
  zmq::message_t topic_frame, meta_frame, payload;
  if (!impl.subscriber.recv(topic_frame, zmq::recv_flags::dontwait)) {
    const auto timeout_ms = std::chrono::duration_cast<std::chrono::milliseconds>(timeout);
    if (!internal::PollOne(impl.subscriber, ZMQ_POLLIN, timeout_ms)) return 0;
    if (!impl.subscriber.recv(topic_frame, zmq::recv_flags::dontwait)) return 0;
  }

  int dispatched = 0;
  std::string topic;
  Meta meta;
  bool have_frame = true;
  for (; have_frame && dispatched < max_batch;
       have_frame = dispatched < max_batch && impl.subscriber.recv(topic_frame, zmq::recv_flags::dontwait)) {
    // read the whole multipart message before judging it, so a bad one never desynchronises the stream
    std::vector<zmq::message_t> extra;
    bool complete = topic_frame.more() && impl.subscriber.recv(meta_frame) && meta_frame.more() &&
                    impl.subscriber.recv(payload);
    while (impl.subscriber.get(zmq::sockopt::rcvmore)) {
      zmq::message_t rest;
      (void)impl.subscriber.recv(rest);
      complete = false;
    }
    if (!complete || topic_frame.size() == 0 ||
        static_cast<const char*>(topic_frame.data())[topic_frame.size() - 1] != '\0' ||
        !ParseMeta(meta_frame, &meta)) {
      ++stats_.malformed;
      continue;
    }
    topic.assign(static_cast<const char*>(topic_frame.data()), topic_frame.size() - 1);

    // handshake traffic is handled here and never reaches subscribers
    if (topic == kHelloTopic) {
      impl.hello_from.insert(meta.publisher);
      continue;
    }
    if (topic == kConfirmTopic) {
      impl.confirm_from.insert(meta.publisher);
      continue;
    }

    auto& counters = stats_.topics[topic];
    ++counters.received;
    auto [it, inserted] = impl.seen.try_emplace({meta.publisher, topic}, meta.sequence);
    if (meta.sequence > it->second) counters.lost += meta.sequence - it->second;
    it->second = meta.sequence + 1;

    const MessageInfo info{topic, meta.datatype, meta.md5, meta.publisher, meta.sequence, meta.sent_unix_ns};
    const auto* data = static_cast<const uint8_t*>(payload.data());
    for (const auto& sub : impl.subscriptions) {
      const bool match = sub.exact ? sub.topic == topic : topic.compare(0, sub.topic.size(), sub.topic) == 0;
      if (!match) continue;
      if (sub.type && (sub.type->datatype != meta.datatype || sub.type->md5 != meta.md5)) {
        throw BusError("topic '" + topic + "': node '" + impl.options.node_name + "' expects " +
                       sub.type->datatype + " (md5 " + sub.type->md5 + ") but '" + meta.publisher +
                       "' sends " + meta.datatype + " (md5 " + meta.md5 + ")");
      }
      sub.callback(data, payload.size(), info);
    }
    ++dispatched;
  }
  return dispatched;
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
  stats_.topics.erase(kHelloTopic);
  stats_.topics.erase(kConfirmTopic);
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
  impl_->next_sequence.erase(kHelloTopic);
  impl_->next_sequence.erase(kConfirmTopic);
}

}  // namespace iapsim::bridge
