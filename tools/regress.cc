// `iapsim regress`: the regression flights of a suite (configs/regression/suite.yaml), each an `iapsim run`
// in lockstep (evaluated as that command evaluates it; a few side by side), its metrics compared with the
// suite's upper bounds: once as written (fidelity ideal) and once with `fidelity: realistic`
// (configs/profiles/realistic.yaml). With `--monte-carlo N` each flight flies N seeds of the realistic
// profile (each a model-mismatch draw, its own turbulence and sensor noise), and its metrics' percentiles and
// task success rate are compared with the flight's `monte_carlo` bounds.

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <map>
#include <tuple>

#include "bridge/config.h"
#include "bridge/launcher.h"
#include "bridge/scenario.h"
#include "tools/batch.h"
#include "tools/child_run.h"
#include "tools/commands.h"
#include "tools/plot_script.h"
#include "tools/run_evaluation.h"
#include "tools/sweep.h"

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

  std::string Metric() const {
    return (analysis == "contact" ? "contact." : "") + section + (key.empty() ? "" : "." + key);
  }
  nlohmann::json::json_pointer Pointer() const {
    return nlohmann::json::json_pointer("/" + analysis + "/" + section + (key.empty() ? "" : "/" + key));
  }
};

struct Flight {
  std::string name;
  std::string scenario;
  std::vector<Bound> bounds;            // one run, ideal
  std::vector<Bound> realistic_bounds;  // one run, fidelity: realistic
  // the realistic run's seed (its model-mismatch draw, turbulence and noise); 0: the scenario's. A contact
  // flight names a draw that does its task, so that a change which breaks the task in the realistic
  // profile is caught; the Monte Carlo success rate says how many draws do
  uint64_t realistic_seed = 0;
  // the profile the flight flies where the suite flies `realistic`: a task flown in a laboratory names the
  // arena's (realistic_indoor)
  std::string realistic_profile = "realistic";

  // The profile this flight flies where the suite flies `profile` (ideal or realistic).
  std::string ProfileFor(const std::string& profile) const {
    return profile == "realistic" ? realistic_profile : profile;
  }
  // --monte-carlo: bounds on the draws' 95th (max) and 5th (min) percentiles, and the least fraction of
  // draws that meet the flight's own contact bounds (that did the task)
  std::vector<Bound> monte_carlo_bounds;
  double task_success_min = 0.0;
};

struct Suite {
  std::vector<Flight> flights;
  std::vector<std::string> monte_carlo_overrides;  // "key.path=value", as --set
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

// The bounds of a flight (or of its monte_carlo block): `max` on the tracking metrics, `min: {samples}` on
// the number of samples compared, `contact_max` and
// `contact_min` on the contact metrics (contact_evaluation.h) by dotted path, e.g. wrench_error_relative.fy.
std::vector<Bound> ReadBounds(bridge::YamlMap& map) {
  std::vector<Bound> bounds;
  bridge::YamlMap max = map.Map("max");
  ReadAxisBounds(max, "position_rmse_m", {"x", "y", "z"}, &bounds);
  ReadAxisBounds(max, "position_max_m", {"x", "y", "z"}, &bounds);
  ReadAxisBounds(max, "attitude_rmse_deg", {"roll", "pitch", "yaw"}, &bounds);
  ReadAxisBounds(max, "attitude_max_deg", {"roll", "pitch", "yaw"}, &bounds);
  for (const char* count : {"saturated_updates", "mixer_saturated_steps", "unmatched_setpoints"}) {
    if (!max.Has(count)) continue;
    Bound bound{"tracking", count, "", 0.0, kUnchecked};
    double value = 0.0;
    max.Required(count, &value);
    if (!(value >= 0.0)) max.Fail(count, "must be a non-negative count");
    bound.max = value;
    bounds.push_back(bound);
  }
  max.Finish();
  // a flight that compared fewer samples than it should (a recording that lost messages) is a regression
  bridge::YamlMap min = map.Map("min");
  if (min.Has("samples")) {
    Bound bound{"tracking", "samples", "", kUnchecked, 0.0};
    min.Required("samples", &bound.min);
    if (!(bound.min >= 1.0)) min.Fail("samples", "must be a positive count");
    bounds.push_back(bound);
  }
  min.Finish();
  for (const char* kind : {"contact_max", "contact_min"}) {
    bridge::YamlMap limits = map.Map(kind);
    for (const std::string& metric : limits.Keys()) {
      const auto dot = metric.find('.');
      Bound bound{"contact", metric.substr(0, dot), dot == std::string::npos ? "" : metric.substr(dot + 1),
                  kUnchecked, kUnchecked};
      double value = 0.0;
      limits.Required(metric, &value);
      if (!std::isfinite(value)) limits.Fail(metric, "expected a number");
      (std::string(kind) == "contact_max" ? bound.max : bound.min) = value;
      bounds.push_back(bound);
    }
    limits.Finish();
  }
  return bounds;
}

Suite ReadSuite(const std::string& suite_dir) {
  const std::string path = suite_dir + "/suite.yaml";
  const YAML::Node root = bridge::LoadYamlFile(path);
  bridge::YamlMap top(root, path);
  Suite suite;
  bridge::YamlMap flights = top.Map("flights");
  for (const std::string& name : flights.Keys()) {
    Flight flight;
    flight.name = name;
    bridge::YamlMap map = flights.Map(name);
    map.Required("scenario", &flight.scenario);
    flight.scenario = (fs::path(suite_dir) / flight.scenario).string();
    if (!fs::exists(flight.scenario)) map.Fail("scenario", "no such file: " + flight.scenario);
    flight.bounds = ReadBounds(map);
    bridge::YamlMap realistic = map.Map("realistic");
    flight.realistic_bounds = ReadBounds(realistic);
    realistic.Optional("seed", &flight.realistic_seed);
    realistic.Optional("fidelity", &flight.realistic_profile);
    if (flight.realistic_profile == "ideal")
      realistic.Fail("fidelity", "expected a realistic profile, not ideal");
    realistic.Finish();
    bridge::YamlMap monte_carlo = map.Map("monte_carlo");
    flight.monte_carlo_bounds = ReadBounds(monte_carlo);
    monte_carlo.Optional("task_success_min", &flight.task_success_min);
    if (!(flight.task_success_min >= 0.0 && flight.task_success_min <= 1.0)) {
      monte_carlo.Fail("task_success_min", "expected a fraction of the draws, in [0, 1]");
    }
    monte_carlo.Finish();
    map.Finish();
    suite.flights.push_back(flight);
  }
  flights.Finish();
  bridge::YamlMap monte_carlo = top.Map("monte_carlo");
  suite.monte_carlo_overrides = ReadSetOverrides(monte_carlo);
  monte_carlo.Finish();
  top.Finish();
  if (suite.flights.empty()) top.Fail("flights", "the suite has no flights");
  return suite;
}

// One flight run and evaluated; `error` says why not.
struct FlightRun {
  std::string name;  // <flight> or <flight>-<profile>
  const Flight* flight = nullptr;
  std::string profile;   // ideal, realistic
  std::string fidelity;  // the profile flown: the flight's for `realistic`, or a --set fidelity=...
  bool ideal = true;
  std::vector<std::string> overrides;
  std::string run_dir;  // empty for a run that failed before flying
  std::string error;
  int exit_code = 0;
  nlohmann::json metrics;  // {tracking: ..., contact: ...}
};

// The sections a run's evaluation wrote into its metrics.json (not the processes' or the losses' counters).
nlohmann::json EvaluationSections(const nlohmann::json& metrics) {
  nlohmann::json sections = nlohmann::json::object();
  if (!metrics.is_object()) return sections;
  for (const auto& [key, value] : metrics.items()) {
    if (value.is_object() && key != "processes" && key != "losses") sections[key] = value;
  }
  return sections;
}

// What a flight's `iapsim run` left: its exit, and its evaluation's metrics.
void Landed(FlightRun* run, const ChildExit& exit) {
  run->exit_code = exit.exit_code;
  if (exit.exit_code != 0) {
    run->error =
        exit.reason.empty() ? "iapsim run exited with " + std::to_string(exit.exit_code) : exit.reason;
    return;
  }
  std::ifstream in(fs::path(run->run_dir) / "metrics.json");
  run->metrics = EvaluationSections(nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false));
  if (run->metrics.empty()) {
    run->error = "no evaluation in " + run->run_dir + "/metrics.json (see its iapsim.log)";
  }
}

// A metric's value, NaN when the evaluation did not produce it or it is null (an axis never settled).
double Value(const nlohmann::json& metrics, const Bound& bound) {
  const auto pointer = bound.Pointer();
  if (!metrics.contains(pointer) || !metrics[pointer].is_number()) return kUnchecked;
  return metrics[pointer].get<double>();
}

// Whether a value meets its bound (a missing value does not).
bool Holds(double value, const Bound& bound) {
  return !std::isnan(value) && !(value > bound.max) && !(value < bound.min);
}

// Prints and records one check; returns whether it holds.
bool Check(const std::string& flight, const std::string& metric, double value, const Bound& bound,
           nlohmann::json* checks) {
  const bool ok = Holds(value, bound);
  const double limit = std::isnan(bound.max) ? bound.min : bound.max;
  std::printf("%-28s %-40s %12.4f %4s %9.4f  %s\n", flight.c_str(), metric.c_str(), value,
              std::isnan(bound.max) ? "min" : "max", limit, ok ? "ok" : "REGRESSION");
  (*checks)[metric] = {{"value", value}, {std::isnan(bound.max) ? "min" : "max", limit}, {"ok", ok}};
  return ok;
}

std::vector<Flight> Selected(const std::vector<Flight>& flights, const std::vector<std::string>& only) {
  std::vector<Flight> out;
  for (const Flight& flight : flights) {
    if (only.empty() || std::find(only.begin(), only.end(), flight.name) != only.end()) out.push_back(flight);
  }
  return out;
}

// Prints a flown and evaluated run's tables and checks, and records them in `report`; returns the failures.
int Report(const FlightRun& run, nlohmann::json* report) {
  nlohmann::json& entry = (*report)[run.name];
  if (!run.run_dir.empty()) entry["run_dir"] = run.run_dir;
  entry["fidelity"] = run.fidelity;
  if (!run.error.empty()) {
    std::printf("%-28s %-40s  FAILED: %s\n", run.name.c_str(), "run", run.error.c_str());
    entry["error"] = run.error;
    return 1;
  }
  PrintRunEvaluation(run.metrics);
  int failures = 0;
  for (const auto& [analysis, section] : run.metrics.items()) entry[analysis] = section;
  for (const Bound& bound : run.ideal ? run.flight->bounds : run.flight->realistic_bounds) {
    if (!Check(run.name, bound.Metric(), Value(run.metrics, bound), bound, &entry["checks"])) ++failures;
  }
  std::printf("%-28s plots and metrics in %s\n", run.name.c_str(), run.run_dir.c_str());
  std::fflush(stdout);
  return failures;
}

// Each flight once in each of `profiles`, its metrics against the bounds of that profile. A realistic run
// is named <flight>-realistic (its folder, its rows and its entry in the report). The runs fly as `iapsim
// run` children, `jobs` at a time (each evaluates itself, as it would alone), and are reported in order.
int RegressOnce(const std::vector<Flight>& flights, const std::vector<std::string>& profiles,
                const std::vector<std::string>& overrides, int jobs, const fs::path& out_dir,
                nlohmann::json* report, bool* interrupted) {
  std::vector<FlightRun> runs;
  std::vector<ChildRun> children;
  for (const Flight& flight : flights) {
    for (const std::string& profile : profiles) {
      FlightRun run;
      run.flight = &flight;
      run.profile = profile;
      run.ideal = profile == "ideal";
      run.name = run.ideal ? flight.name : flight.name + "-" + profile;
      run.overrides = overrides;
      run.fidelity = flight.ProfileFor(profile);
      run.overrides.insert(run.overrides.begin(), "fidelity=" + run.fidelity);  // --set may still change it
      if (!run.ideal && flight.realistic_seed != 0) {
        run.overrides.insert(run.overrides.begin() + 1, "seed=" + std::to_string(flight.realistic_seed));
      }
      run.run_dir = (out_dir / run.name).string();
      runs.push_back(run);
    }
  }
  std::vector<size_t> flown;  // the runs whose scenario can be evaluated; the others fail before flying
  for (size_t i = 0; i < runs.size(); ++i) {
    FlightRun& run = runs[i];
    try {
      const bridge::Scenario scenario = bridge::LoadScenario(run.flight->scenario, run.overrides);
      run.fidelity = scenario.fidelity;
      if (ReadRunEvaluation(scenario).empty()) {
        run.error = "the scenario has no evaluation section";
      }
    } catch (const bridge::ConfigError& e) {
      run.error = std::string("invalid configuration: ") + e.what();
    }
    if (!run.error.empty()) {
      run.run_dir.clear();
      continue;
    }
    fs::remove_all(run.run_dir);  // an earlier regress's run, with the same --out
    fs::create_directories(run.run_dir);
    flown.push_back(i);
    children.push_back(ChildRun{run.flight->scenario, run.overrides, run.run_dir});
  }
  std::vector<bool> landed(runs.size());  // or failed before flying
  for (size_t i = 0; i < runs.size(); ++i) landed[i] = !runs[i].error.empty();
  int failures = 0;
  size_t reported = 0;
  const auto report_landed = [&] {
    for (; reported < runs.size() && landed[reported]; ++reported) failures += Report(runs[reported], report);
  };
  std::printf("%-28s %-40s %12s %14s  %s\n", "flight", "metric", "value", "bound", "result");
  report_landed();
  const InterruptFlag interrupt;
  RunChildren(children, jobs, InterruptFlag::raised, [&](size_t c, const ChildExit& exit) {
    FlightRun& run = runs[flown[c]];
    Landed(&run, exit);
    if (exit.exit_code == 130) InterruptFlag::raised = 1;  // stopped on its own: the others stop too
    landed[flown[c]] = true;
    report_landed();
  });
  *interrupted = InterruptFlag::raised != 0;
  return failures;
}

// Each flight `draws` times with seeds 1..draws, as a sweep over the seeds (tools/sweep.h) on the local pool
// or on Slurm, in OUT/FLIGHT/draw-SEED (a finished draw's bag deleted unless kept; a failed draw keeps it; a
// draw finished by an earlier invocation with the same --out is not flown again); the monte_carlo bounds hold
// for the 95th percentile of a metric (an upper bound) or its 5th (a lower bound), every draw must fly, and
// at least task_success_min of the draws must meet the flight's own contact bounds (its realistic ones when
// the draws fly realistic).
int RegressMonteCarlo(const std::vector<Flight>& flights, const std::vector<std::string>& overrides,
                      const std::string& fidelity, int draws, bool keep_bags, const SweepExecution& how,
                      const fs::path& out_dir, nlohmann::json* report, bool* interrupted) {
  int failures = 0;
  for (const Flight& flight : flights) {
    nlohmann::json& entry = (*report)[flight.name];
    const std::string flown = flight.ProfileFor(fidelity);
    entry["fidelity"] = flown;
    std::vector<nlohmann::json> metrics;
    std::vector<std::string> csvs;
    // the flight's contact bounds in the profile flown: what doing its task means
    const std::vector<Bound>& own =
        fidelity == "realistic" && !flight.realistic_bounds.empty() ? flight.realistic_bounds : flight.bounds;
    std::vector<Bound> task;
    std::copy_if(own.begin(), own.end(), std::back_inserter(task),
                 [](const Bound& bound) { return bound.analysis == "contact"; });
    int task_successes = 0;

    SweepSpec spec;
    spec.name = flight.name;
    spec.scenario = fs::absolute(flight.scenario).lexically_normal().string();
    // the profile first, so that the suite's Monte Carlo keys and --set lie over it
    spec.overrides = overrides;
    spec.overrides.insert(spec.overrides.begin(), "fidelity=" + flown);
    spec.keep_bags = keep_bags;
    try {  // a draw's plots are the band plot's
      const bridge::Scenario scenario = bridge::LoadScenario(flight.scenario, spec.overrides);
      entry["fidelity"] = scenario.fidelity;  // a --set fidelity=... included
      const RunEvaluation evaluation = ReadRunEvaluation(scenario);
      if (evaluation.empty())
        throw bridge::ConfigError(flight.scenario + ": the scenario has no evaluation section");
      if (evaluation.tracking) spec.overrides.push_back("evaluation.tracking.plots=false");
      if (evaluation.contact) spec.overrides.push_back("evaluation.contact.plots=false");
    } catch (const bridge::ConfigError& e) {  // every draw would fail the same way
      std::printf("%-28s draws: FAILED: %s\n", flight.name.c_str(), e.what());
      entry["error"] = e.what();
      ++failures;
      continue;
    }
    for (int seed = 1; seed <= draws; ++seed) spec.seeds.push_back(static_cast<uint64_t>(seed));
    std::vector<SweepRun> runs = ExpandSweep(spec);
    for (SweepRun& run : runs) run.dir = "draw-" + std::to_string(*run.seed);
    bool stopped = false, submitted = true;
    const std::vector<SweepOutcome> outcomes =
        RunSweep(spec, runs, out_dir / flight.name, how, &stopped, &submitted);
    if (!submitted) {
      entry["error"] = "the draws could not be submitted to Slurm";
      ++failures;
      continue;
    }
    for (const SweepRun& run : runs) {
      const int seed = static_cast<int>(*run.seed);
      const SweepOutcome& outcome = outcomes[run.index];
      const std::string run_dir = (out_dir / flight.name / run.dir).string();
      if (!outcome.Finished()) {
        const std::string error = outcome.status + (outcome.reason.empty() ? "" : ": " + outcome.reason);
        std::printf("%-28s draw %d/%d (seed %d): FAILED: %s\n", flight.name.c_str(), seed, draws, seed,
                    error.c_str());
        entry["failed_draws"].push_back({{"seed", seed}, {"error", error}, {"run_dir", run_dir}});
        ++failures;
        continue;
      }
      const nlohmann::json run_metrics = EvaluationSections(outcome.metrics);
      if (run_metrics.contains("tracking")) {  // a line a draw: its largest errors per axis
        const nlohmann::json& tracking = run_metrics.at("tracking");
        std::string line;
        using Axes = std::vector<std::string>;
        for (const auto& [section, axes, unit] :
             {std::tuple{"position_max_m", Axes{"x", "y", "z"}, " m"},
              {"attitude_max_deg", Axes{"roll", "pitch", "yaw"}, " deg"}}) {
          line += std::string(" ") + (axes[0] == "x" ? "x y z" : "roll pitch yaw") + " [";
          for (const std::string& axis : axes) {
            const nlohmann::json value = tracking[section].value(axis, nlohmann::json());
            char number[32];
            std::snprintf(number, sizeof number, value.is_number() ? " %.3g" : " -",
                          value.is_number() ? value.get<double>() : 0.0);
            line += number;
          }
          line += std::string(" ]") + unit;
        }
        std::printf("%-28s draw %d/%d (seed %d): max |error|%s\n", flight.name.c_str(), seed, draws, seed,
                    line.c_str());
        csvs.push_back(tracking["csv"].get<std::string>());
      } else {
        std::printf("%-28s draw %d/%d (seed %d): flown\n", flight.name.c_str(), seed, draws, seed);
      }
      metrics.push_back(run_metrics);
      if (std::all_of(task.begin(), task.end(),
                      [&](const Bound& bound) { return Holds(Value(run_metrics, bound), bound); })) {
        ++task_successes;
      }
    }
    if (stopped) return *interrupted = true, failures;
    entry["draws"] = draws;
    for (int seed = 1; seed <= draws; ++seed) entry["seeds"].push_back(seed);
    if (metrics.empty()) continue;
    const nlohmann::json statistics = MetricStatistics(metrics);
    for (const auto& [analysis, section] : statistics.items()) entry[analysis] = section;
    if (!task.empty()) {  // a draw that failed to fly did not do its task
      const double rate = static_cast<double>(task_successes) / draws;
      entry["task_success_rate"] = rate;
      Bound bound{"", "task_success_rate", "", kUnchecked, flight.task_success_min};
      if (!Check(flight.name, "task_success_rate", rate, bound, &entry["checks"])) ++failures;
    }
    if (flight.monte_carlo_bounds.empty() && task.empty()) {
      std::printf("%-28s no monte_carlo bounds: percentiles reported, nothing checked\n",
                  flight.name.c_str());
    }
    for (const Bound& bound : flight.monte_carlo_bounds) {
      const bool upper = !std::isnan(bound.max);
      const std::string percentile = upper ? "p95" : "p5";
      const auto pointer = bound.Pointer() / percentile;
      const double value = statistics.contains(pointer) ? statistics[pointer].get<double>() : kUnchecked;
      if (!Check(flight.name, bound.Metric() + " " + percentile, value, bound, &entry["checks"])) ++failures;
    }
    const fs::path flight_dir = out_dir / flight.name;
    std::ofstream(flight_dir / "metrics.json") << entry.dump(2) << "\n";
    if (!csvs.empty()) {
      const fs::path plot = flight_dir / "monte_carlo_error.png";
      std::vector<std::string> args{plot.string(), flight.name};
      args.insert(args.end(), csvs.begin(), csvs.end());
      if (RunPlotScript(IAPSIM_PLOT_MONTE_CARLO, args)) entry["plot"] = plot.string();
    }
    std::printf("%-28s percentiles over %zu draws in %s/metrics.json\n", flight.name.c_str(), metrics.size(),
                flight_dir.c_str());
  }
  return failures;
}

}  // namespace

int Regress(const RegressArgs& args) {
  Suite suite;
  try {
    suite = ReadSuite(args.suite_dir);
  } catch (const bridge::ConfigError& e) {
    std::cerr << "iapsim: invalid suite: " << e.what() << std::endl;
    return 2;
  }
  for (const auto& only : args.only) {
    if (std::none_of(suite.flights.begin(), suite.flights.end(),
                     [&](const Flight& f) { return f.name == only; })) {
      std::cerr << "iapsim: no flight '" << only << "' in " << args.suite_dir << "/suite.yaml" << std::endl;
      return 2;
    }
  }
  const fs::path out_dir =
      args.out_dir.empty() ? fs::path("runs") / ("regress-" + bridge::UtcStamp()) : fs::path(args.out_dir);
  fs::create_directories(out_dir);
  const std::vector<Flight> flights = Selected(suite.flights, args.only);

  // the suite's Monte Carlo settings, then the command line's --set (each Monte Carlo flight puts its
  // profile first)
  std::vector<std::string> overrides{"mode=lockstep"};
  const std::string monte_carlo_fidelity = args.fidelity.empty() ? "realistic" : args.fidelity;
  if (args.monte_carlo == 0 && args.execution.slurm) {
    std::cerr << "iapsim: --slurm spreads the draws of --monte-carlo N; without it the flights fly on this "
                 "machine"
              << std::endl;
    return 2;
  }
  if (args.monte_carlo > 0) {
    if (args.fidelity == "both") {
      std::cerr << "iapsim: --monte-carlo flies one profile: --fidelity ideal or realistic" << std::endl;
      return 2;
    }
    overrides.insert(overrides.end(), suite.monte_carlo_overrides.begin(), suite.monte_carlo_overrides.end());
  }
  overrides.insert(overrides.end(), args.overrides.begin(), args.overrides.end());
  const std::vector<std::string> profiles = args.fidelity.empty() || args.fidelity == "both"
                                                ? std::vector<std::string>{"ideal", "realistic"}
                                                : std::vector<std::string>{args.fidelity};

  nlohmann::json report;
  bool interrupted = false;
  const SharedPlotServer plots;  // the flights' and the draws' plots: one Python for them all
  const int failures = args.monte_carlo > 0
                           ? RegressMonteCarlo(flights, overrides, monte_carlo_fidelity, args.monte_carlo,
                                               args.keep_bags, args.execution, out_dir, &report, &interrupted)
                           : RegressOnce(flights, profiles, overrides, LocalJobs(args.execution.jobs),
                                         out_dir, &report, &interrupted);
  const fs::path report_path = out_dir / "regress.json";
  std::ofstream(report_path) << report.dump(2) << "\n";
  if (interrupted) {
    std::printf("\ninterrupted; what ran is under %s\n", out_dir.c_str());
    return 130;
  }
  std::printf("\n%s: %d regression%s; runs and plots under %s\n", failures == 0 ? "PASS" : "FAIL", failures,
              failures == 1 ? "" : "s", out_dir.c_str());
  return failures == 0 ? 0 : 1;
}

}  // namespace iapsim::tools
