#include "bridge/bus.h"

#include <gtest/gtest.h>
#include <iapsim_msgs/IapState.h>
#include <std_msgs/Header.h>
#include <std_msgs/String.h>
#include <unistd.h>

#include <algorithm>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <thread>

#include "bridge/control_channel.h"
#include "bridge/internal/shm_transport.h"
#include "bridge/internal/zap_gate.h"
#include "bridge/testing/busy_loops.h"

namespace iapsim::bridge {
namespace {

using std::chrono::milliseconds;

// Every behaviour holds on each same-host transport: shared memory and ZeroMQ over unix sockets.
class BusOn : public ::testing::TestWithParam<std::string> {};

std::string UniqueEndpoint(const std::string& name) {
  const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string test_name = test->name();
  std::replace(test_name.begin(), test_name.end(), '/', '-');
  const std::string tag = "iapsim-test-" + std::to_string(getpid()) + "-" + test_name + "-" + name;
  return test->value_param() && std::string(test->value_param()) == "\"shm\"" ? "shm://" + tag
                                                                              : "ipc://@" + tag;
}

BusOptions Options(const std::string& name, const std::vector<std::string>& peers) {
  BusOptions options;
  options.node_name = name;
  options.bind_endpoint = UniqueEndpoint(name);
  for (const auto& peer : peers) options.peer_endpoints.push_back(UniqueEndpoint(peer));
  return options;
}

// Runs the start-up handshake between buses in one thread, as their processes would.
void Handshake(const std::vector<Bus*>& buses) {
  for (Bus* bus : buses) bus->BeginHandshake();
  auto complete = [&] {
    for (Bus* bus : buses) {
      std::vector<std::string> others;
      for (Bus* other : buses) {
        if (other != bus) others.push_back(other->node_name());
      }
      if (!bus->HandshakeComplete(others)) return false;
    }
    return true;
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!complete()) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "handshake did not complete";
    for (Bus* bus : buses) bus->PublishHello();
    for (Bus* bus : buses) bus->Spin(milliseconds(2));
  }
  for (Bus* bus : buses) bus->EndHandshake();
}

void Handshake(Bus& a, Bus& b) { Handshake({&a, &b}); }

TEST_P(BusOn, DeliversEveryMessageAfterHandshakeInOrder) {
  Bus physics(Options("physics", {"control"}));
  Bus control(Options("control", {"physics"}));
  std::vector<uint64_t> steps;
  control.Subscribe<iapsim_msgs::IapState>("/iap/state",
                                           [&](const iapsim_msgs::IapState& s, const MessageInfo& info) {
                                             EXPECT_EQ(info.publisher, "physics");
                                             EXPECT_EQ(info.sequence, s.step);
                                             steps.push_back(s.step);
                                           });
  Handshake(physics, control);

  // no slow-joiner loss: the very first message after the handshake arrives
  iapsim_msgs::IapState state;
  for (uint64_t k = 0; k < 500; ++k) {
    state.step = k;
    physics.Publish("/iap/state", state);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (steps.size() < 500 && std::chrono::steady_clock::now() < deadline) control.Spin(milliseconds(10));
  ASSERT_EQ(steps.size(), 500u);
  for (uint64_t k = 0; k < 500; ++k) EXPECT_EQ(steps[k], k);
  EXPECT_EQ(physics.stats().topics.at("/iap/state").sent, 500u);
  EXPECT_EQ(control.stats().topics.at("/iap/state").received, 500u);
  EXPECT_EQ(control.stats().topics.at("/iap/state").lost, 0u);
}

TEST_P(BusOn, ExactTopicDoesNotMatchLongerTopic) {
  Bus a(Options("a", {"b"}));
  Bus b(Options("b", {"a"}));
  int exact = 0, prefixed = 0;
  b.Subscribe<std_msgs::String>("/x", [&](const std_msgs::String&, const MessageInfo&) { ++exact; });
  b.SubscribeRaw("/x", [&](const uint8_t*, size_t, const MessageInfo&) { ++prefixed; });
  Handshake(a, b);
  std_msgs::String text;
  a.Publish("/x", text);
  a.Publish("/xy", text);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (prefixed < 2 && std::chrono::steady_clock::now() < deadline) b.Spin(milliseconds(10));
  EXPECT_EQ(exact, 1);
  EXPECT_EQ(prefixed, 2);
}

// the ROS bridge's subscription: one topic's serialised bytes, exactly as published, and its type checked
TEST_P(BusOn, ASerializedSubscriptionGetsThePublishedBytesOfOneTopicAndChecksTheType) {
  Bus a(Options("a", {"b"}));
  Bus b(Options("b", {"a"}));
  std::vector<std::vector<uint8_t>> received;
  b.SubscribeSerialized("/x", TypeInfoOf<std_msgs::String>(),
                        [&](const uint8_t* data, size_t size, const MessageInfo& info) {
                          EXPECT_EQ(info.datatype, "std_msgs/String");
                          received.emplace_back(data, data + size);
                        });
  Handshake(a, b);
  std_msgs::String text;
  text.data = "forwarded as is";
  a.Publish("/x", text);
  a.Publish("/xy", text);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (received.empty() && std::chrono::steady_clock::now() < deadline) b.Spin(milliseconds(10));
  ASSERT_EQ(received.size(), 1u);
  std::vector<uint8_t> expected;
  EncodeInto(text, &expected);
  EXPECT_EQ(received[0], expected);

  std_msgs::Header wrong;
  a.Publish("/x", wrong);
  EXPECT_THROW(
      {
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        while (std::chrono::steady_clock::now() < until) b.Spin(milliseconds(10));
      },
      BusError);
}

TEST_P(BusOn, NumbersEachPublisherAndTopicPairInOrderOfFirstMessage) {
  Bus a(Options("a", {"b"}));
  Bus b(Options("b", {"a"}));
  std::vector<std::pair<std::string, uint32_t>> seen;
  b.SubscribeRaw("/", [&](const uint8_t*, size_t, const MessageInfo& info) {
    seen.emplace_back(info.topic, info.stream);
  });
  Handshake(a, b);
  std_msgs::String text;
  for (const char* topic : {"/x", "/y", "/x", "/z", "/y"}) a.Publish(topic, text);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (seen.size() < 5 && std::chrono::steady_clock::now() < deadline) b.Spin(milliseconds(10));
  const std::vector<std::pair<std::string, uint32_t>> expected = {
      {"/x", 0}, {"/y", 1}, {"/x", 0}, {"/z", 2}, {"/y", 1}};
  EXPECT_EQ(seen, expected);
}

TEST_P(BusOn, RefusesTypeMismatchWithAClearError) {
  Bus a(Options("physics", {"control"}));
  Bus b(Options("control", {"physics"}));
  b.Subscribe<iapsim_msgs::IapState>("/iap/state", [](const iapsim_msgs::IapState&, const MessageInfo&) {});
  Handshake(a, b);
  std_msgs::String wrong;
  a.Publish("/iap/state", wrong);
  try {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (std::chrono::steady_clock::now() < deadline) b.Spin(milliseconds(10));
    FAIL() << "no error for a type mismatch";
  } catch (const BusError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/iap/state"), std::string::npos) << what;
    EXPECT_NE(what.find("iapsim_msgs/IapState"), std::string::npos) << what;
    EXPECT_NE(what.find("std_msgs/String"), std::string::npos) << what;
    EXPECT_NE(what.find("'physics'"), std::string::npos) << what;
  }
}

TEST(MessageSizeLimits, TheLongestKeyThatCoversATopicWins) {
  MessageSizeLimits limits;
  limits.default_bytes = 1000;
  limits.topic_bytes = {{"/iap/", 200}, {"/iap/camera/", 5000}, {"/iap/state", 100}};
  EXPECT_EQ(limits.For("/iap/state"), 100u);
  EXPECT_EQ(limits.For("/iap/state_estimate"), 200u);  // a key without '/' at its end is one topic
  EXPECT_EQ(limits.For("/iap/camera/left"), 5000u);
  EXPECT_EQ(limits.For("/iap/cmd"), 200u);
  EXPECT_EQ(limits.For("/clock"), 1000u);
  EXPECT_EQ(limits.For("/iap"), 1000u);
  EXPECT_EQ(limits.Largest(), 5000u);
}

// A topic's size limit holds at both ends: the publisher refuses a larger message with an error naming the
// topic, and a subscriber with a tighter limit than its peer discards what is over it, counts it and goes
// on with the rest in order.
TEST_P(BusOn, TopicSizeLimitsHoldAtPublisherAndSubscriber) {
  BusOptions publisher_options = Options("pub", {"sub"});
  publisher_options.message_limits.topic_bytes = {{"/small", 64}};
  Bus publisher(publisher_options);
  BusOptions subscriber_options = Options("sub", {"pub"});
  subscriber_options.message_limits.topic_bytes = {{"/text/", 100}};
  Bus subscriber(subscriber_options);
  std::vector<size_t> lengths;
  subscriber.Subscribe<std_msgs::String>(
      "/text/a", [&](const std_msgs::String& m, const MessageInfo&) { lengths.push_back(m.data.size()); });
  Handshake(publisher, subscriber);

  std_msgs::String text;
  text.data.assign(100, 'x');  // 104 bytes serialised
  try {
    publisher.Publish("/small", text);
    FAIL() << "a message over its topic's limit was sent";
  } catch (const BusError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'/small'"), std::string::npos) << what;
    EXPECT_NE(what.find("104 bytes"), std::string::npos) << what;
    EXPECT_NE(what.find("limit of 64 bytes"), std::string::npos) << what;
  }
  for (const size_t length : {10, 96, 97, 200, 20}) {  // 96 + 4 = 100 bytes: at the limit
    text.data.assign(length, 'x');
    publisher.Publish("/text/a", text);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (lengths.size() < 3 && std::chrono::steady_clock::now() < deadline) subscriber.Spin(milliseconds(10));
  EXPECT_EQ(lengths, (std::vector<size_t>{10, 96, 20}));
  const TopicCounters& counters = subscriber.stats().topics.at("/text/a");
  EXPECT_EQ(counters.received, 3u);
  EXPECT_EQ(counters.oversized, 2u);
  EXPECT_EQ(counters.lost, 0u);
  EXPECT_EQ(publisher.stats().topics.at("/text/a").sent, 5u);
}

// A subscriber that takes a few messages at a time while its publisher sends many more: the rest wait,
// whole and in order, while the queue behind them grows (shm: from 64 kB to megabytes) and wraps.
TEST_P(BusOn, APartiallyReadingSubscriberGetsTheRestInOrder) {
  Bus publisher(Options("pub", {"sub"}));
  Bus subscriber(Options("sub", {"pub"}));
  std::vector<std::string> received;
  subscriber.Subscribe<std_msgs::String>(
      "/s", [&](const std_msgs::String& m, const MessageInfo&) { received.push_back(m.data); });
  Handshake(publisher, subscriber);
  const auto payload = [](int i) { return std::to_string(i) + std::string(1000, 'x'); };
  constexpr int kMessages = 3000, kBatch = 3;
  for (int i = 0; i < kMessages; ++i) {
    std_msgs::String text;
    text.data = payload(i);
    publisher.Publish("/s", text);
    if (i % 10 == 9) {
      EXPECT_LE(subscriber.Spin(milliseconds(0), kBatch), kBatch);
    }
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (received.size() < kMessages && std::chrono::steady_clock::now() < deadline) {
    subscriber.Spin(milliseconds(10), kBatch);
  }
  ASSERT_EQ(received.size(), static_cast<size_t>(kMessages));
  for (int i = 0; i < kMessages; ++i) ASSERT_EQ(received[i], payload(i)) << i;
  EXPECT_EQ(publisher.stats().topics.at("/s").dropped, 0u);
  EXPECT_EQ(subscriber.stats().topics.at("/s").lost, 0u);
}

// Best effort: a subscriber that does not keep up loses messages (and counts them); a fast one loses none.
TEST_P(BusOn, ASlowSubscriberLosesMessagesAloneAndCountsThem) {
  auto options = Options("fast", {"slow", "quick"});
  options.send_hwm = 1000;                // with the slow subscriber's 10-message receive queue: ~1010 fit
  options.shm_max_queue_bytes = 1 << 20;  // ~1000 of them
  options.drop_policy = DropPolicy::kDropNewest;
  Bus publisher(options);
  auto slow_options = Options("slow", {"fast"});
  slow_options.receive_hwm = 10;
  Bus slow(slow_options);
  Bus quick(Options("quick", {"fast"}));
  uint64_t slow_received = 0, quick_received = 0;
  slow.SubscribeRaw("/s", [&](const uint8_t*, size_t, const MessageInfo&) { ++slow_received; });
  quick.SubscribeRaw("/s", [&](const uint8_t*, size_t, const MessageInfo&) { ++quick_received; });
  // handshake all three in one thread
  publisher.BeginHandshake();
  slow.BeginHandshake();
  quick.BeginHandshake();
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!(slow.HandshakeComplete({"fast"}) && quick.HandshakeComplete({"fast"}))) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline);
    publisher.PublishHello();
    slow.Spin(milliseconds(2));
    quick.Spin(milliseconds(2));
  }
  std_msgs::String text;
  text.data.assign(1000, 'x');
  // the quick subscriber takes each message before the next is sent; the slow one does not read at all
  for (uint64_t i = 0; i < 5000; ++i) {
    publisher.Publish("/s", text);
    deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (quick_received <= i && std::chrono::steady_clock::now() < deadline) quick.Spin(milliseconds(10));
  }
  deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
  while (std::chrono::steady_clock::now() < deadline) slow.Spin(milliseconds(10));
  // one more once there is room again: every miss before it shows as a gap
  publisher.Publish("/s", text);
  deadline = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (std::chrono::steady_clock::now() < deadline) {
    slow.Spin(milliseconds(10));
    quick.Spin(milliseconds(0));
  }
  EXPECT_EQ(publisher.stats().topics.at("/s").sent, 5001u);
  EXPECT_EQ(quick_received, 5001u);
  EXPECT_EQ(quick.stats().topics.at("/s").lost, 0u);
  EXPECT_LT(slow_received, 5001u);
  EXPECT_EQ(slow_received + slow.stats().topics.at("/s").lost, 5001u);
}

// Lossless: with kBlock a full queue holds the publisher back; what cannot be sent in time is counted.
TEST_P(BusOn, BlockingPublisherCountsWhatItCouldNotSend) {
  auto options = Options("fast", {"slow"});
  options.send_hwm = 10;
  options.shm_max_queue_bytes = 1 << 20;  // ~10 of them
  options.drop_policy = DropPolicy::kBlock;
  options.block_timeout = milliseconds(20);
  Bus publisher(options);
  auto slow_options = Options("slow", {"fast"});
  slow_options.receive_hwm = 10;
  Bus slow(slow_options);
  uint64_t received = 0;
  slow.SubscribeRaw("/s", [&](const uint8_t*, size_t, const MessageInfo&) { ++received; });
  Handshake(publisher, slow);
  // 100 kB messages: 10 MB in all, far more than the queues and the kernel's socket buffers hold, so some
  // must time out whatever the machine's load (1 kB ones all fit in the socket buffers on an idle one)
  std_msgs::String text;
  text.data.assign(100000, 'x');
  for (int i = 0; i < 100; ++i) publisher.Publish("/s", text);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (std::chrono::steady_clock::now() < deadline) slow.Spin(milliseconds(10));
  const auto& counters = publisher.stats().topics.at("/s");
  EXPECT_GT(counters.dropped, 0u);
  EXPECT_EQ(counters.sent + counters.dropped, 100u);
  EXPECT_EQ(received, counters.sent);
}

INSTANTIATE_TEST_SUITE_P(, BusOn, ::testing::Values("shm", "ipc"),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

TEST(BusEndpoints, ReportsAnEndpointItCannotBind) {
  BusOptions options;
  options.node_name = "bad";
  options.bind_endpoint = "tcp://not-an-address:xyz";
  try {
    Bus bus(options);
    FAIL() << "bound an invalid endpoint";
  } catch (const BusError& e) {
    EXPECT_NE(std::string(e.what()).find("'bad'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("tcp://not-an-address:xyz"), std::string::npos);
  }
}

// ZeroMQ: a blocking publisher waits for every subscriber of its socket, so observers connect to a socket of
// their own that never waits. One that reads nothing while 5,000 messages go out (its queues hold ~20)
// holds nothing up: the run's subscriber gets every message and the publisher drops none.
TEST(BusObservers, AnObserverThatStopsReadingNeverHoldsABlockingZeroMqPublisher) {
  const std::string tag = "iapsim-test-" + std::to_string(getpid()) + "-observers-";
  BusOptions options;
  options.node_name = "physics";
  options.bind_endpoint = "ipc://@" + tag + "physics";
  options.observer_endpoint = "ipc://@" + tag + "physics-observers";
  options.peer_endpoints = {"ipc://@" + tag + "control"};
  options.send_hwm = 10;
  options.block_timeout = milliseconds(200);
  options.secret = std::string(64, 'a');
  Bus publisher(options);
  BusOptions member_options;
  member_options.node_name = "control";
  member_options.bind_endpoint = "ipc://@" + tag + "control";
  member_options.peer_endpoints = {options.bind_endpoint};
  member_options.secret = options.secret;
  Bus member(member_options);
  BusOptions observer_options = member_options;
  observer_options.node_name = "echo";
  observer_options.bind_endpoint = "ipc://@" + tag + "echo";
  observer_options.peer_endpoints = {options.observer_endpoint};
  observer_options.receive_hwm = 10;
  observer_options.observer = true;
  Bus observer(observer_options);
  uint64_t member_received = 0, observer_received = 0;
  member.SubscribeRaw("/s", [&](const uint8_t*, size_t, const MessageInfo&) { ++member_received; });
  observer.SubscribeRaw("/s", [&](const uint8_t*, size_t, const MessageInfo&) { ++observer_received; });
  Handshake(publisher, member);
  std_msgs::String text;
  text.data.assign(1000, 'x');
  // the observer's subscription is live once it has a message
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (observer_received == 0 && std::chrono::steady_clock::now() < deadline) {
    publisher.Publish("/s", text);
    publisher.Spin(milliseconds(0));
    member.Spin(milliseconds(0));
    observer.Spin(milliseconds(10));
  }
  ASSERT_GT(observer_received, 0u);
  const uint64_t before = member_received;
  for (uint64_t i = 0; i < 5000; ++i) {
    publisher.Publish("/s", text);
    while (member.Spin(milliseconds(0)) > 0) {
    }
  }
  deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (member_received < before + 5000 && std::chrono::steady_clock::now() < deadline) {
    member.Spin(milliseconds(10));
  }
  EXPECT_EQ(publisher.stats().topics.at("/s").dropped, 0u);
  EXPECT_EQ(member.stats().topics.at("/s").lost, 0u);
  EXPECT_GE(member_received, before + 5000);
  // the observer, reading again, finds what its queues held and counts the rest as lost
  const uint64_t observed_before = observer_received;
  deadline = std::chrono::steady_clock::now() + milliseconds(300);
  while (std::chrono::steady_clock::now() < deadline) observer.Spin(milliseconds(10));
  EXPECT_LT(observer_received - observed_before, 1000u);
  // the next message it gets shows the gap
  const uint64_t drained = observer_received;
  publisher.Publish("/s", text);
  deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (observer_received == drained && std::chrono::steady_clock::now() < deadline) {
    observer.Spin(milliseconds(10));
  }
  EXPECT_GT(observer.stats().topics.at("/s").lost, 4000u);
}

TEST(BusEndpoints, TcpLoopbackWithWildcardPort) {
  BusOptions a_options;
  a_options.node_name = "a";
  a_options.bind_endpoint = "tcp://127.0.0.1:*";
  Bus a(a_options);
  BusOptions b_options;
  b_options.node_name = "b";
  b_options.bind_endpoint = "tcp://127.0.0.1:*";
  b_options.peer_endpoints = {a.bound_endpoint()};
  Bus b(b_options);
  int received = 0;
  b.Subscribe<std_msgs::String>("/t", [&](const std_msgs::String& s, const MessageInfo&) {
    EXPECT_EQ(s.data, "over tcp");
    ++received;
  });
  b.BeginHandshake();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!b.HandshakeComplete({"a"}) && std::chrono::steady_clock::now() < deadline) {
    a.PublishHello();
    b.Spin(milliseconds(5));
  }
  ASSERT_TRUE(b.HandshakeComplete({"a"}));
  b.EndHandshake();
  std_msgs::String s;
  s.data = "over tcp";
  a.Publish("/t", s);
  while (received == 0 && std::chrono::steady_clock::now() < deadline) b.Spin(milliseconds(10));
  EXPECT_EQ(received, 1);
}

// Shared memory: a queue too small for a message grows; one larger than the largest queue is an error that
// names the topic.
TEST(BusShm, GrowsTheQueueForALargeMessageAndRefusesOneTooLarge) {
  auto options = Options("camera", {"recorder"});
  options.bind_endpoint = "shm://iapsim-test-" + std::to_string(getpid()) + "-grow-camera";
  options.shm_max_queue_bytes = 4 << 20;
  Bus camera(options);
  auto recorder_options = Options("recorder", {});
  recorder_options.peer_endpoints = {options.bind_endpoint};
  Bus recorder(recorder_options);
  std::vector<std::string> received;
  recorder.Subscribe<std_msgs::String>(
      "/image", [&](const std_msgs::String& m, const MessageInfo&) { received.push_back(m.data); });
  Handshake(camera, recorder);
  std_msgs::String image;
  const std::vector<size_t> sizes = {1000, 1500000, 10};  // the initial queue is 64 KiB
  for (size_t i = 0; i < sizes.size(); ++i) {
    image.data.assign(sizes[i], static_cast<char>('a' + i));
    camera.Publish("/image", image);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (received.size() < 3 && std::chrono::steady_clock::now() < deadline) recorder.Spin(milliseconds(10));
  ASSERT_EQ(received.size(), 3u);
  for (size_t i = 0; i < sizes.size(); ++i) {
    EXPECT_EQ(received[i].size(), sizes[i]);
    EXPECT_TRUE(received[i] == std::string(sizes[i], static_cast<char>('a' + i))) << "message " << i;
  }
  image.data.assign(3000000, 'x');
  try {
    camera.Publish("/image", image);
    FAIL() << "a message larger than the largest queue was accepted";
  } catch (const BusError& e) {
    EXPECT_NE(std::string(e.what()).find("/image"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("4 MiB"), std::string::npos) << e.what();
  }
}

// Shared memory: a muted peer gets nothing, others everything; once unmuted, the gap it was muted over is
// not counted as lost (real loss still is: ASlowSubscriberLosesMessagesAloneAndCountsThem).
TEST(BusShm, AMutedPeerMissesMessagesWithoutCountingThemLost) {
  auto options = Options("clock", {"due", "muted"});
  options.bind_endpoint = "shm://iapsim-test-" + std::to_string(getpid()) + "-mute-clock";
  Bus clock(options);
  std::map<std::string, std::unique_ptr<Bus>> peers;
  std::map<std::string, std::vector<uint64_t>> steps;
  for (const std::string name : {"due", "muted"}) {
    auto peer_options = Options(name, {name == "due" ? "muted" : "due"});
    peer_options.peer_endpoints.push_back(options.bind_endpoint);
    peers[name] = std::make_unique<Bus>(peer_options);
    peers[name]->Subscribe<iapsim_msgs::IapState>(
        "/iap/state", [&steps, name](const iapsim_msgs::IapState& s, const MessageInfo&) {
          steps[name].push_back(s.step);
        });
  }
  Handshake({&clock, peers["due"].get(), peers["muted"].get()});
  auto spin_until = [&](const std::string& name, size_t count) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (steps[name].size() < count && std::chrono::steady_clock::now() < deadline) {
      peers[name]->Spin(milliseconds(10));
    }
  };
  iapsim_msgs::IapState state;
  for (uint64_t k = 0; k < 10; ++k) {
    clock.SetMutedPeers(k % 5 == 0 ? std::vector<std::string>{} : std::vector<std::string>{"muted"});
    state.step = k;
    clock.Publish("/iap/state", state);
  }
  spin_until("due", 10);
  spin_until("muted", 2);
  EXPECT_EQ(steps["due"].size(), 10u);
  EXPECT_EQ(steps["muted"], (std::vector<uint64_t>{0, 5}));
  EXPECT_EQ(peers["muted"]->stats().topics.at("/iap/state").lost, 0u);
  EXPECT_EQ(peers["muted"]->stats().topics.at("/iap/state").received, 2u);
  EXPECT_EQ(peers["due"]->stats().topics.at("/iap/state").lost, 0u);
}

// A publisher and a subscriber to its "/t" over shared memory, the subscriber through its handshake (the
// publisher needs none: it serves whoever connects).
struct ShmPair {
  std::unique_ptr<Bus> publisher, subscriber;
};
ShmPair ConnectShm(const std::string& tag, std::chrono::microseconds subscriber_spin,
                   Bus::RawCallback on_message) {
  ShmPair pair;
  auto publisher_options = Options("pub", {});
  publisher_options.bind_endpoint = "shm://iapsim-test-" + std::to_string(getpid()) + "-" + tag + "-pub";
  pair.publisher = std::make_unique<Bus>(publisher_options);
  auto subscriber_options = Options("sub", {});
  subscriber_options.peer_endpoints = {publisher_options.bind_endpoint};
  subscriber_options.spin = subscriber_spin;
  pair.subscriber = std::make_unique<Bus>(subscriber_options);
  pair.subscriber->SubscribeRaw("/t", std::move(on_message));
  pair.subscriber->BeginHandshake();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!pair.subscriber->HandshakeComplete({"pub"})) {
    if (std::chrono::steady_clock::now() > deadline) throw std::runtime_error("handshake did not complete");
    pair.publisher->PublishHello();
    pair.subscriber->Spin(milliseconds(2));
  }
  pair.subscriber->EndHandshake();
  return pair;
}

// A subscriber asleep in Spin is woken by the publisher, not by its timeout.
TEST(BusShm, WakesASleepingSubscriber) {
  int received = 0;
  ShmPair pair = ConnectShm("wake", std::chrono::microseconds(0),
                            [&](const uint8_t*, size_t, const MessageInfo&) { ++received; });
  Bus& publisher = *pair.publisher;
  Bus& subscriber = *pair.subscriber;
  const BusStats before = subscriber.stats();  // the handshake's short sleeps ran out
  for (int i = 0; i < 20; ++i) {
    std::thread later([&] {
      std::this_thread::sleep_for(milliseconds(5));
      std_msgs::String s;
      publisher.Publish("/t", s);
    });
    // one sleep, ended by the message: a subscriber that missed its wake-up would sleep the 10 s out
    subscriber.Spin(std::chrono::seconds(10));
    later.join();
    ASSERT_EQ(received, i + 1);
    ASSERT_EQ(subscriber.stats().sleeps_timed_out, before.sleeps_timed_out)
        << "woken by the timeout, not by the message";
  }
  EXPECT_GT(subscriber.stats().sleeps,
            before.sleeps);  // a message sent before it slept is taken without sleeping
}

// On an oversubscribed machine a spinning subscriber's yields give its core away for a time slice: it then
// sleeps at once for a growing number of waits instead of spinning (without the back-off every wait's spin
// would be cut short).
TEST(BusShm, ASubscriberWhoseSpinLosesTheCoreSleepsInstead) {
  ShmPair pair = ConnectShm("contended", std::chrono::microseconds(200),
                            [](const uint8_t*, size_t, const MessageInfo&) {});
  Bus& subscriber = *pair.subscriber;
  const BusStats before = subscriber.stats();
  constexpr int kWaits = 60;
  {
    const testing::BusyLoops busy;
    for (int i = 0; i < kWaits; ++i) subscriber.Spin(milliseconds(2));  // nothing comes: spin, then sleep
  }
  const uint64_t contended = subscriber.stats().contended_spins - before.contended_spins;
  EXPECT_GE(contended, 1u);
  EXPECT_LE(contended, kWaits / 3) << "spun on after its spins had lost the core";
  EXPECT_EQ(subscriber.stats().sleeps - before.sleeps, static_cast<uint64_t>(kWaits));
}

// Processes come and go: a subscriber that starts after its publisher gets its messages, and it reconnects
// to a publisher that restarted.
TEST(BusShm, ASubscriberJoinsLateAndReconnectsToARestartedPublisher) {
  const std::string endpoint = "shm://iapsim-test-" + std::to_string(getpid()) + "-restart-pub";
  auto publisher_options = Options("pub", {});
  publisher_options.bind_endpoint = endpoint;
  auto subscriber_options = Options("sub", {});
  subscriber_options.peer_endpoints = {endpoint};
  std::vector<std::string> received;
  auto publish_until_received = [&](Bus& publisher, Bus& subscriber, const std::string& text) {
    std_msgs::String s;
    s.data = text;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while ((received.empty() || received.back() != text) && std::chrono::steady_clock::now() < deadline) {
      publisher.Publish("/t", s);
      subscriber.Spin(milliseconds(5));
    }
    ASSERT_FALSE(received.empty());
    EXPECT_EQ(received.back(), text);
  };
  auto publisher = std::make_unique<Bus>(publisher_options);
  std_msgs::String early;
  publisher->Publish("/t", early);  // nobody listens yet
  Bus subscriber(subscriber_options);
  subscriber.Subscribe<std_msgs::String>(
      "/t", [&](const std_msgs::String& m, const MessageInfo&) { received.push_back(m.data); });
  publish_until_received(*publisher, subscriber, "first");
  publisher.reset();
  subscriber.Spin(milliseconds(20));  // sees the hang-up
  publisher = std::make_unique<Bus>(publisher_options);
  publish_until_received(*publisher, subscriber, "after restart");
}

}  // namespace

namespace internal {
namespace {

// The queue keeps records whole and in order across many laps of its memory, and hands over to a successor.
TEST(ShmQueue, KeepsRecordsInOrderAcrossWrapAroundAndMoves) {
  auto writer = ShmQueue::Create(4096);
  auto reader = ShmQueue::Open(dup(writer->fd()));
  std::mt19937 random(7);
  std::uniform_int_distribution<size_t> size(0, writer->MaxRecordBytes());
  std::deque<std::string> sent;
  uint64_t received = 0;
  auto read_all = [&] {
    const uint8_t* data;
    size_t n;
    while (reader->Peek(&data, &n) == ShmQueue::Next::kRecord) {
      ASSERT_FALSE(sent.empty());
      ASSERT_EQ(std::string(reinterpret_cast<const char*>(data), n), sent.front()) << "record " << received;
      sent.pop_front();
      reader->Pop();
      ++received;
    }
  };
  for (int i = 0; i < 2000; ++i) {
    std::string record(size(random), static_cast<char>('a' + i % 26));
    const ByteSpan parts[] = {{record.data(), record.size() / 2},
                              {record.data() + record.size() / 2, record.size() - record.size() / 2}};
    if (!writer->TryWrite(parts, 2)) {
      read_all();
      ASSERT_TRUE(writer->TryWrite(parts, 2)) << "an empty queue refused a record it can take";
    }
    sent.push_back(record);
  }
  read_all();
  EXPECT_EQ(received, 2000u);
  EXPECT_FALSE(reader->HasData());

  const std::string big(writer->MaxRecordBytes() + 1, 'x');
  const ByteSpan too_big{big.data(), big.size()};
  EXPECT_FALSE(writer->TryWrite(&too_big, 1));
  writer->WriteMoved();
  const uint8_t* data;
  size_t n;
  EXPECT_EQ(reader->Peek(&data, &n), ShmQueue::Next::kMoved);
}

// A ZapGate counts the failed handshakes on the sockets it watches until it stops watching them (which an
// owner does before they close: bridge/internal/zap_gate.h), and still refuses peers after that.
TEST(ZapGate, CountsFailedHandshakesUntilItStopsWatching) {
  zmq::context_t context(1);
  int checked = 0;
  ZapGate gate(context, [&checked](const ZapRequest&) {
    ++checked;
    return std::string("nobody gets in");
  });
  zmq::socket_t server(context, zmq::socket_type::router);
  server.set(zmq::sockopt::linger, 0);
  server.set(zmq::sockopt::plain_server, 1);
  server.set(zmq::sockopt::zap_domain, "test");
  gate.Watch(server);
  const std::string endpoint = "ipc://@iapsim-zap-gate-test-" + std::to_string(getpid());
  server.bind(endpoint);
  // a PLAIN peer tries for `duration` (or until `until` holds) while the gate serves
  const auto attempt = [&](std::chrono::milliseconds duration, const std::function<bool()>& until) {
    zmq::context_t client_context(1);
    zmq::socket_t client(client_context, zmq::socket_type::dealer);
    client.set(zmq::sockopt::linger, 0);
    client.set(zmq::sockopt::plain_username, "someone");
    client.set(zmq::sockopt::plain_password, "anything");
    client.connect(endpoint);
    const auto end = std::chrono::steady_clock::now() + duration;
    while (std::chrono::steady_clock::now() < end && !until()) {
      gate.Serve();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  };
  attempt(std::chrono::milliseconds(5000), [&gate] { return gate.refused() > 0; });
  ASSERT_GT(gate.refused(), 0u);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  gate.Serve();  // the events of the last retries
  const uint64_t counted = gate.refused();
  const int checks_before = checked;
  gate.StopWatching();
  attempt(std::chrono::milliseconds(300), [] { return false; });
  EXPECT_GT(checked, checks_before);  // still checked and refused
  EXPECT_EQ(gate.refused(), counted);
}

// A process the launcher refuses (another run's secret) knows it, and does not wait the linger meant for a
// final report at close: its messages never leave. One it accepts is not refused.
TEST(ControlClient, ARefusedClientKnowsItAndDoesNotLingerAtClose) {
  const std::string endpoint = "ipc://@iapsim-control-refusal-test-" + std::to_string(getpid());
  ControlServer server(endpoint, "the run's secret", {"physics"});
  ControlClient accepted(endpoint, "physics", "the run's secret");
  auto refused = std::make_unique<ControlClient>(endpoint, "physics", "another run's secret");
  accepted.Send("hello");
  refused->Send("done");
  bool heard = false;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while ((!heard || !refused->Refused()) && std::chrono::steady_clock::now() < give_up) {
    if (const auto message = server.Receive(milliseconds(10))) heard = heard || message->kind == "hello";
  }
  EXPECT_TRUE(heard);
  ASSERT_TRUE(refused->Refused());
  EXPECT_FALSE(accepted.Refused());
  EXPECT_GE(server.refused(), 1u);
  const auto start = std::chrono::steady_clock::now();
  refused.reset();  // "done" is still queued: a client that lingered would wait its 1000 ms here
  EXPECT_LT(std::chrono::steady_clock::now() - start, milliseconds(900));
}

}  // namespace
}  // namespace internal
}  // namespace iapsim::bridge
