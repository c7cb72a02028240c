#pragma once
// The commands of `iapsim rl`. They run in their own program, iapsim_rl (tools/rl_main.cc), which
// `iapsim rl ...` becomes: they may fly learned policies, and loading libtorch costs a process 2 s that no
// other `iapsim` command should pay. Each returns the process exit code.

#include <cstdint>
#include <string>
#include <vector>

namespace iapsim::tools {

/// What `iapsim rl eval` and `collect` fly: episodes e = 0 .. episodes − 1 of a task, each from the stream
/// (seed, e), with a policy.
struct RlEpisodeArgs {
  std::string task = "configs/rl/docking.yaml";
  std::string policy = "expert";  // or a TorchScript file (*.pt)
  int episodes = 200;
  uint64_t seed = 1;
  int threads = 2;
  std::vector<std::string> overrides;  // --set KEY=VALUE on the task
};

struct RlEvalArgs {
  RlEpisodeArgs episodes;
  std::string out_dir;      // summary.json, episodes.csv, traces.csv; empty: print only
  int trace_episodes = 10;  // episodes whose d_xz, d_y and f_y are written step by step
};
/// Flies `episodes` randomised docking episodes with a policy and prints its success rate and steps to
/// dock (seed §VI-H). Exit 2 on a bad task or policy.
int RlEval(const RlEvalArgs& args);

struct RlCollectArgs {
  RlEpisodeArgs episodes;
  std::string output;  // the HDF5 data set
};
/// Flies `episodes` episodes with a policy and writes their transitions as an HDF5 data set in D4RL's layout
/// (rl/dataset.h). Exit 2 on a bad task or policy, 1 when the file cannot be written.
int RlCollect(const RlCollectArgs& args);

}  // namespace iapsim::tools
