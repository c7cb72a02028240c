// iapsim bench bus: one-way latency publish -> receive between two processes over ipc:// and tcp:// for a
// state-sized and an image-sized message, and lockstep round trips (tick -> ack) per second.
//
// One-way latency is exact without clock sync: both processes read the same CLOCK_MONOTONIC, the sender puts
// its send time in header.stamp, the receiver subtracts. Messages go one at a time (ping-pong), so the figure
// is the transport's latency, not queueing.

#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/StepAck.h>
#include <iapsim_msgs/Tick.h>
#include <poll.h>
#include <sensor_msgs/CompressedImage.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "bridge/bus.h"
#include "bridge/eigen_msgs.h"
#include "bridge/scenario.h"
#include "bridge/testing/busy_loops.h"
#include "tools/commands.h"

namespace iapsim::tools {
namespace {

using namespace iapsim::bridge;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

struct Endpoints {
  std::string parent, child;
  std::string secret;  // "+curve": the ZeroMQ connections authenticate and encrypt as a run's do
  std::chrono::microseconds spin = BusOptions{}.spin;  // shm: how long a waiting bus looks before it sleeps
};

Endpoints MakeEndpoints(std::string transport, int index) {
  const std::string tag = std::to_string(getpid()) + "-" + std::to_string(index);
  if (const size_t plus = transport.find("+curve"); plus != std::string::npos) {
    Endpoints e = MakeEndpoints(transport.substr(0, plus), index);
    e.secret = std::string(64, 'a');  // any 64 hex digits: the cost is measured, not the secrecy
    return e;
  }
  if (transport == "shm") {
    return {"shm://iapsim-bench-" + tag + "-parent", "shm://iapsim-bench-" + tag + "-child", {}};
  }
  if (transport == "tcp") {
    const int port = 18000 + (getpid() % 2000) * 4 + index * 2;
    return {"tcp://127.0.0.1:" + std::to_string(port), "tcp://127.0.0.1:" + std::to_string(port + 1), {}};
  }
  return {"ipc://@iapsim-bench-" + tag + "-parent", "ipc://@iapsim-bench-" + tag + "-child", {}};
}

Bus MakeBusFor(const std::string& name, const std::string& bind, const std::string& peer,
               const Endpoints& e) {
  BusOptions options;
  options.node_name = name;
  options.bind_endpoint = bind;
  options.peer_endpoints = {peer};
  options.secret = e.secret;
  options.spin = e.spin;
  // a ZeroMQ publisher of a run also serves observers (bridge/bus.h): measured with it, idle as in most runs
  if (bind.rfind("tcp://", 0) == 0) options.observer_endpoint = "tcp://127.0.0.1:*";
  if (bind.rfind("ipc://", 0) == 0) options.observer_endpoint = bind + "-observers";
  return Bus(options);
}

void HandshakeWith(Bus& bus, const std::string& peer) {
  bus.BeginHandshake();
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (!bus.HandshakeComplete({peer})) {
    if (Clock::now() > deadline) throw std::runtime_error("bench: no handshake with " + peer);
    bus.PublishHello();
    bus.Spin(milliseconds(2));
  }
}

// The child side: answers every /ping with a /pong ack and, for latency runs, records one-way latencies.
// Reports "ready" and then the latencies (JSON) through `pipe_fd`.
[[noreturn]] void Child(const Endpoints& e, const std::string& kind, int pipe_fd) {
  int code = 0;
  try {
    Bus bus = MakeBusFor("child", e.child, e.parent, e);
    std::vector<double> latencies_us;
    bool pinged = false, done = false;
    iapsim_msgs::StepAck ack;
    ack.node = "child";
    auto answer = [&](uint64_t step, int64_t sent_ns) {
      if (sent_ns > 0) latencies_us.push_back(static_cast<double>(NowNs() - sent_ns) * 1e-3);
      pinged = true;
      ack.step = step;
      bus.Publish("/pong", ack);
    };
    if (kind == "image") {
      bus.Subscribe<sensor_msgs::CompressedImage>(
          "/ping", [&](const sensor_msgs::CompressedImage& m, const MessageInfo& info) {
            if (m.format == "end") done = true;
            answer(info.sequence, static_cast<int64_t>(m.header.stamp.toNSec()));
          });
    } else if (kind == "state") {
      bus.Subscribe<iapsim_msgs::IapState>("/ping", [&](const iapsim_msgs::IapState& m, const MessageInfo&) {
        if (m.header.frame_id == "end") done = true;
        answer(m.step, static_cast<int64_t>(m.header.stamp.toNSec()));
      });
    } else {
      bus.Subscribe<iapsim_msgs::Tick>("/ping", [&](const iapsim_msgs::Tick& t, const MessageInfo&) {
        if (t.final) done = true;
        answer(t.step, 0);
      });
    }
    HandshakeWith(bus, "parent");
    if (write(pipe_fd, "R", 1) != 1) throw std::runtime_error("bench: pipe");
    // keep greeting until the parent starts: it may still be waiting for our confirm
    while (!pinged) {
      bus.PublishHello();
      bus.Spin(milliseconds(2));
    }
    bus.EndHandshake();
    while (!done) bus.Spin(milliseconds(100));
    const std::string report = nlohmann::json(latencies_us).dump();
    if (write(pipe_fd, report.data(), report.size()) != static_cast<ssize_t>(report.size())) code = 1;
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "bench child: %s\n", ex.what());
    code = 1;
  }
  close(pipe_fd);
  _exit(code);
}

struct PingPongResult {
  std::vector<double> latencies_us;
  double round_trips_per_s = 0.0;
  uint64_t round_trips = 0;
  size_t message_bytes = 0;  // serialized size of the messages sent
};

// Forks a child before any ZeroMQ context exists in this process, then ping-pongs `count` messages.
PingPongResult PingPong(const std::string& transport, const std::string& kind, int index, int count,
                        std::chrono::microseconds spin = BusOptions{}.spin) {
  Endpoints e = MakeEndpoints(transport, index);
  e.spin = spin;
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("bench: pipe");
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    Child(e, kind, fds[1]);
  }
  close(fds[1]);
  PingPongResult result;
  {
    Bus bus = MakeBusFor("parent", e.parent, e.child, e);
    uint64_t acked = 0;
    bool have_ack = false;
    bus.Subscribe<iapsim_msgs::StepAck>("/pong", [&](const iapsim_msgs::StepAck& a, const MessageInfo&) {
      acked = a.step;
      have_ack = true;
    });
    HandshakeWith(bus, "child");
    // keep greeting until the child is through its own handshake too
    pollfd child_ready{fds[0], POLLIN, 0};
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (poll(&child_ready, 1, 0) == 0) {
      if (Clock::now() > deadline) throw std::runtime_error("bench: the child process did not get ready");
      bus.PublishHello();
      bus.Spin(milliseconds(2));
    }
    char ready;
    if (read(fds[0], &ready, 1) != 1) throw std::runtime_error("bench: the child process failed to start");
    bus.EndHandshake();

    iapsim_msgs::IapState state;
    state.bodies.resize(4);  // platform + three sub-aircraft: about 1 KB serialized
    for (auto& b : state.bodies) b.name = "sub-aircraft";
    state.joints.resize(3);
    sensor_msgs::CompressedImage image;
    image.format = "png";
    image.data.assign(640 * 480 * 3, 0x5a);  // an incompressible 640x480 RGB PNG is about this size
    iapsim_msgs::Tick tick;

    result.message_bytes = kind == "image"   ? ros::serialization::serializationLength(image)
                           : kind == "state" ? ros::serialization::serializationLength(state)
                                             : ros::serialization::serializationLength(tick);
    const auto start = Clock::now();
    for (int i = 0; i < count; ++i) {
      const bool last = i + 1 == count;
      have_ack = false;
      if (kind == "image") {
        image.header.stamp = ToRosTime(NowNs());
        if (last) image.format = "end";
        bus.Publish("/ping", image);
      } else if (kind == "state") {
        state.step = static_cast<uint64_t>(i);
        state.header.frame_id = last ? "end" : "W";
        state.header.stamp = ToRosTime(NowNs());
        bus.Publish("/ping", state);
      } else {
        tick.step = static_cast<uint64_t>(i);
        tick.final = last;
        bus.Publish("/ping", tick);
      }
      const auto answer_deadline = Clock::now() + std::chrono::seconds(5);
      while (!(have_ack && acked == static_cast<uint64_t>(i))) {
        if (Clock::now() > answer_deadline)
          throw std::runtime_error("bench: no answer from the child process");
        bus.Spin(milliseconds(1));
      }
    }
    const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
    result.round_trips = static_cast<uint64_t>(count);
    result.round_trips_per_s = count / elapsed_s;
  }
  std::string report;
  char buffer[65536];
  ssize_t n;
  while ((n = read(fds[0], buffer, sizeof(buffer))) > 0) report.append(buffer, static_cast<size_t>(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) throw std::runtime_error("bench: child process failed");
  result.latencies_us = nlohmann::json::parse(report).get<std::vector<double>>();
  if (!result.latencies_us.empty())
    result.latencies_us.erase(result.latencies_us.begin());  // connection warm-up
  return result;
}

// The machine's floor for a blocking cross-process exchange: one byte back and forth over a unix socket
// pair, no library in between. Bus figures are reported against it.
double BareSocketRoundTripsPerSecond(int count) {
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0) throw std::runtime_error("bench: socketpair");
  const pid_t pid = fork();
  if (pid == 0) {
    char c;
    for (int i = 0; i < count; ++i) {
      if (read(sv[1], &c, 1) != 1 || write(sv[1], &c, 1) != 1) _exit(1);
    }
    _exit(0);
  }
  char c = 'x';
  const auto start = Clock::now();
  for (int i = 0; i < count; ++i) {
    if (write(sv[0], &c, 1) != 1 || read(sv[0], &c, 1) != 1) throw std::runtime_error("bench: socket pair");
  }
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  waitpid(pid, nullptr, 0);
  close(sv[0]);
  close(sv[1]);
  return count / elapsed_s;
}

}  // namespace

int BenchBus(nlohmann::json* report) {
  nlohmann::json& out = (*report)["bus"];
  std::printf("iapsim bench bus (two processes on this machine, one message in flight at a time)\n\n");
  std::printf("%-9s %-34s %9s %9s %10s %10s %10s\n", "transport", "message", "bytes", "samples", "p50_us",
              "p99_us", "max_us");
  int index = 0;
  // "+curve": as a run's ZeroMQ connections are (CURVE, keys from the run's secret): the cost of encryption
  for (const std::string transport : {"shm", "ipc", "ipc+curve", "tcp", "tcp+curve"}) {
    for (const std::string kind : {"state", "image"}) {
      const int count = kind == "state" ? 20000 : 1000;
      const PingPongResult r = PingPong(transport, kind, index++, count);
      const size_t bytes = r.message_bytes;
      const double p50 = Percentile(r.latencies_us, 0.50), p99 = Percentile(r.latencies_us, 0.99);
      const double max =
          r.latencies_us.empty() ? 0.0 : *std::max_element(r.latencies_us.begin(), r.latencies_us.end());
      const std::string label =
          kind == "state" ? "iapsim_msgs/IapState (4 bodies)" : "sensor_msgs/CompressedImage";
      std::printf("%-9s %-34s %9zu %9zu %10.1f %10.1f %10.1f\n", transport.c_str(), label.c_str(), bytes,
                  r.latencies_us.size(), p50, p99, max);
      out["latency"][transport][kind] = {
          {"samples", r.latencies_us.size()}, {"p50_us", p50}, {"p99_us", p99}, {"max_us", max}};
    }
  }
  const double bare = BareSocketRoundTripsPerSecond(50000);
  std::printf("\n%-9s %-34s %12s %14s %16s\n", "transport", "round trip between two processes", "round trips",
              "per second", "vs bare socket");
  std::printf("%-9s %-34s %12d %14.0f %16.2f\n", "unix", "1 byte, no library (baseline)", 50000, bare, 1.0);
  out["bare_unix_socket_round_trips_per_s"] = bare;
  for (const std::string transport : {"shm", "ipc", "ipc+curve", "tcp", "tcp+curve"}) {
    const PingPongResult r = PingPong(transport, "tick", index++, 50000);
    std::printf("%-9s %-34s %12llu %14.0f %16.2f\n", transport.c_str(), "lockstep tick -> ack",
                static_cast<unsigned long long>(r.round_trips), r.round_trips_per_s,
                r.round_trips_per_s / bare);
    out["lockstep_round_trips_per_s"][transport] = r.round_trips_per_s;
  }
  // Waiting processes spin (bus.spin_us) only while a yield keeps the core (bridge/bus.cc, Spin): on an
  // oversubscribed machine spinners wait for each other's time slices. Against sleeping at once (spin 0).
  {
    const testing::BusyLoops busy;
    std::printf("\nshm lockstep tick -> ack with %zu busy loops on %u cores (an oversubscribed machine)\n",
                busy.count(), std::thread::hardware_concurrency());
    std::printf("%-34s %12s %14s %16s\n", "waiting bus", "round trips", "per second", "vs no spin");
    double no_spin = 0.0;
    for (const int spin_us : {0, bridge::BusConfig{}.spin_us}) {
      const PingPongResult r = PingPong("shm", "tick", index++, 5000, std::chrono::microseconds(spin_us));
      if (spin_us == 0) no_spin = r.round_trips_per_s;
      const std::string label =
          "spin_us " + std::to_string(spin_us) + (spin_us == 0 ? " (sleeps at once)" : "");
      std::printf("%-34s %12llu %14.0f %16.2f\n", label.c_str(),
                  static_cast<unsigned long long>(r.round_trips), r.round_trips_per_s,
                  r.round_trips_per_s / no_spin);
      out["oversubscribed_lockstep_round_trips_per_s"]["spin_us_" + std::to_string(spin_us)] =
          r.round_trips_per_s;
    }
  }
  std::printf("\ntargets: state p99 on the same host (shm) < 100 us; >= 20000 lockstep round trips/s\n");
  return 0;
}

double Percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<size_t>(fraction * static_cast<double>(values.size() - 1) + 0.5);
  return values[std::min(values.size() - 1, rank)];
}

}  // namespace iapsim::tools
