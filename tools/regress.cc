// `iapsim regress`: the regression flights of a suite (configs/regression/suite.yaml), each run in lockstep
// and evaluated like `iapsim run` does, its metrics compared with the suite's upper bounds.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>

#include "bridge/config.h"
#include "bridge/launcher.h"
#include "bridge/scenario.h"
#include "tools/commands.h"
#include "tools/run_evaluation.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
constexpr double kUnchecked = std::numeric_limits<double>::quiet_NaN();

// A bound on one number of the evaluation's metrics: its JSON path (analysis, section, key).
struct Bound {
  std::string analysis = "tracking";  // or "contact"
  std::string section;
  std::string key;  // empty: the section is the number
  double max = kUnchecked;
  double min = kUnchecked;
};

struct Flight {
  std::string name;
  std::string scenario;
  std::vector<Bound> bounds;
};

// A per-axis bound: three numbers, or null for an axis left unchecked (the free roll of a 5-DOF flight).
void ReadAxisBounds(bridge::YamlMap& map, const std::string& section, const std::vector<std::string>& axes,
                    std::vector<Bound>* bounds) {
  if (!map.Has(section)) return;
  const YAML::Node node = map.Raw(section);
  if (!node.IsSequence() || node.size() != axes.size()) {
    map.Fail(section, "expected " + std::to_string(axes.size()) + " upper bounds (a number or null each)");
  }
  for (size_t i = 0; i < axes.size(); ++i) {
    if (node[i].IsNull()) continue;
    double value = 0.0;
    if (!YAML::convert<double>::decode(node[i], value) || !(value >= 0.0)) {
      map.Fail(section, "entry " + std::to_string(i) + " must be a non-negative number or null");
    }
    bounds->push_back({"tracking", section, axes[i], value, kUnchecked});
  }
}

std::vector<Flight> ReadSuite(const std::string& suite_dir) {
  const std::string path = suite_dir + "/suite.yaml";
  const YAML::Node root = bridge::LoadYamlFile(path);
  bridge::YamlMap top(root, path);
  bridge::YamlMap flights = top.Map("flights");
  std::vector<Flight> out;
  for (const std::string& name : flights.Keys()) {
    Flight flight;
    flight.name = name;
    bridge::YamlMap map = flights.Map(name);
    map.Required("scenario", &flight.scenario);
    flight.scenario = (fs::path(suite_dir) / flight.scenario).string();
    if (!fs::exists(flight.scenario)) map.Fail("scenario", "no such file: " + flight.scenario);
    bridge::YamlMap max = map.Map("max");
    ReadAxisBounds(max, "position_rmse_m", {"x", "y", "z"}, &flight.bounds);
    ReadAxisBounds(max, "position_max_m", {"x", "y", "z"}, &flight.bounds);
    ReadAxisBounds(max, "attitude_rmse_deg", {"roll", "pitch", "yaw"}, &flight.bounds);
    ReadAxisBounds(max, "attitude_max_deg", {"roll", "pitch", "yaw"}, &flight.bounds);
    for (const char* count : {"saturated_updates", "mixer_saturated_steps"}) {
      if (!max.Has(count)) continue;
      Bound bound{"tracking", count, "", 0.0, kUnchecked};
      max.OptionalInRange(count, &bound.max, 0.0, 1e12);
      flight.bounds.push_back(bound);
    }
    max.Finish();
    // contact metrics (contact_evaluation.h) by dotted path, e.g. wrench_error_relative.fy: 0.1
    for (const char* kind : {"contact_max", "contact_min"}) {
      bridge::YamlMap limits = map.Map(kind);
      for (const std::string& metric : limits.Keys()) {
        const auto dot = metric.find('.');
        Bound bound{"contact", metric.substr(0, dot), dot == std::string::npos ? "" : metric.substr(dot + 1),
                    kUnchecked, kUnchecked};
        double value = 0.0;
        limits.Required(metric, &value);
        (std::string(kind) == "contact_max" ? bound.max : bound.min) = value;
        flight.bounds.push_back(bound);
      }
      limits.Finish();
    }
    map.Finish();
    out.push_back(flight);
  }
  flights.Finish();
  top.Finish();
  if (out.empty()) top.Fail("flights", "the suite has no flights");
  return out;
}

}  // namespace

int Regress(const RegressArgs& args) {
  std::vector<Flight> flights;
  try {
    flights = ReadSuite(args.suite_dir);
  } catch (const bridge::ConfigError& e) {
    std::cerr << "iapsim: invalid suite: " << e.what() << std::endl;
    return 2;
  }
  for (const auto& only : args.only) {
    if (std::none_of(flights.begin(), flights.end(), [&](const Flight& f) { return f.name == only; })) {
      std::cerr << "iapsim: no flight '" << only << "' in " << args.suite_dir << "/suite.yaml" << std::endl;
      return 2;
    }
  }
  const fs::path out_dir =
      args.out_dir.empty() ? fs::path("runs") / ("regress-" + bridge::UtcStamp()) : fs::path(args.out_dir);
  fs::create_directories(out_dir);

  nlohmann::json report;
  int failures = 0;
  std::printf("%-22s %-34s %12s %14s  %s\n", "flight", "metric", "value", "bound", "result");
  for (const Flight& flight : flights) {
    if (!args.only.empty() && std::find(args.only.begin(), args.only.end(), flight.name) == args.only.end())
      continue;
    bridge::LaunchOptions options;
    options.scenario_path = flight.scenario;
    options.overrides = {"mode=lockstep"};
    options.out_dir = (out_dir / flight.name).string();
    options.bin_dir = bridge::ExecutableDir();
    const bridge::LaunchResult result = bridge::Launch(options);
    nlohmann::json& entry = report[flight.name];
    entry["run_dir"] = options.out_dir;
    if (result.exit_code != 0) {
      std::printf("%-22s %-28s %12s %12s  FAILED: %s\n", flight.name.c_str(), "run", "-", "-",
                  result.message.c_str());
      entry["error"] = result.message;
      ++failures;
      continue;
    }
    const RunEvaluation evaluation = ReadRunEvaluation(bridge::LoadScenario(flight.scenario));
    if (evaluation.empty()) {
      std::printf("%-22s %-28s  FAILED: the scenario has no evaluation section\n", flight.name.c_str(),
                  "run");
      ++failures;
      continue;
    }
    const nlohmann::json metrics = EvaluateRun(result.run_dir, evaluation);
    for (const auto& [analysis, section] : metrics.items()) entry[analysis] = section;
    for (const Bound& bound : flight.bounds) {
      const std::string metric = (bound.analysis == "contact" ? "contact." : "") + bound.section +
                                 (bound.key.empty() ? "" : "." + bound.key);
      const nlohmann::json* number = nullptr;
      if (metrics.contains(bound.analysis) && metrics[bound.analysis].contains(bound.section)) {
        const nlohmann::json& section = metrics[bound.analysis][bound.section];
        number = bound.key.empty() ? &section : section.contains(bound.key) ? &section[bound.key] : nullptr;
      }
      // a metric the evaluation did not produce, or null (an axis never settled), fails its check
      const double value = number && number->is_number() ? number->get<double>() : kUnchecked;
      const bool ok = !std::isnan(value) && !(value > bound.max) && !(value < bound.min);
      const double limit = std::isnan(bound.max) ? bound.min : bound.max;
      std::printf("%-22s %-34s %12.4f %4s %9.4f  %s\n", flight.name.c_str(), metric.c_str(), value,
                  std::isnan(bound.max) ? "min" : "max", limit, ok ? "ok" : "REGRESSION");
      entry["checks"][metric] = {
          {"value", value}, {std::isnan(bound.max) ? "min" : "max", limit}, {"ok", ok}};
      if (!ok) ++failures;
    }
    std::printf("%-22s plots and metrics in %s\n", flight.name.c_str(), result.run_dir.c_str());
  }
  const fs::path report_path = out_dir / "regress.json";
  std::ofstream(report_path) << report.dump(2) << "\n";
  std::printf("\n%s: %d regression%s; runs and plots under %s\n", failures == 0 ? "PASS" : "FAIL", failures,
              failures == 1 ? "" : "s", out_dir.c_str());
  return failures == 0 ? 0 : 1;
}

}  // namespace iapsim::tools
