// iapsim bench launch: the launcher's wall-clock behaviour, which the tests only bound by contract (issue
// 24): how long a run takes to end after a participant dies (SIGKILL) or after the user stops it (SIGINT, as
// Ctrl-C), and how closely realtime mode follows the wall clock (the real-time factor it reached, the steps
// its clock finished after their slot, the acknowledgements that came late).

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "bridge/launcher.h"
#include "bridge/scenario.h"
#include "tools/commands.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The pid of the process that runs `node` of the run in `run_dir` (its command line ends with "--node NODE
// --run-dir RUN_DIR"), or -1.
pid_t FindNode(const std::string& node, const std::string& run_dir) {
  std::string tail = "--node";
  for (const std::string& part : {node, std::string("--run-dir"), run_dir}) (tail += '\0') += part;
  tail += '\0';
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(entry.path() / "cmdline", std::ios::binary);
    const std::string cmdline((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (cmdline.size() >= tail.size() &&
        cmdline.compare(cmdline.size() - tail.size(), tail.size(), tail) == 0) {
      return static_cast<pid_t>(std::stol(name));
    }
  }
  return -1;
}

bool ClockStarted(const fs::path& run_dir) {
  std::ifstream log(run_dir / "log.txt");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  return text.find("clock started") != std::string::npos;
}

struct StopSample {
  double latency_s = -1.0;  // from the kill or the stop request to Launch's return; < 0: not measured
  std::string why;          // when not measured
};

// Starts the scenario (60 s more than it will run), waits until its clock runs and `settle_s` more, then
// kills `node` (or, when `node` is empty, sends this process SIGINT, which the launcher takes as Ctrl-C) and
// times the run's end.
StopSample StopOnce(const std::string& scenario, const std::string& node, const fs::path& out_dir) {
  bridge::LaunchOptions options;
  options.scenario_path = scenario;
  options.overrides = {"mode=lockstep", "duration_s=60"};
  options.out_dir = out_dir.string();
  options.bin_dir = bridge::ExecutableDir();
  Clock::time_point ended;
  bridge::LaunchResult result;
  std::thread run([&] {
    result = bridge::Launch(options);
    ended = Clock::now();
  });
  StopSample sample;
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (!ClockStarted(out_dir) && Clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  Clock::time_point stopped = Clock::now();
  if (node.empty()) {
    kill(getpid(), SIGINT);
  } else if (const pid_t pid = FindNode(node, out_dir.string()); pid > 0) {
    stopped = Clock::now();
    kill(pid, SIGKILL);
  } else {
    sample.why = "no process '" + node + "' found running";
  }
  run.join();
  const int expected = node.empty() ? 130 : 1;
  if (sample.why.empty() && result.exit_code != expected) {
    sample.why = "the run exited " + std::to_string(result.exit_code) + " (expected " +
                 std::to_string(expected) + "): " + result.message;
  }
  if (sample.why.empty()) sample.latency_s = std::chrono::duration<double>(ended - stopped).count();
  fs::remove_all(out_dir);
  return sample;
}

}  // namespace

int BenchLaunch(const std::string& scenario_path, int repeats, nlohmann::json* report) {
  const bridge::Scenario scenario = bridge::LoadScenario(scenario_path);
  // the participant that dies: the first process that neither owns the clock nor records
  std::string victim;
  for (const auto& p : scenario.processes) {
    if (p.role == bridge::ProcessRole::kParticipant) {
      victim = p.name;
      break;
    }
  }
  if (victim.empty()) {
    std::fprintf(stderr, "bench launch: %s has no participant to kill\n", scenario_path.c_str());
    return 1;
  }
  const fs::path dir = fs::temp_directory_path() / ("iapsim-bench-launch-" + std::to_string(getpid()));
  nlohmann::json& out = (*report)["launch"];
  out["scenario"] = scenario_path;
  std::printf("iapsim bench launch: %s, %d runs of each\n\n", scenario_path.c_str(), repeats);
  std::printf("  %-44s %10s %10s %10s\n", "stop: from the event to the launcher's return", "p50 ms", "max ms",
              "runs");
  int status = 0;
  double worst_s = 0.0, worst_pacing = 0.0;
  for (const std::string& node : {victim, std::string()}) {
    std::vector<double> latencies_s;
    for (int i = 0; i < repeats; ++i) {
      const StopSample sample = StopOnce(scenario_path, node, dir / std::to_string(i));
      if (sample.latency_s < 0.0) {
        std::fprintf(stderr, "bench launch: %s\n", sample.why.c_str());
        status = 1;
        continue;
      }
      latencies_s.push_back(sample.latency_s);
    }
    const std::string label = node.empty() ? "the user stops it (SIGINT)" : "'" + node + "' killed (SIGKILL)";
    const double p50 = Percentile(latencies_s, 0.5), max = Percentile(latencies_s, 1.0);
    worst_s = std::max(worst_s, max);
    std::printf("  %-44s %10.0f %10.0f %10zu\n", label.c_str(), p50 * 1e3, max * 1e3, latencies_s.size());
    out["stop"][node.empty() ? "sigint" : "participant_killed"] = {
        {"node", node}, {"latency_s", latencies_s}, {"p50_s", p50}, {"max_s", max}};
  }

  std::printf("\n  %-14s %10s %12s %16s %16s %10s\n", "realtime", "sim s", "x real time", "steps behind",
              "max behind ms", "late acks");
  for (const double factor : {1.0, 2.0}) {
    bridge::LaunchOptions options;
    options.scenario_path = scenario_path;
    options.overrides = {"mode=realtime", "duration_s=4", "clock.realtime_factor=" + std::to_string(factor)};
    options.out_dir = (dir / "realtime").string();
    options.bin_dir = bridge::ExecutableDir();
    const bridge::LaunchResult result = bridge::Launch(options);
    if (result.exit_code != 0) {
      std::fprintf(stderr, "bench launch: the realtime run at %.0fx failed: %s\n", factor,
                   result.message.c_str());
      status = 1;
      continue;
    }
    const nlohmann::json metrics = nlohmann::json::parse(std::ifstream(result.run_dir + "/metrics.json"));
    nlohmann::json behind, late = nlohmann::json::object();
    for (const auto& [name, process] : metrics["processes"].items()) {
      if (process.contains("behind_schedule")) behind = process["behind_schedule"];
      if (process.contains("late_acks")) late = process["late_acks"];
    }
    uint64_t late_total = 0;
    for (const auto& [name, count] : late.items()) late_total += count.get<uint64_t>();
    const double rtf = metrics["real_time_factor"].get<double>();
    worst_pacing = std::max(worst_pacing, std::abs(rtf / factor - 1.0));
    char label[32];
    std::snprintf(label, sizeof(label), "%.0fx requested", factor);
    std::printf("  %-14s %10.1f %12.3f %16llu %16.1f %10llu\n", label, metrics["sim_time_s"].get<double>(),
                rtf, static_cast<unsigned long long>(behind["steps"].get<uint64_t>()),
                behind["max_ms"].get<double>(), static_cast<unsigned long long>(late_total));
    out["realtime"][std::to_string(static_cast<int>(factor)) + "x"] = {
        {"requested", factor}, {"real_time_factor", rtf}, {"behind_schedule", behind}, {"late_acks", late}};
    fs::remove_all(result.run_dir);
  }
  fs::remove_all(dir);
  std::printf(
      "\n  targets: a run ends within 1 s of a death or a stop (the tests' contract: 10 s): %.2f s, %s; "
      "realtime\n"
      "  within 2 %% of the requested factor: %.1f %%, %s\n",
      worst_s, worst_s <= 1.0 ? "met" : "NOT met", worst_pacing * 100.0,
      worst_pacing <= 0.02 ? "met" : "NOT met");
  return status;
}

}  // namespace iapsim::tools
