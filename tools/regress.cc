// `iapsim regress`: the regression flights of a suite (configs/regression/suite.yaml), each run in lockstep
// and evaluated like `iapsim run` does, its metrics compared with the suite's upper bounds.

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>

#include "bridge/config.h"
#include "bridge/launcher.h"
#include "bridge/scenario.h"
#include "tools/commands.h"
#include "tools/flight_evaluation.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
constexpr double kUnchecked = std::numeric_limits<double>::quiet_NaN();

// An upper bound on one number of the tracking metrics: its JSON path (section, key).
struct Bound {
  std::string section;
  std::string key;  // empty: the section is the number
  double max = kUnchecked;
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
    bounds->push_back({section, axes[i], value});
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
      Bound bound{count, "", 0.0};
      max.OptionalInRange(count, &bound.max, 0.0, 1e12);
      flight.bounds.push_back(bound);
    }
    max.Finish();
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
  const fs::path out_dir = args.out_dir.empty() ? fs::path("runs") / ("regress-" + bridge::UtcStamp()) : fs::path(args.out_dir);
  fs::create_directories(out_dir);

  nlohmann::json report;
  int failures = 0;
  std::printf("%-22s %-28s %12s %12s  %s\n", "flight", "metric", "value", "max", "result");
  for (const Flight& flight : flights) {
    if (!args.only.empty() && std::find(args.only.begin(), args.only.end(), flight.name) == args.only.end()) continue;
    bridge::LaunchOptions options;
    options.scenario_path = flight.scenario;
    options.overrides = {"mode=lockstep"};
    options.out_dir = (out_dir / flight.name).string();
    options.bin_dir = bridge::ExecutableDir();
    const bridge::LaunchResult result = bridge::Launch(options);
    nlohmann::json& entry = report[flight.name];
    entry["run_dir"] = options.out_dir;
    if (result.exit_code != 0) {
      std::printf("%-22s %-28s %12s %12s  FAILED: %s\n", flight.name.c_str(), "run", "-", "-", result.message.c_str());
      entry["error"] = result.message;
      ++failures;
      continue;
    }
    std::optional<TrackingEvaluation> evaluation = ReadTrackingEvaluation(bridge::LoadScenario(flight.scenario));
    if (!evaluation) {
      std::printf("%-22s %-28s  FAILED: the scenario has no evaluation.tracking\n", flight.name.c_str(), "run");
      ++failures;
      continue;
    }
    const nlohmann::json tracking = EvaluateTracking(result.run_dir, *evaluation);
    entry["tracking"] = tracking;
    for (const Bound& bound : flight.bounds) {
      const nlohmann::json& number = bound.key.empty() ? tracking[bound.section] : tracking[bound.section][bound.key];
      const double value = number.get<double>();
      const bool ok = value <= bound.max;
      const std::string metric = bound.key.empty() ? bound.section : bound.section + "." + bound.key;
      std::printf("%-22s %-28s %12.4f %12.4f  %s\n", flight.name.c_str(), metric.c_str(), value, bound.max,
                  ok ? "ok" : "REGRESSION");
      entry["checks"][metric] = {{"value", value}, {"max", bound.max}, {"ok", ok}};
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
