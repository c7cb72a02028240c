#include "tools/sweep.h"

#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "bridge/config.h"
#include "bridge/launcher.h"
#include "bridge/scenario.h"
#include "tools/batch.h"
#include "tools/child_run.h"
#include "tools/plot_script.h"

namespace iapsim::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// FNV-1a, 64 bits, then MurmurHash3's finaliser so that every input bit reaches the 48 kept: a run's id only
// has to be stable and tell a sweep's runs apart (1,000 runs collide with odds of 2e-9 in 48 bits)
std::string Hash48(const std::string& text) {
  uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdull;
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ull;
  h ^= h >> 33;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return std::string(hex + 4);
}

std::string FlowYaml(const YAML::Node& node) {
  if (node.IsScalar()) return node.Scalar();
  YAML::Emitter out;
  out << YAML::Flow << node;
  return out.c_str();
}

std::string FormatNumber(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", value);
  return text;
}

// "tracking.position_rmse_m.z" or "/tracking/position_rmse_m/z" -> the JSON pointer
std::string MetricPointer(const std::string& metric) {
  if (!metric.empty() && metric[0] == '/') return metric;
  std::string pointer = "/" + metric;
  std::replace(pointer.begin(), pointer.end(), '.', '/');
  return pointer;
}

void ReadRandom(bridge::YamlMap& top, SweepSpec* spec) {
  if (!top.Has("random")) return;
  bridge::YamlMap random = top.Map("random");
  random.Required("draws", &spec->draws);
  if (spec->draws < 1 || spec->draws > 100000) random.Fail("draws", "must be in [1, 100000]");
  random.Optional("seed", &spec->random_seed);
  bridge::YamlMap keys = random.Map("keys");
  for (const std::string& key : keys.Keys()) {
    bridge::YamlMap law = keys.Map(key);
    SweepRandomKey draw{key, "", {}, {}};
    for (const char* name : {"uniform", "normal", "choice"}) {
      if (!law.Has(name)) continue;
      if (!draw.distribution.empty())
        law.Fail(name, "one distribution per key: " + draw.distribution + " or " + name);
      draw.distribution = name;
    }
    if (draw.distribution.empty())
      keys.Fail(key, "expected {uniform: [lo, hi]}, {normal: [mean, sigma]} or {choice: [...]}");
    if (draw.distribution == "choice") {
      const YAML::Node choices = law.Raw("choice");
      if (!choices.IsSequence() || choices.size() == 0)
        law.Fail("choice", "expected a non-empty list of values");
      for (const auto& choice : choices) draw.choices.push_back(FlowYaml(choice));
    } else {
      draw.parameters = bridge::ReadNumberList(law, draw.distribution, {2});
      if (draw.distribution == "uniform" && !(draw.parameters[0] < draw.parameters[1])) {
        law.Fail("uniform", "expected [lo, hi] with lo < hi");
      }
      if (draw.distribution == "normal" && !(draw.parameters[1] > 0.0)) {
        law.Fail("normal", "expected [mean, sigma] with sigma > 0");
      }
    }
    law.Finish();
    spec->random.push_back(draw);
  }
  keys.Finish();
  if (spec->random.empty()) random.Fail("keys", "expected the keys to draw");
  random.Finish();
}

// what a run's outcome is called, from `iapsim run`'s exit code (tools/commands.h)
std::string StatusOf(int exit_code) {
  switch (exit_code) {
    case 0:
      return "completed";
    case 3:
      return "completed_with_losses";
    case 2:
      return "invalid_configuration";
    case 130:
      return "interrupted";
    default:
      return "failed";
  }
}

nlohmann::json OutcomeJson(const SweepRun& run, const SweepOutcome& outcome) {
  nlohmann::json values = nlohmann::json::object();
  for (const auto& [key, value] : run.values) values[key] = value;
  nlohmann::json entry = {{"index", run.index},         {"id", run.id},
                          {"group", run.group},         {"values", values},
                          {"overrides", run.overrides}, {"dir", run.dir},
                          {"status", outcome.status},   {"exit_code", outcome.exit_code},
                          {"reason", outcome.reason},   {"wall_s", outcome.wall_s}};
  entry["seed"] = run.seed ? nlohmann::json(*run.seed) : nlohmann::json();
  return entry;
}

// A run's outcome as recorded in RUN/sweep_run.json (by its task, or an earlier invocation: --resume)
SweepOutcome ReadOutcome(const SweepRun& run, const fs::path& run_dir) {
  SweepOutcome outcome;
  std::ifstream in(run_dir / "sweep_run.json");
  const nlohmann::json entry = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  // a folder named otherwise than by the id (a Monte Carlo draw's) may hold a run of other settings
  if (!entry.is_object() || !entry.contains("exit_code") || entry.value("id", "") != run.id) return outcome;
  outcome.done = true;
  outcome.exit_code = entry["exit_code"].get<int>();
  outcome.status = entry.value("status", StatusOf(outcome.exit_code));
  outcome.reason = entry.value("reason", "");
  outcome.wall_s = entry.value("wall_s", 0.0);
  std::ifstream metrics(run_dir / "metrics.json");
  outcome.metrics = nlohmann::json::parse(metrics, nullptr, false);
  if (outcome.metrics.is_discarded()) outcome.metrics = nlohmann::json();
  return outcome;
}

// The folder is made if missing: a Slurm task killed between clearing its run's folder and making it anew
// leaves none, and the sweep then records that run's failure there.
void WriteJsonAtomically(const fs::path& path, const nlohmann::json& json) {
  fs::create_directories(path.parent_path());
  const fs::path part = path.string() + ".part";
  std::ofstream out(part);
  out << json.dump(2) << "\n";
  out.close();
  if (!out) throw std::runtime_error("cannot write " + part.string() + ": " + std::strerror(errno));
  fs::rename(part, path);
}

std::string Describe(const SweepRun& run) {
  std::string text;
  for (const auto& [key, value] : run.values) text += (text.empty() ? "" : " ") + key + "=" + value;
  if (run.seed) text += (text.empty() ? "" : " ") + std::string("seed=") + std::to_string(*run.seed);
  return text.empty() ? "(the scenario as it is)" : text;
}

// A run that ended with wait status `status`: its outcome from its exit code, its log and its metrics.json,
// recorded in RUN/sweep_run.json (what --resume, and a --slurm sweep waiting for its tasks, read)
SweepOutcome EndRun(const SweepRun& run, const fs::path& run_dir, const ChildExit& exit, bool keep_bags) {
  SweepOutcome outcome;
  outcome.done = true;
  outcome.wall_s = exit.wall_s;
  outcome.exit_code = exit.exit_code;
  outcome.status = StatusOf(exit.exit_code);  // SIGINT before its handler was set: interrupted
  if (!outcome.Finished()) outcome.reason = exit.reason;
  if (outcome.Finished()) {
    std::ifstream metrics(run_dir / "metrics.json");
    outcome.metrics = nlohmann::json::parse(metrics, nullptr, false);
    if (outcome.metrics.is_discarded()) outcome.metrics = nlohmann::json();
    if (!keep_bags) fs::remove(run_dir / "run.bag");
  }
  WriteJsonAtomically(run_dir / "sweep_run.json", OutcomeJson(run, outcome));
  return outcome;
}

// A run as sweep.json lists it (OutcomeJson)
SweepRun RunFromJson(const nlohmann::json& entry) {
  SweepRun run;
  run.index = entry.at("index").get<size_t>();
  run.id = entry.at("id").get<std::string>();
  run.group = entry.at("group").get<std::string>();
  for (const auto& [key, value] : entry.at("values").items())
    run.values.emplace_back(key, value.get<std::string>());
  if (entry.at("seed").is_number()) run.seed = entry["seed"].get<uint64_t>();
  run.overrides = entry.at("overrides").get<std::vector<std::string>>();
  run.dir = entry.value("dir", "runs/" + run.id);
  return run;
}

void PrintEnded(size_t ended, size_t total, const SweepRun& run, const SweepOutcome& outcome) {
  std::printf("[%zu/%zu] %s %s: %s in %.1f s%s%s\n", ended, total, run.id.c_str(), Describe(run).c_str(),
              outcome.status.c_str(), outcome.wall_s, outcome.reason.empty() ? "" : ": ",
              outcome.reason.c_str());
  std::fflush(stdout);
}

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string MarkdownField(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  std::string escaped;
  for (const char c : text) escaped += c == '|' ? std::string("\\|") : std::string(1, c);
  return escaped;
}

// numbers of metrics.json that repeat the run's settings
const std::set<std::string> kSettings = {"/seed", "/duration_s", "/lead_in_s", "/clock_step_s"};

// The metric columns: those the sweep names, else every number the finished runs report outside the
// per-process and loss counters and the settings, in order of first appearance.
std::vector<std::string> MetricColumns(const SweepSpec& spec, const std::vector<SweepOutcome>& outcomes) {
  if (!spec.metrics.empty()) return spec.metrics;
  std::vector<std::string> columns;
  std::set<std::string> seen;
  for (const SweepOutcome& outcome : outcomes) {
    if (!outcome.metrics.is_object()) continue;
    const nlohmann::json flat = outcome.metrics.flatten();  // items() of a temporary would outlive it
    for (const auto& [pointer, value] : flat.items()) {
      if (!value.is_number() || pointer.rfind("/processes/", 0) == 0 || pointer.rfind("/losses/", 0) == 0 ||
          kSettings.count(pointer) > 0) {
        continue;
      }
      if (seen.insert(pointer).second) columns.push_back(pointer);
    }
  }
  return columns;
}

std::optional<double> MetricValue(const SweepOutcome& outcome, const std::string& pointer) {
  if (!outcome.metrics.is_object()) return std::nullopt;
  const nlohmann::json::json_pointer p(pointer);
  if (!outcome.metrics.contains(p) || !outcome.metrics[p].is_number()) return std::nullopt;
  return outcome.metrics[p].get<double>();
}

std::string ColumnName(const std::string& pointer) {
  std::string name = pointer.substr(1);
  std::replace(name.begin(), name.end(), '/', '.');
  return name;
}

std::vector<std::string> SweptKeys(const SweepSpec& spec) {
  std::vector<std::string> keys;
  for (const auto& [key, values] : spec.grid) keys.push_back(key);
  for (const SweepRandomKey& r : spec.random) keys.push_back(r.key);
  return keys;
}

std::string ValueOf(const SweepRun& run, const std::string& key) {
  for (const auto& [k, v] : run.values) {
    if (k == key) return v;
  }
  return "";
}

// DIR/results.csv and .md: a row per run
void WriteResults(const fs::path& dir, const SweepSpec& spec, const std::vector<SweepRun>& runs,
                  const std::vector<SweepOutcome>& outcomes, const std::vector<std::string>& metrics) {
  const std::vector<std::string> keys = SweptKeys(spec);
  std::ofstream csv(dir / "results.csv"), md(dir / "results.md");
  std::vector<std::string> header = {"id", "group"};
  header.insert(header.end(), keys.begin(), keys.end());
  for (const char* c : {"seed", "status", "exit_code", "wall_s"}) header.push_back(c);
  for (const std::string& m : metrics) header.push_back(ColumnName(m));
  header.push_back("reason");
  for (size_t i = 0; i < header.size(); ++i) {
    csv << (i ? "," : "") << CsvField(header[i]);
    md << "| " << MarkdownField(header[i]) << " ";
  }
  csv << "\n";
  md << "|\n";
  for (size_t i = 0; i < header.size(); ++i) md << "|---";
  md << "|\n";
  for (size_t r = 0; r < runs.size(); ++r) {
    const SweepRun& run = runs[r];
    const SweepOutcome& o = outcomes[r];
    std::vector<std::string> csv_row = {run.id, run.group}, md_row;
    for (const std::string& key : keys) csv_row.push_back(ValueOf(run, key));
    // a sweep without seeds: the scenario's, as the run reports it
    const auto seed =
        run.seed ? std::optional<double>(static_cast<double>(*run.seed)) : MetricValue(o, "/seed");
    csv_row.push_back(seed ? FormatNumber(*seed) : "");
    csv_row.push_back(o.status);
    csv_row.push_back(o.done && o.exit_code >= 0 ? std::to_string(o.exit_code) : "");
    char wall[32] = "";
    if (o.done && o.exit_code >= 0) std::snprintf(wall, sizeof wall, "%.2f", o.wall_s);
    csv_row.push_back(wall);
    md_row = csv_row;
    for (const std::string& m : metrics) {
      const auto value = MetricValue(o, m);
      csv_row.push_back(value ? FormatNumber(*value) : "");
      char text[32] = "";
      if (value) std::snprintf(text, sizeof text, "%.4g", *value);
      md_row.push_back(text);
    }
    csv_row.push_back(o.reason);
    md_row.push_back(o.reason);
    for (size_t i = 0; i < csv_row.size(); ++i) {
      csv << (i ? "," : "") << CsvField(csv_row[i]);
      md << "| " << MarkdownField(md_row[i]) << " ";
    }
    csv << "\n";
    md << "|\n";
  }
}

// DIR/summary.csv and .md: a row per group (the runs that differ only by seed), each metric's mean, p50 and
// p95 over the group's finished runs, and its failures with their reasons
void WriteSummary(const fs::path& dir, const SweepSpec& spec, const std::vector<SweepRun>& runs,
                  const std::vector<SweepOutcome>& outcomes, const std::vector<std::string>& metrics) {
  const std::vector<std::string> keys = SweptKeys(spec);
  std::vector<std::string> groups;
  std::map<std::string, std::vector<size_t>> members;
  for (size_t r = 0; r < runs.size(); ++r) {
    if (members[runs[r].group].empty()) groups.push_back(runs[r].group);
    members[runs[r].group].push_back(r);
  }
  std::ofstream csv(dir / "summary.csv"), md(dir / "summary.md");
  csv << "group";
  for (const std::string& key : keys) csv << "," << CsvField(key);
  csv << ",runs,finished,failed";
  for (const std::string& m : metrics) {
    for (const char* stat : {"mean", "p50", "p95"}) csv << "," << CsvField(ColumnName(m) + "." + stat);
  }
  csv << "\n";
  md << "# Sweep " << spec.name << "\n\n"
     << runs.size() << " runs of `" << spec.scenario << "` in " << groups.size()
     << " groups (a group: the runs that differ only by seed). Each metric: mean, p50 and "
     << "p95 over a group's finished runs.\n";
  std::map<std::string, std::map<std::string, std::vector<double>>> values;  // group -> metric -> sorted
  for (const std::string& group : groups) {
    for (const size_t r : members[group]) {
      if (!outcomes[r].Finished()) continue;
      for (const std::string& m : metrics) {
        if (const auto v = MetricValue(outcomes[r], m)) values[group][m].push_back(*v);
      }
    }
    for (auto& [m, v] : values[group]) std::sort(v.begin(), v.end());
  }
  for (const std::string& group : groups) {
    const SweepRun& first = runs[members[group].front()];
    size_t finished = 0, failed = 0;
    for (const size_t r : members[group]) {
      finished += outcomes[r].Finished();
      failed += (outcomes[r].done && !outcomes[r].Finished());
    }
    csv << group;
    for (const std::string& key : keys) csv << "," << CsvField(ValueOf(first, key));
    csv << "," << members[group].size() << "," << finished << "," << failed;
    for (const std::string& m : metrics) {
      const std::vector<double>& v = values[group][m];
      double sum = 0.0;
      for (const double x : v) sum += x;
      for (const double stat :
           {v.empty() ? 0.0 : sum / v.size(), v.empty() ? 0.0 : InterpolatedPercentile(v, 50),
            v.empty() ? 0.0 : InterpolatedPercentile(v, 95)}) {
        csv << "," << (v.empty() ? "" : FormatNumber(stat));
      }
    }
    csv << "\n";
  }
  for (const std::string& m : metrics) {
    md << "\n## " << ColumnName(m) << "\n\n|";
    for (const std::string& key : keys) md << " " << MarkdownField(key) << " |";
    md << " runs | failed | mean | p50 | p95 | min | max |\n|";
    for (size_t i = 0; i < keys.size() + 7; ++i) md << "---|";
    md << "\n";
    for (const std::string& group : groups) {
      const SweepRun& first = runs[members[group].front()];
      const std::vector<double>& v = values[group][m];
      size_t failed = 0;
      for (const size_t r : members[group]) failed += (outcomes[r].done && !outcomes[r].Finished());
      md << "|";
      for (const std::string& key : keys) md << " " << MarkdownField(ValueOf(first, key)) << " |";
      md << " " << members[group].size() << " | " << failed << " |";
      if (v.empty()) {
        md << " | | | | |\n";
        continue;
      }
      double sum = 0.0;
      for (const double x : v) sum += x;
      char row[160];
      std::snprintf(row, sizeof row, " %.4g | %.4g | %.4g | %.4g | %.4g |\n", sum / v.size(),
                    InterpolatedPercentile(v, 50), InterpolatedPercentile(v, 95), v.front(), v.back());
      md << row;
    }
  }
  md << "\n## Runs that did not finish\n\n";
  bool any = false;
  for (size_t r = 0; r < runs.size(); ++r) {
    if (outcomes[r].Finished()) continue;
    any = true;
    md << "- `" << runs[r].id << "` " << MarkdownField(Describe(runs[r])) << ": " << outcomes[r].status;
    if (outcomes[r].done && outcomes[r].exit_code >= 0) md << " (exit " << outcomes[r].exit_code << ")";
    if (!outcomes[r].reason.empty()) md << ": " << MarkdownField(outcomes[r].reason);
    md << "\n";
  }
  if (!any) md << "none\n";
}

}  // namespace

SweepSpec ReadSweep(const std::string& path) {
  const YAML::Node root = bridge::LoadYamlFile(path);
  bridge::YamlMap top(root, path);
  SweepSpec spec;
  spec.file = path;
  spec.name = fs::path(path).stem().string();
  top.Optional("name", &spec.name);
  top.Required("scenario", &spec.scenario);
  const fs::path scenario = fs::path(path).parent_path() / spec.scenario;
  if (!fs::is_regular_file(scenario)) top.Fail("scenario", "no such file: " + scenario.string());
  // absolute: a run's id includes it, and stays the same from whatever folder the sweep is resumed
  spec.scenario = fs::absolute(scenario).lexically_normal().string();
  spec.overrides = ReadSetOverrides(top);

  bridge::YamlMap grid = top.Map("grid");
  for (const std::string& key : grid.Keys()) {
    const YAML::Node values = grid.Raw(key);
    if (!values.IsSequence() || values.size() == 0) grid.Fail(key, "expected a non-empty list of values");
    std::vector<std::string> texts;
    for (const auto& value : values) {
      texts.push_back(FlowYaml(value));
      if (std::count(texts.begin(), texts.end(), texts.back()) > 1) {
        grid.Fail(key, "the value " + texts.back() + " is given twice");
      }
    }
    spec.grid.emplace_back(key, texts);
  }
  grid.Finish();
  ReadRandom(top, &spec);
  for (const SweepRandomKey& r : spec.random) {
    for (const auto& [key, values] : spec.grid) {
      if (key == r.key) top.Fail("random", "'" + key + "' is both in the grid and drawn");
    }
  }

  if (top.Has("seeds")) {
    const YAML::Node seeds = top.Raw("seeds");
    if (!seeds.IsSequence() || seeds.size() == 0) top.Fail("seeds", "expected a non-empty list of seeds");
    for (const auto& node : seeds) {
      uint64_t seed = 0;
      if (!node.IsScalar() || !YAML::convert<uint64_t>::decode(node, seed) || node.Scalar()[0] == '-') {
        top.Fail("seeds", "expected non-negative integers, got '" + FlowYaml(node) + "'");
      }
      if (std::count(spec.seeds.begin(), spec.seeds.end(), seed) > 0) {
        top.Fail("seeds", "the seed " + std::to_string(seed) + " is given twice");
      }
      spec.seeds.push_back(seed);
    }
  }
  if (top.Has("metrics")) {
    const YAML::Node metrics = top.Raw("metrics");
    if (!metrics.IsSequence()) top.Fail("metrics", "expected a list of metrics.json paths (tracking.x.y)");
    for (const auto& node : metrics) spec.metrics.push_back(MetricPointer(FlowYaml(node)));
  }
  if (top.Has("jobs")) top.OptionalInRange("jobs", &spec.jobs, 1, 1024);  // absent: 0, not set
  top.Optional("keep_bags", &spec.keep_bags);
  if (top.Has("slurm")) {
    bridge::YamlMap slurm = top.Map("slurm");
    slurm.Optional("partition", &spec.slurm.partition);
    slurm.Optional("time", &spec.slurm.time);
    slurm.OptionalInRange("cpus_per_run", &spec.slurm.cpus_per_task, 1, 1024);
    if (slurm.Has("sbatch")) {
      const YAML::Node sbatch = slurm.Raw("sbatch");
      if (!sbatch.IsSequence()) slurm.Fail("sbatch", "expected a list of sbatch arguments ([--qos=short])");
      for (const auto& node : sbatch) {
        if (!node.IsScalar() || node.Scalar().rfind("-", 0) != 0) {
          slurm.Fail("sbatch",
                     "expected sbatch options (each starting with -), got '" + FlowYaml(node) + "'");
        }
        spec.slurm.sbatch_args.push_back(node.Scalar());
      }
    }
    slurm.Finish();
  }
  top.Finish();
  return spec;
}

std::vector<SweepRun> ExpandSweep(const SweepSpec& spec) {
  // the grid's points, the last key fastest
  std::vector<std::vector<std::pair<std::string, std::string>>> points(1);
  for (const auto& [key, values] : spec.grid) {
    std::vector<std::vector<std::pair<std::string, std::string>>> next;
    for (const auto& point : points) {
      for (const std::string& value : values) {
        next.push_back(point);
        next.back().emplace_back(key, value);
      }
    }
    points = std::move(next);
  }
  // the draws, one stream for the whole sweep: draw d is the same whatever the grid
  std::vector<std::vector<std::pair<std::string, std::string>>> draws(spec.random.empty() ? 1 : spec.draws);
  std::mt19937_64 rng(spec.random_seed);
  for (auto& draw : draws) {
    for (const SweepRandomKey& r : spec.random) {
      std::string value;
      if (r.distribution == "uniform") {
        value = FormatNumber(std::uniform_real_distribution<double>(r.parameters[0], r.parameters[1])(rng));
      } else if (r.distribution == "normal") {
        value = FormatNumber(std::normal_distribution<double>(r.parameters[0], r.parameters[1])(rng));
      } else {
        value = r.choices[std::uniform_int_distribution<size_t>(0, r.choices.size() - 1)(rng)];
      }
      draw.emplace_back(r.key, value);
    }
  }
  std::vector<std::optional<uint64_t>> seeds;
  for (const uint64_t seed : spec.seeds) seeds.emplace_back(seed);
  if (seeds.empty()) seeds.emplace_back(std::nullopt);

  std::vector<SweepRun> runs;
  std::string common = spec.scenario + "\n";
  for (const std::string& o : spec.overrides) common += o + "\n";
  for (const auto& point : points) {
    for (const auto& draw : draws) {
      SweepRun base;
      base.values = point;
      base.values.insert(base.values.end(), draw.begin(), draw.end());
      // what the group's runs share, keys sorted so that reordering the sweep file keeps the ids
      std::vector<std::string> assignments;
      for (const auto& [key, value] : base.values) assignments.push_back(key + "=" + value);
      std::sort(assignments.begin(), assignments.end());
      std::string settings = common;
      for (const std::string& a : assignments) settings += a + "\n";
      base.group = Hash48(settings);
      for (const auto& seed : seeds) {
        SweepRun run = base;
        run.index = runs.size();
        run.seed = seed;
        run.id = Hash48(settings + (seed ? "seed=" + std::to_string(*seed) : std::string()));
        run.dir = "runs/" + run.id;
        run.overrides = spec.overrides;
        for (const auto& [key, value] : run.values) run.overrides.push_back(key + "=" + value);
        if (seed) run.overrides.push_back("seed=" + std::to_string(*seed));
        runs.push_back(std::move(run));
      }
    }
  }
  return runs;
}

namespace {

// what the runs of one invocation share while they run
struct SweepState {
  const SweepSpec& spec;
  const fs::path& dir;
  const std::vector<SweepRun>& runs;
  std::vector<SweepOutcome>& outcomes;
  size_t ended = 0;  // runs done, in earlier invocations too

  void End(const SweepRun& run, SweepOutcome outcome) {
    outcomes[run.index] = std::move(outcome);
    PrintEnded(++ended, runs.size(), run, outcomes[run.index]);
  }
};

// DIR/slurm/<this>: the sweep was interrupted; a --slurm task that starts after it records its run as
// interrupted without running it
constexpr const char* kInterruptedMark = "interrupted";

nlohmann::json SweepRecord(const SweepState& state, const std::string& backend) {
  nlohmann::json record = {{"name", state.spec.name},
                           {"scenario", state.spec.scenario},
                           {"backend", backend},
                           {"keep_bags", state.spec.keep_bags},
                           {"swept_keys", SweptKeys(state.spec)},
                           {"runs", nlohmann::json::array()}};
  for (const SweepRun& run : state.runs)
    record["runs"].push_back(OutcomeJson(run, state.outcomes[run.index]));
  return record;
}

// `pending` on this machine, `jobs` at a time, each a child `iapsim run`
void RunLocalPool(SweepState& state, const std::vector<size_t>& pending, int jobs) {
  std::vector<ChildRun> children;
  for (const size_t r : pending) {
    const SweepRun& run = state.runs[r];
    children.push_back(ChildRun{state.spec.scenario, run.overrides, state.dir / run.dir});
  }
  RunChildren(children, jobs, InterruptFlag::raised, [&](size_t i, const ChildExit& exit) {
    const SweepRun& run = state.runs[pending[i]];
    state.End(run, EndRun(run, children[i].dir, exit, state.spec.keep_bags));
  });
}

// `pending` as the tasks of one Slurm job array, each `iapsim sweep-task DIR ID`; waits for the array, taking
// each run's outcome as its task records it. False when the array could not be submitted.
bool RunOnSlurm(SweepState& state, const std::vector<size_t>& pending, const SlurmOptions& options) {
  const fs::path slurm_dir = fs::absolute(state.dir / "slurm");  // the cluster's paths: absolute
  fs::create_directories(slurm_dir);
  fs::remove(slurm_dir / kInterruptedMark);  // an earlier, interrupted invocation's
  std::vector<std::string> ids;
  for (const size_t r : pending) ids.push_back(state.runs[r].id);
  const fs::path script = slurm_dir / ("array-" + bridge::UtcStamp() + ".sh");
  std::string job;
  try {
    job = SubmitArray(script, "iapsim-" + state.spec.name, options,
                      {bridge::ExecutableDir() + "/iapsim", "sweep-task", fs::absolute(state.dir).string()},
                      ids, slurm_dir);
  } catch (const SlurmError& e) {
    std::cerr << "iapsim sweep: --slurm: " << e.what() << std::endl;
    return false;
  }
  std::printf("submitted Slurm job array %s (%zu tasks, %s); its tasks' output in %s\n", job.c_str(),
              ids.size(), script.string().c_str(), slurm_dir.string().c_str());
  std::fflush(stdout);

  std::vector<size_t> waiting(pending.size());  // task numbers whose run has no outcome yet
  for (size_t t = 0; t < waiting.size(); ++t) waiting[t] = t;
  const auto take_outcomes = [&] {
    waiting.erase(std::remove_if(waiting.begin(), waiting.end(),
                                 [&](size_t t) {
                                   const SweepRun& run = state.runs[pending[t]];
                                   SweepOutcome outcome = ReadOutcome(run, state.dir / run.dir);
                                   if (!outcome.done) return false;
                                   state.End(run, std::move(outcome));
                                   return true;
                                 }),
                  waiting.end());
  };
  // a controller that does not answer for this long is taken as gone (its runs are failed, --resume reruns
  // them)
  constexpr double kUnreachableS = 60.0;
  constexpr double kPollS = 0.25;  // squeue's load on the controller: 4 small queries a second
  int unanswered_queries = 0;      // in a row, 4 a second
  constexpr double kCancelGraceS = 30.0;
  int polls_since_cancel = 0;
  bool cancelled = false;
  std::string unreachable;
  while (true) {
    take_outcomes();
    if (waiting.empty()) return true;
    if (InterruptFlag::raised && !cancelled) {
      std::printf("interrupted: cancelling Slurm job %s\n", job.c_str());
      std::fflush(stdout);
      // first the mark, then the signals: a task that starts between them, and so misses them, sees it
      std::ofstream(slurm_dir / kInterruptedMark) << "interrupted\n";
      InterruptArray(job);
      cancelled = true;
    }
    // a task that has not ended its run this long after the interrupt is cancelled outright
    if (cancelled && ++polls_since_cancel * kPollS == kCancelGraceS) CancelArray(job);
    std::string error;
    const SlurmJobState job_state = QueryArray(job, &error);
    if (job_state == SlurmJobState::kUnreachable) {
      if (unanswered_queries++ == 0) {
        std::fprintf(stderr, "iapsim sweep: squeue: %s (trying again for %.0f s)\n", error.c_str(),
                     kUnreachableS);
      }
      unreachable = error;
    } else {
      unanswered_queries = 0;
    }
    const bool lost = unanswered_queries * kPollS > kUnreachableS;
    if (job_state == SlurmJobState::kEnded || lost) {
      take_outcomes();  // a task records its outcome before it ends
      for (const size_t t : waiting) {
        const SweepRun& run = state.runs[pending[t]];
        SweepOutcome outcome{true, -1, cancelled ? "interrupted" : "failed", "", 0.0, {}};
        const fs::path output = TaskOutput(slurm_dir, job, t);
        if (lost) {
          outcome.reason = "lost contact with Slurm: " + unreachable;
        } else if (cancelled) {
          outcome.reason = fs::exists(output) ? "cancelled while it ran" : "cancelled before it started";
        } else {
          const std::string last = ReasonFromLog(output);
          outcome.reason = "its Slurm task " + job + "_" + std::to_string(t) +
                           " ended without recording an outcome (killed, out of time, or its node lost)" +
                           (last.empty() ? "" : "; its output ends: " + last);
        }
        WriteJsonAtomically(state.dir / run.dir / "sweep_run.json", OutcomeJson(run, outcome));
        state.End(run, std::move(outcome));
      }
      return true;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(kPollS));
  }
}

}  // namespace

std::vector<SweepOutcome> RunSweep(const SweepSpec& spec, const std::vector<SweepRun>& runs,
                                   const fs::path& dir, const SweepExecution& how, bool* was_interrupted,
                                   bool* submitted) {
  fs::create_directories(dir);
  std::vector<SweepOutcome> outcomes(runs.size());
  std::vector<size_t> pending;
  for (const SweepRun& run : runs) {
    outcomes[run.index] = ReadOutcome(run, dir / run.dir);
    if (!outcomes[run.index].Finished()) {
      outcomes[run.index] = SweepOutcome{};
      pending.push_back(run.index);
      fs::remove_all(dir / run.dir);  // what an unfinished earlier attempt left
      fs::create_directories(dir / run.dir);
    }
  }
  SweepState state{spec, dir, runs, outcomes, runs.size() - pending.size()};
  const std::string backend = how.slurm ? "slurm" : "local";
  // written before any run starts: a sweep killed outright can be resumed, and the Slurm tasks read it
  WriteJsonAtomically(dir / "sweep.json", SweepRecord(state, backend));

  const int jobs = LocalJobs(how.jobs);
  SlurmOptions slurm = how.slurm_options;
  slurm.max_running = how.jobs;  // on Slurm, a limit only when asked: the cluster decides otherwise
  std::printf("sweep %s: %zu runs of %s in %s; %zu finished before, %zu to run, ", spec.name.c_str(),
              runs.size(), spec.scenario.c_str(), dir.string().c_str(), runs.size() - pending.size(),
              pending.size());
  if (how.slurm) {
    std::printf("on Slurm, %d CPU%s each%s\n", slurm.cpus_per_task, slurm.cpus_per_task == 1 ? "" : "s",
                how.jobs > 0 ? (", " + std::to_string(how.jobs) + " at a time").c_str() : "");
  } else {
    std::printf("%d at a time\n", jobs);
  }
  std::fflush(stdout);

  *submitted = true;
  {
    const InterruptFlag interrupt;
    if (!pending.empty()) {
      if (how.slurm) {
        *submitted = RunOnSlurm(state, pending, slurm);
      } else {
        const SharedPlotServer plots;  // the runs' plots: one Python for them all
        RunLocalPool(state, pending, jobs);
      }
    }
    *was_interrupted = InterruptFlag::raised != 0;
  }
  WriteJsonAtomically(dir / "sweep.json", SweepRecord(state, backend));
  return outcomes;
}

int Sweep(const SweepArgs& args) {
  SweepSpec spec;
  std::vector<SweepRun> runs;
  try {
    spec = ReadSweep(args.file);
    // the command line's --set joins the sweep's own set, and so each run's settings (and id)
    spec.overrides.insert(spec.overrides.end(), args.overrides.begin(), args.overrides.end());
    runs = ExpandSweep(spec);
    // every run's scenario keys are checked before any starts: a typo in a grid key fails them all
    for (const SweepRun& run : runs) {
      try {
        bridge::LoadScenario(spec.scenario, run.overrides);
      } catch (const bridge::ConfigError& e) {
        throw bridge::ConfigError("run " + run.id + " (" + Describe(run) + "): " + e.what());
      }
    }
  } catch (const bridge::ConfigError& e) {
    std::cerr << "iapsim sweep: invalid sweep: " << e.what() << std::endl;
    return 2;
  }
  if (args.list) {
    std::printf("%zu runs of %s\n", runs.size(), spec.scenario.c_str());
    for (const SweepRun& run : runs)
      std::printf("%4zu  %s  %s\n", run.index, run.id.c_str(), Describe(run).c_str());
    return 0;
  }
  const fs::path dir = args.out_dir.empty() ? fs::path("sweeps") / (spec.name + "-" + bridge::UtcStamp())
                                            : fs::path(args.out_dir);
  if (args.resume && !fs::exists(dir / "sweep.json")) {
    std::cerr << "iapsim sweep: --resume: no sweep in '" << dir.string() << "' (no sweep.json)" << std::endl;
    return 2;
  }
  if (!args.resume && fs::exists(dir / "sweep.json")) {
    std::cerr << "iapsim sweep: '" << dir.string()
              << "' holds a sweep: --resume to finish it, or another --out" << std::endl;
    return 2;
  }
  fs::create_directories(dir);
  fs::copy_file(args.file, dir / "sweep.yaml", fs::copy_options::overwrite_existing);
  SweepExecution how;
  how.slurm = args.slurm;
  how.jobs = args.jobs > 0 ? args.jobs : spec.jobs;
  how.slurm_options = spec.slurm;
  if (!args.partition.empty()) how.slurm_options.partition = args.partition;
  if (!args.time.empty()) how.slurm_options.time = args.time;
  if (args.cpus_per_run > 0) how.slurm_options.cpus_per_task = args.cpus_per_run;
  bool was_interrupted = false, submitted = true;
  const std::vector<SweepOutcome> outcomes = RunSweep(spec, runs, dir, how, &was_interrupted, &submitted);

  size_t finished = 0;
  for (const SweepOutcome& o : outcomes) finished += o.Finished();
  const std::vector<std::string> metrics = MetricColumns(spec, outcomes);
  WriteResults(dir, spec, runs, outcomes, metrics);
  WriteSummary(dir, spec, runs, outcomes, metrics);
  if (!SweptKeys(spec).empty() && finished > 0) RunPlotScript(IAPSIM_PLOT_SWEEP, {dir.string()});

  std::printf("%zu of %zu runs finished; %s/results.md (a row per run), summary.md (per group), plot_*.png\n",
              finished, runs.size(), dir.string().c_str());
  if (was_interrupted) {
    std::printf("interrupted: `iapsim sweep %s --out %s --resume%s` runs the rest\n", args.file.c_str(),
                dir.string().c_str(), args.slurm ? " --slurm" : "");
    return 130;
  }
  return submitted && finished == runs.size() ? 0 : 1;
}

namespace {
volatile pid_t task_child = 0;
volatile std::sig_atomic_t task_stopped = 0;
// a task's SIGTERM (scancel, the time limit) or SIGINT: the run ends its graph cleanly, as in the local pool
extern "C" void OnTaskSignal(int) {
  task_stopped = 1;
  if (task_child > 0) kill(task_child, SIGINT);
}
}  // namespace

int SweepTask(const std::string& dir, const std::string& id) {
  std::ifstream in(fs::path(dir) / "sweep.json");
  const nlohmann::json sweep = nlohmann::json::parse(in, nullptr, false);
  if (!sweep.is_object() || !sweep.contains("runs") || !sweep.contains("scenario")) {
    std::cerr << "iapsim sweep-task: no sweep in '" << dir << "' (no readable sweep.json)" << std::endl;
    return 2;
  }
  const auto entry = std::find_if(sweep["runs"].begin(), sweep["runs"].end(),
                                  [&](const nlohmann::json& r) { return r.value("id", "") == id; });
  if (entry == sweep["runs"].end()) {
    std::cerr << "iapsim sweep-task: no run '" << id << "' in " << dir << "/sweep.json" << std::endl;
    return 2;
  }
  const SweepRun run = RunFromJson(*entry);
  const fs::path run_dir = fs::path(dir) / run.dir;
  fs::remove_all(run_dir);
  fs::create_directories(run_dir);
  struct sigaction action {};
  action.sa_handler = OnTaskSignal;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  if (task_stopped || fs::exists(fs::path(dir) / "slurm" / kInterruptedMark)) {
    const SweepOutcome outcome{true, 130, "interrupted", "the sweep was interrupted before this run started",
                               0.0,  {}};
    WriteJsonAtomically(run_dir / "sweep_run.json", OutcomeJson(run, outcome));
    PrintEnded(1, 1, run, outcome);
    return outcome.exit_code;
  }
  const Clock::time_point start = Clock::now();
  const pid_t pid = StartChildRun(ChildRun{sweep["scenario"].get<std::string>(), run.overrides, run_dir});
  if (pid < 0) {
    std::cerr << "iapsim sweep-task: fork: " << std::strerror(errno) << std::endl;
    return 1;
  }
  task_child = pid;
  if (task_stopped) kill(pid, SIGINT);  // the signal came between the check and the fork
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      std::cerr << "iapsim sweep-task: waitpid: " << std::strerror(errno) << std::endl;
      return 1;
    }
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  const SweepOutcome outcome =
      EndRun(run, run_dir, ChildExitOf(status, run_dir, wall_s), sweep.value("keep_bags", true));
  PrintEnded(1, 1, run, outcome);
  return outcome.exit_code;
}

}  // namespace iapsim::tools
