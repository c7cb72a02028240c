// iapsim bench ros: the ROS bridge's round trip (issue 21's target: bus -> ROS -> external node -> ROS -> bus
// p99 < 2 ms in realtime, 200 Hz odometry and setpoints for 60 s, nothing lost), with the example's external
// roscpp node (ros_square_node) answering every odometry message; and the same flight in lockstep, where the
// bridge waits for each answer, as a real-time factor.

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "bridge/launcher.h"
#include "tools/batch.h"
#include "tools/commands.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
constexpr char kScenario[] = "configs/scenarios/three_star_ros_square.yaml";

struct RosFlight {
  std::string error;  // empty: measured
  nlohmann::json metrics;
};

// One run of the example with the square node started once the run's private master is up.
RosFlight Fly(const std::string& mode, double duration_s, const fs::path& out) {
  bridge::LaunchOptions options;
  options.scenario_path = kScenario;
  options.overrides = {"mode=" + mode, "duration_s=" + std::to_string(duration_s)};
  options.out_dir = out.string();
  options.bin_dir = bridge::ExecutableDir();
  bridge::LaunchResult result;
  std::thread run([&] { result = bridge::Launch(options); });
  const fs::path uri_file = out / "ros" / "master_uri";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(uri_file) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::string uri;
  std::ifstream(uri_file) >> uri;
  CommandResult node;
  if (!uri.empty()) {
    node = RunCapturing({"env", "ROS_MASTER_URI=" + uri, "ROS_IP=127.0.0.1",
                         "ROS_HOME=" + (out / "ros").string(), bridge::ExecutableDir() + "/ros_square_node",
                         "odom:=/iap/odom", "setpoint:=/iap/setpoint", "_idle_exit_s:=2"});
  }
  run.join();
  RosFlight flight;
  if (uri.empty()) {
    flight.error = "no " + uri_file.string() + " within 60 s";
  } else if (result.exit_code != 0) {
    flight.error = "the " + mode + " run exited " + std::to_string(result.exit_code) + ": " + result.message;
  } else if (node.exit_code != 0) {
    flight.error = "ros_square_node exited " + std::to_string(node.exit_code) + ": " + node.output;
  } else {
    flight.metrics = nlohmann::json::parse(std::ifstream(result.run_dir + "/metrics.json"));
  }
  fs::remove_all(out);
  return flight;
}

}  // namespace

int BenchRos(nlohmann::json* report) {
  const fs::path dir = fs::temp_directory_path() / ("iapsim-bench-ros-" + std::to_string(getpid()));
  nlohmann::json& out = (*report)["ros"];
  out["scenario"] = kScenario;
  std::printf("iapsim bench ros: %s, 60 s, ros_square_node answering every 200 Hz odometry message\n\n",
              kScenario);
  std::printf("  %-9s %11s %9s %10s %12s %8s %8s %8s %8s\n", "mode", "x real time", "answered", "unanswered",
              "before first", "lost", "p50 ms", "p99 ms", "max ms");
  int status = 0;
  double realtime_p99_ms = -1.0;
  uint64_t realtime_lost = 0;
  for (const std::string mode : {"realtime", "lockstep"}) {
    const RosFlight flight = Fly(mode, 60.0, dir / mode);
    if (!flight.error.empty()) {
      std::fprintf(stderr, "bench ros: %s\n", flight.error.c_str());
      status = 1;
      continue;
    }
    const nlohmann::json& processes = flight.metrics["processes"];
    const nlohmann::json& trips = processes["ros"]["process"]["to_ros"]["/iap/odom"]["round_trip"];
    // a setpoint lost between the bridge and the controller, or an odometry message whose answer never came
    const auto forwarded =
        processes["ros"]["process"]["from_ros"]["/iap/setpoint"]["forwarded"].get<uint64_t>();
    const auto received =
        processes["control"]["bus"]["topics"]["/three_star/ros_setpoint"]["received"].get<uint64_t>();
    const uint64_t lost = forwarded - received + trips["unanswered"].get<uint64_t>();
    const double rtf = flight.metrics["real_time_factor"].get<double>();
    std::printf("  %-9s %11.2f %9llu %10llu %12llu %8llu %8.2f %8.2f %8.2f\n", mode.c_str(), rtf,
                static_cast<unsigned long long>(trips["answered"].get<uint64_t>()),
                static_cast<unsigned long long>(trips["unanswered"].get<uint64_t>()),
                static_cast<unsigned long long>(trips["before_first_answer"].get<uint64_t>()),
                static_cast<unsigned long long>(lost), trips.value("p50_ms", 0.0), trips.value("p99_ms", 0.0),
                trips.value("max_ms", 0.0));
    out[mode] = {{"real_time_factor", rtf}, {"round_trip", trips}, {"setpoints_lost", lost}};
    if (mode == "realtime") {
      realtime_p99_ms = trips.value("p99_ms", -1.0);
      realtime_lost = lost;
    }
  }
  fs::remove_all(dir);
  const bool met = realtime_p99_ms >= 0.0 && realtime_p99_ms < 2.0 && realtime_lost == 0;
  std::printf(
      "\n  (before first: odometry forwarded before the node's first answer, while it started; lockstep's "
      "max\n"
      "  is that wait)\n"
      "  target: realtime round trip p99 < 2 ms with nothing lost: %.2f ms, %llu lost, %s\n",
      realtime_p99_ms, static_cast<unsigned long long>(realtime_lost), met ? "met" : "NOT met");
  return status;
}

}  // namespace iapsim::tools
