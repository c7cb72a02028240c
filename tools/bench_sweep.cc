// iapsim bench sweep: the throughput of `iapsim sweep` against issue 22's targets. Eight seeds of the
// scenario run one at a time (the sum of the single runs' wall times), on the local pool with a run per core
// (target: the pool's wall time ≤ 1.1 × sum / cores), and as one Slurm job array (target: under 1 s added per
// run over the local pool). Slurm: the cluster of SLURM_CONF, else a one-node cluster of
// tools/slurm_local_cluster.sh started for the benchmark when Slurm is installed, else not measured.

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "bridge/launcher.h"
#include "tools/batch.h"
#include "tools/commands.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct SweepTiming {
  double wall_s = -1.0;    // the whole `iapsim sweep`; < 0: it failed
  double sum_run_s = 0.0;  // its runs' own wall times
  double cpu_s = 0.0;      // CPU time of all its processes (user and system), when they ran on this machine
  std::string error;
};

// user + system time of every process this one has waited for, and those have waited for (RUSAGE_CHILDREN)
double ChildrenCpu_s() {
  rusage usage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

SweepTiming TimeSweep(const fs::path& sweep_file, const fs::path& out,
                      const std::vector<std::string>& flags) {
  std::vector<std::string> argv = {bridge::ExecutableDir() + "/iapsim", "sweep", sweep_file.string(), "--out",
                                   out.string()};
  argv.insert(argv.end(), flags.begin(), flags.end());
  const Clock::time_point start = Clock::now();
  const double cpu_before_s = ChildrenCpu_s();
  const CommandResult result = RunCapturing(argv);
  SweepTiming timing;
  if (result.exit_code != 0) {
    timing.error = "iapsim sweep exited " + std::to_string(result.exit_code) + ": " + result.output;
    return timing;
  }
  timing.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  timing.cpu_s = ChildrenCpu_s() - cpu_before_s;
  std::ifstream in(out / "sweep.json");
  const nlohmann::json record = nlohmann::json::parse(in);  // named: a temporary's ["runs"] would dangle
  for (const auto& run : record["runs"]) timing.sum_run_s += run.value("wall_s", 0.0);
  return timing;
}

// A one-node cluster for the benchmark, stopped when it goes out of scope; empty() when none could start.
class LocalCluster {
 public:
  explicit LocalCluster(const fs::path& dir) : dir_(dir) {
    if (RunCapturing({"sh", "-c", "command -v slurmctld"}).exit_code != 0) {
      why_ = "Slurm is not installed and SLURM_CONF is not set";
      return;
    }
    const CommandResult result = RunCapturing({IAPSIM_SLURM_LOCAL_CLUSTER, "start", dir.string()});
    const std::string prefix = "export SLURM_CONF=";
    const size_t at = result.output.rfind(prefix);
    if (result.exit_code != 0 || at == std::string::npos) {
      why_ = "the local cluster did not start: " + result.output;
      return;
    }
    std::string conf = result.output.substr(at + prefix.size());
    conf = conf.substr(0, conf.find('\n'));
    ::setenv("SLURM_CONF", conf.c_str(), 1);
    up_ = true;
  }
  ~LocalCluster() {
    if (!up_) return;
    RunCapturing({IAPSIM_SLURM_LOCAL_CLUSTER, "stop", dir_.string()});
    ::unsetenv("SLURM_CONF");
  }
  bool up() const { return up_; }
  const std::string& why() const { return why_; }

 private:
  fs::path dir_;
  bool up_ = false;
  std::string why_;
};

}  // namespace

int BenchSweep(const std::string& scenario_path, nlohmann::json* report) {
  constexpr int kRuns = 8;
  constexpr double kDurationS = 10.0;
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const fs::path dir = fs::temp_directory_path() / ("iapsim-bench-sweep-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path sweep_file = dir / "seeds.yaml";
  {
    std::ofstream out(sweep_file);
    out << "name: bench\nscenario: " << fs::absolute(scenario_path).string()
        << "\nset: {duration_s: " << kDurationS << "}\nseeds: [";
    for (int i = 1; i <= kRuns; ++i) out << (i > 1 ? ", " : "") << i;
    out << "]\nmetrics: [wall_time_s]\nkeep_bags: false\n";
  }
  std::printf("iapsim bench sweep: %d runs (seeds) of %s, %.0f s each, on %d cores\n\n", kRuns,
              scenario_path.c_str(), kDurationS, cores);
  nlohmann::json& out = (*report)["sweep"];
  out = {{"scenario", scenario_path}, {"runs", kRuns}, {"duration_s", kDurationS}, {"cores", cores}};

  const SweepTiming single = TimeSweep(sweep_file, dir / "single", {"--jobs", "1"});
  const SweepTiming pool = TimeSweep(sweep_file, dir / "pool", {"--jobs", std::to_string(cores)});
  for (const SweepTiming* t : {&single, &pool}) {
    if (t->wall_s < 0) {
      std::fprintf(stderr, "bench sweep: %s\n", t->error.c_str());
      fs::remove_all(dir);
      return 1;
    }
  }
  // a run is a graph of processes: alone it keeps more than one core busy, and the pool cannot beat its CPU
  const double ideal_s = single.sum_run_s / cores,
               cpu_bound_s = std::max(single.cpu_s, single.sum_run_s) / cores;
  std::printf("  %-52s %8.1f s (%.2f s a run, %.2f cores busy)\n",
              "one at a time: the sum of the runs' wall times", single.sum_run_s, single.sum_run_s / kRuns,
              single.cpu_s / single.sum_run_s);
  std::printf("  %-52s %8.1f s = %.2f x sum/%d (target <= 1.1)\n",
              ("local pool, " + std::to_string(cores) + " at a time").c_str(), pool.wall_s,
              pool.wall_s / ideal_s, cores);
  std::printf("  %-52s %8.1f s; the pool took %.2f x that\n",
              ("  its bound: the runs' CPU time / " + std::to_string(cores) + " cores").c_str(), cpu_bound_s,
              pool.wall_s / cpu_bound_s);
  // what the pool itself costs: the time its slots were not running a run
  const double pool_idle_s = pool.wall_s - pool.sum_run_s / cores;
  std::printf("  %-52s %8.2f s (the runs, slowed by sharing the cores: %.2f x their time alone)\n",
              "  the pool's own cost: wall - sum of its runs / cores", pool_idle_s,
              pool.sum_run_s / single.sum_run_s);
  out["pool_idle_s"] = pool_idle_s;
  out["pool_run_slowdown"] = pool.sum_run_s / single.sum_run_s;
  out["sum_single_run_wall_s"] = single.sum_run_s;
  out["single_cores_busy"] = single.cpu_s / single.sum_run_s;
  out["pool_wall_s"] = pool.wall_s;
  out["pool_ratio_to_ideal"] = pool.wall_s / ideal_s;
  out["pool_ratio_to_cpu_bound"] = pool.wall_s / cpu_bound_s;

  std::optional<LocalCluster> cluster;
  std::string where = "SLURM_CONF's cluster";
  if (std::getenv("SLURM_CONF") == nullptr) {
    cluster.emplace(dir / "cluster");
    where = "a one-node cluster on this machine";
  }
  if (cluster && !cluster->up()) {
    std::printf("  %-52s not measured: %s\n", "Slurm job array", cluster->why().c_str());
    out["slurm"] = {{"measured", false}, {"why", cluster->why()}};
  } else {
    const SweepTiming slurm = TimeSweep(sweep_file, dir / "slurm", {"--slurm"});
    if (slurm.wall_s < 0) {
      std::fprintf(stderr, "bench sweep: --slurm: %s\n", slurm.error.c_str());
      fs::remove_all(dir);
      return 1;
    }
    const double added_per_run_s = (slurm.wall_s - pool.wall_s) / kRuns;
    std::printf("  %-52s %8.1f s: %+.2f s a run over the local pool (target < 1)\n",
                ("Slurm job array, " + where).c_str(), slurm.wall_s, added_per_run_s);
    out["slurm"] = {{"measured", true},
                    {"cluster", where},
                    {"wall_s", slurm.wall_s},
                    {"sum_run_wall_s", slurm.sum_run_s},
                    {"added_per_run_s", added_per_run_s}};
  }
  cluster.reset();
  fs::remove_all(dir);
  return 0;
}

}  // namespace iapsim::tools
