#pragma once
// What the batches of runs share: the regression suite's Monte Carlo draws (tools/regress.cc) and
// `iapsim sweep` (tools/sweep.h) read their `set:` blocks and summarise their runs' metrics the same way, and
// start the programs they drive (sbatch, iapsim sweep) the same way.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bridge/config.h"

namespace iapsim::tools {

/// `set: {dotted.key: value, ...}` of `map` as --set assignments, each value one line of flow YAML.
std::vector<std::string> ReadSetOverrides(bridge::YamlMap& map);

/// Percentile p (0..100) of sorted values, interpolated linearly between order statistics (numpy's default,
/// Hyndman and Fan's type 7), as the band plots compute it.
double InterpolatedPercentile(const std::vector<double>& sorted, double p);

/// Every number of the runs' metrics (metrics.json) as {p5, p50, p95, mean, min, max, draws} over the runs
/// that have it.
nlohmann::json MetricStatistics(const std::vector<nlohmann::json>& runs);

struct CommandResult {
  int exit_code = -1;  // 127: it could not be started; 128 + N: killed by signal N
  std::string output;  // standard output and error together
};

/// Runs argv[0] (found on PATH) with these arguments, no shell in between, and collects what it prints.
CommandResult RunCapturing(const std::vector<std::string>& argv);

}  // namespace iapsim::tools
