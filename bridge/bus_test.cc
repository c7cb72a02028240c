#include "bridge/bus.h"

#include <gtest/gtest.h>
#include <iapsim_msgs/IapState.h>
#include <std_msgs/String.h>
#include <unistd.h>

#include <thread>

namespace iapsim::bridge {
namespace {

using std::chrono::milliseconds;

std::string UniqueEndpoint(const std::string& name) {
  const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
  return "ipc://@iapsim-test-" + std::to_string(getpid()) + "-" + test->name() + "-" + name;
}

BusOptions Options(const std::string& name, const std::vector<std::string>& peers) {
  BusOptions options;
  options.node_name = name;
  options.bind_endpoint = UniqueEndpoint(name);
  for (const auto& peer : peers) options.peer_endpoints.push_back(UniqueEndpoint(peer));
  return options;
}

// Runs the start-up handshake between two buses in one thread, as two processes would.
void Handshake(Bus& a, Bus& b) {
  a.BeginHandshake();
  b.BeginHandshake();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!(a.HandshakeComplete({b.node_name()}) && b.HandshakeComplete({a.node_name()}))) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "handshake did not complete";
    a.PublishHello();
    b.PublishHello();
    a.Spin(milliseconds(2));
    b.Spin(milliseconds(2));
  }
  a.EndHandshake();
  b.EndHandshake();
}

TEST(Bus, DeliversEveryMessageAfterHandshakeInOrder) {
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

TEST(Bus, ExactTopicDoesNotMatchLongerTopic) {
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

TEST(Bus, RefusesTypeMismatchWithAClearError) {
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

// Best effort: a subscriber that does not keep up loses messages (and counts them); a fast one loses none.
TEST(Bus, ASlowSubscriberLosesMessagesAloneAndCountsThem) {
  auto options = Options("fast", {"slow", "quick"});
  options.send_hwm = 1000;  // with the slow subscriber's 10-message receive queue: ~1010 fit
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
TEST(Bus, BlockingPublisherCountsWhatItCouldNotSend) {
  auto options = Options("fast", {"slow"});
  options.send_hwm = 10;
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

TEST(Bus, ReportsAnEndpointItCannotBind) {
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

TEST(Bus, TcpLoopbackWithWildcardPort) {
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

}  // namespace
}  // namespace iapsim::bridge
