#include "tools/batch.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace iapsim::tools {

std::vector<std::string> ReadSetOverrides(bridge::YamlMap& map) {
  std::vector<std::string> overrides;
  if (!map.Has("set")) return overrides;
  const YAML::Node set = map.Raw("set");
  if (!set.IsMap()) map.Fail("set", "expected a map of scenario keys (dotted, as --set) to values");
  for (const auto& entry : set) {
    YAML::Emitter value;
    value << YAML::Flow << entry.second;
    overrides.push_back(entry.first.Scalar() + "=" + value.c_str());
  }
  return overrides;
}

double InterpolatedPercentile(const std::vector<double>& sorted, double p) {
  const double h = (sorted.size() - 1) * p / 100.0;
  const size_t below = static_cast<size_t>(std::floor(h));
  const size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (h - below) * (sorted[above] - sorted[below]);
}

nlohmann::json MetricStatistics(const std::vector<nlohmann::json>& runs) {
  std::map<std::string, std::vector<double>> values;  // by JSON pointer
  for (const nlohmann::json& metrics : runs) {
    const nlohmann::json flat = metrics.flatten();  // items() of a temporary would outlive it
    for (const auto& [pointer, value] : flat.items()) {
      if (value.is_number()) values[pointer].push_back(value.get<double>());
    }
  }
  nlohmann::json flat = nlohmann::json::object();
  for (auto& [pointer, samples] : values) {
    std::sort(samples.begin(), samples.end());
    double sum = 0.0;
    for (double v : samples) sum += v;
    flat[pointer + "/p5"] = InterpolatedPercentile(samples, 5.0);
    flat[pointer + "/p50"] = InterpolatedPercentile(samples, 50.0);
    flat[pointer + "/p95"] = InterpolatedPercentile(samples, 95.0);
    flat[pointer + "/mean"] = sum / samples.size();
    flat[pointer + "/min"] = samples.front();
    flat[pointer + "/max"] = samples.back();
    flat[pointer + "/draws"] = samples.size();
  }
  return flat.unflatten();
}

}  // namespace iapsim::tools
