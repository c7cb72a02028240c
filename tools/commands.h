#pragma once
// The subcommands of the `iapsim` program. Each returns the process exit code.

#include <optional>
#include <string>
#include <vector>

namespace iapsim::tools {

struct RunArgs {
  std::string scenario;
  std::string out_dir;
  std::string mode;  // empty: the scenario's
  std::optional<double> duration_s;
  std::optional<uint64_t> seed;
  std::vector<std::string> overrides;  // KEY=VALUE
};
int Run(const RunArgs& args);

struct ReplayArgs {
  std::string bag;
  std::vector<std::string> topics;
  std::vector<std::string> map;  // FROM:=TO
  RunArgs run;
};
int Replay(const ReplayArgs& args);

int Info(const std::string& bag);

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
int Urdf(const std::string& vehicle, const std::string& output);

/// Bus latency (ipc/tcp, state-sized and image-sized messages) and lockstep round trips between two
/// processes.
int BenchBus(const std::string& json_path);

}  // namespace iapsim::tools
