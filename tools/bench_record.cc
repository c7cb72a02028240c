// iapsim bench record: what recording costs a lockstep flight. The same scenario (by default the three-star
// spiral of `make run`: physics 1 kHz clock, control 200 Hz) runs with recording off, on, and on with lz4
// chunks, alternating in one invocation so that both see the same machine load, and the figures compare
// medians and bests of the launcher's wall time (start of the processes to the last exit, so the bag is
// complete and closed).

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "bridge/launcher.h"
#include "tools/commands.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;

struct Variant {
  const char* key;
  const char* label;
  std::vector<std::string> overrides;
};

struct Sample {
  double wall_s = 0.0;     // metrics.json wall_time_s: the whole run, shutdown and bag close included
  double clock_rtf = 0.0;  // sim time over the clock's own wall time (start to "done")
  double sim_s = 0.0;
  uint64_t bag_bytes = 0;
  uint64_t recorded = 0;  // messages in the bag
};

// One run of the scenario; false (with the reason printed) when it did not complete.
bool RunOnce(const std::string& scenario, const Variant& variant, const fs::path& dir, Sample* sample) {
  bridge::LaunchOptions options;
  options.scenario_path = scenario;
  options.overrides = variant.overrides;
  options.overrides.push_back("mode=lockstep");
  options.out_dir = (dir / variant.key).string();
  options.bin_dir = bridge::ExecutableDir();
  const bridge::LaunchResult result = bridge::Launch(options);
  if (result.exit_code != 0) {
    std::fprintf(stderr, "bench record: the %s run failed: %s\n", variant.label, result.message.c_str());
    return false;
  }
  const nlohmann::json metrics = nlohmann::json::parse(std::ifstream(result.run_dir + "/metrics.json"));
  sample->wall_s = metrics["wall_time_s"].get<double>();
  sample->sim_s = metrics["sim_time_s"].get<double>();
  sample->clock_rtf = metrics["real_time_factor"].get<double>();
  const fs::path bag = fs::path(result.run_dir) / "run.bag";
  sample->bag_bytes = fs::exists(bag) ? fs::file_size(bag) : 0;
  if (metrics["processes"].contains("recorder")) {
    for (const auto& [topic, count] : metrics["processes"]["recorder"]["process"]["recorded"].items()) {
      sample->recorded += count.get<uint64_t>();
    }
  }
  fs::remove_all(result.run_dir);
  return true;
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

struct Summary {
  double best_wall_s = 0.0;
  double median_wall_s = 0.0;
  double median_clock_rtf = 0.0;
  double sim_s = 0.0;
  uint64_t bag_bytes = 0;
  uint64_t recorded = 0;
};

Summary Summarize(const std::vector<Sample>& samples) {
  std::vector<double> walls, rtfs;
  for (const Sample& s : samples) {
    walls.push_back(s.wall_s);
    rtfs.push_back(s.clock_rtf);
  }
  Summary summary;
  summary.best_wall_s = *std::min_element(walls.begin(), walls.end());
  summary.median_wall_s = Median(walls);
  summary.median_clock_rtf = Median(rtfs);
  summary.sim_s = samples.front().sim_s;
  summary.bag_bytes = samples.front().bag_bytes;
  summary.recorded = samples.front().recorded;
  return summary;
}

}  // namespace

int BenchRecord(const std::string& scenario, int repeats, nlohmann::json* report) {
  const std::vector<Variant> variants = {
      {"unrecorded", "recording off", {"recording.enabled=false"}},
      {"recorded", "recorded", {"recording.enabled=true"}},
      {"recorded_lz4", "recorded, lz4", {"recording.enabled=true", "recording.compression=lz4"}},
  };
  const fs::path dir = fs::temp_directory_path() / ("iapsim-bench-record-" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::printf("iapsim bench record: %s in lockstep, %d runs of each, alternating\n", scenario.c_str(),
              repeats);
  std::vector<std::vector<Sample>> samples(variants.size());
  for (int round = 0; round < repeats; ++round) {
    for (size_t v = 0; v < variants.size(); ++v) {
      Sample sample;
      if (!RunOnce(scenario, variants[v], dir, &sample)) {
        fs::remove_all(dir);
        return 1;
      }
      samples[v].push_back(sample);
    }
  }
  fs::remove_all(dir);

  std::printf("\n  %-16s %12s %12s %12s %14s %10s %10s %12s\n", "", "best wall s", "median s", "x real time",
              "clock x real", "vs off", "bag MiB", "messages");
  nlohmann::json& out = (*report)["record"];
  out["scenario"] = scenario;
  out["runs_each"] = repeats;
  const Summary off = Summarize(samples[0]);
  for (size_t v = 0; v < variants.size(); ++v) {
    const Summary s = Summarize(samples[v]);
    const double ratio = s.median_wall_s / off.median_wall_s;
    std::printf("  %-16s %12.2f %12.2f %12.1f %14.1f %10.2f %10.1f %12llu\n", variants[v].label,
                s.best_wall_s, s.median_wall_s, s.sim_s / s.median_wall_s, s.median_clock_rtf, ratio,
                static_cast<double>(s.bag_bytes) / (1 << 20), static_cast<unsigned long long>(s.recorded));
    std::vector<double> walls;
    for (const Sample& sample : samples[v]) walls.push_back(sample.wall_s);
    out[variants[v].key] = {{"wall_s", walls},
                            {"best_wall_s", s.best_wall_s},
                            {"median_wall_s", s.median_wall_s},
                            {"real_time_factor", s.sim_s / s.median_wall_s},
                            {"clock_real_time_factor", s.median_clock_rtf},
                            {"vs_unrecorded", ratio},
                            {"bag_bytes", s.bag_bytes},
                            {"messages", s.recorded}};
  }
  const Summary recorded = Summarize(samples[1]);
  const double ratio = recorded.median_wall_s / off.median_wall_s;
  const double rtf = recorded.sim_s / recorded.median_wall_s;
  std::printf("\n  targets: recorded <= 1.3x unrecorded (%.2fx: %s), >= 50x real time recorded (%.1fx: %s)\n",
              ratio, ratio <= 1.3 ? "met" : "NOT met", rtf, rtf >= 50.0 ? "met" : "NOT met");
  return 0;
}

}  // namespace iapsim::tools
