#pragma once
// The subcommands of the `iapsim` program. Each returns the process exit code.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tools/sweep.h"

namespace iapsim::tools {

struct RunArgs {
  std::string scenario;
  std::string out_dir;
  std::string mode;  // empty: the scenario's
  std::optional<double> duration_s;
  std::optional<uint64_t> seed;
  std::vector<std::string> overrides;  // KEY=VALUE
  std::string video;                   // a camera eye whose recorded images become an MP4 after the run
  bool check = false;                  // validate everything, run nothing
};
int Run(const RunArgs& args);

struct ReplayArgs {
  std::string log;     // a bag, or a TUM / CSV pose file
  std::string format;  // of a pose file: tum | csv (default: from the extension)
  std::string topic;   // where a pose file's poses go
  std::vector<std::string> topics;
  std::vector<std::string> map;  // FROM:=TO
  bool as_pose = false;
  std::string pose_field;
  RunArgs run;
};
int Replay(const ReplayArgs& args);

/// Recomputes the tracking metrics and plots of a finished run from its recording (evaluation.tracking
/// of its scenario.resolved.yaml).
int Evaluate(const std::string& run_dir);

struct RegressArgs {
  std::string suite_dir = "configs/regression";
  std::string out_dir;                 // default runs/regress-<UTC time>
  std::vector<std::string> only;       // flight names; empty: all
  std::vector<std::string> overrides;  // --set KEY=VALUE, on every flight
  int monte_carlo = 0;                 // draws per flight; 0: each flight once
  bool keep_bags = false;              // Monte Carlo: keep every draw's recording
  std::string fidelity;                // ideal | realistic | both; default both, Monte Carlo realistic
  SweepExecution execution;            // the flights (draws) on the local pool (jobs); draws on Slurm
};
/// Runs every regression flight of DIR/suite.yaml in lockstep, evaluates it, compares the metrics with the
/// suite's thresholds and prints a table: each flight in the ideal profile against its `max`/`contact_*`
/// bounds and in `fidelity: realistic` against its `realistic` bounds; each an `iapsim run` child,
/// `execution.jobs` at a time. With `monte_carlo` N, flies each N
/// times (realistic unless told otherwise) with seeds 1..N and the suite's `monte_carlo.set` keys, and checks
/// the 95th/5th percentiles of the metrics and the task success rate against the flights' `monte_carlo`
/// bounds. Returns 1 on any regression, 2 on a bad suite, 130 interrupted.
int Regress(const RegressArgs& args);

int Info(const std::string& bag);

struct ReindexArgs {
  std::string bag;
  std::string output;  // empty: in place, the original kept as BAG.orig.bag (rosbag reindex's habit)
  bool lz4 = false;    // compress the copy's chunks
};
/// Writes the index of a bag its writer did not close (a killed recorder's), from the whole chunks it holds.
int Reindex(const ReindexArgs& args);

struct VideoArgs {
  std::string bag;
  std::string camera;  // eye namespace or image topic
  std::string output;  // empty: DefaultVideoPath
};
/// An MP4 and a contact sheet of a camera's images in a bag (tools/video.h).
int Video(const VideoArgs& args);

struct ExportArgs {
  std::string bag;
  std::string topic;
  std::string format = "csv";
  std::string pose_field;
  std::string output;  // empty: stdout
};
int Export(const ExportArgs& args);

struct LiveArgs {
  std::string run_dir = "runs/latest";
  std::string topic;
  double listen_s = 1.0;
  long count = -1;
};
int Topics(const LiveArgs& args);
int Echo(const LiveArgs& args);

/// Writes the URDF of a vehicle YAML to `output` (stdout when empty). Bad YAML: exit 2.
int Urdf(const std::string& vehicle, const std::string& output, bool ros);

/// The benchmarks' percentile: the nearest-rank value at `fraction` (0.5 the median, 1 the largest); 0 when
/// there is none.
double Percentile(std::vector<double> values, double fraction);

/// Bus latency (ipc/tcp, state-sized and image-sized messages) and lockstep round trips between two
/// processes. Prints a table and adds the figures to `report`.
int BenchBus(nlohmann::json* report);

/// In-process physics steps/s for the vehicle (in the air, on the ground) and for 2..8 sub-aircraft, with
/// a bare Bullet multibody of the same size as the baseline of each; and the physics of `scenario_path` in
/// its realistic profile against its ideal one (issue 19's cost budget).
int BenchPhysics(const std::string& vehicle_path, const std::string& scenario_path, nlohmann::json* report);

/// Images/s at 640x480 on the CPU (OSMesa) in `scene_path` with the vehicle flying through it: one camera and
/// three stereo pairs (six images a frame), render only and render + PNG encode, with frame latencies.
int BenchRender(const std::string& scene_path, const std::string& vehicle_path, nlohmann::json* report);

/// Wall time of a lockstep scenario run `repeats` times each with recording off, on, and on with lz4,
/// alternating: best and median, real-time factor, the recorded/unrecorded ratio and the bag's size.
int BenchRecord(const std::string& scenario, int repeats, nlohmann::json* report);

/// The launcher's wall-clock behaviour on `scenario`, `repeats` runs each: how long a run takes to end after
/// a participant is killed and after a stop request (SIGINT), and the real-time factor, late steps and late
/// acknowledgements of realtime mode at 1x and 2x.
int BenchLaunch(const std::string& scenario, int repeats, nlohmann::json* report);

/// Issue 19's reference checks (tools/fidelity_reference.h) on the vehicle and its first sub-aircraft: a 1 N
/// step force, a 10° attitude step and the rate loop's frequency response, a pack's hover discharge, each
/// beside its linear model or published value, ideal and realistic actuation.
int BenchFidelity(const std::string& vehicle_path, nlohmann::json* report);

/// Control steps/s of the RL docking environments over whole episodes flown by the expert, 1 and 2 threads,
/// and where one thread's time goes (policy, physics in the air and in contact, the rest of the environment).
int BenchRl(const std::string& task_file, nlohmann::json* report);

/// `iapsim sweep`'s throughput: 8 seeds of the scenario one at a time, on the local pool (a run per core) and
/// as a Slurm job array (SLURM_CONF's cluster, else a one-node cluster started for it when Slurm is
/// installed).
int BenchSweep(const std::string& scenario, nlohmann::json* report);

/// The ROS bridge's round trip with the example's external node
/// (configs/scenarios/three_star_ros_square.yaml, ros_square_node), 60 s in realtime and in lockstep:
/// answers, losses, p50/p99/max.
int BenchRos(nlohmann::json* report);

struct BenchArgs {
  std::string what = "all";  // bus, physics, render, record, launch, fidelity, rl, sweep, ros or all
  std::string vehicle = "configs/vehicles/three_star.yaml";
  std::string scene = "configs/scenes/buildings.yaml";
  std::string scenario = "configs/regression/three_star_spiral.yaml";
  std::string task = "configs/rl/docking.yaml";
  int repeats = 3;
  std::string json;  // also write every figure here
};
/// Runs the benchmarks named by `what`.
int Bench(const BenchArgs& args);

}  // namespace iapsim::tools
