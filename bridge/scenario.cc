#include "bridge/scenario.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <set>

namespace iapsim::bridge {
namespace {

ClockMode ParseMode(const std::string& mode) {
  if (mode == "realtime") return ClockMode::kRealtime;
  if (mode == "fast") return ClockMode::kFast;
  return ClockMode::kLockstep;
}

// ZeroMQ would also take an interface or a host name, resolved when each process binds or connects: an
// address is checked here, once, where the message can name the key
void RequireIpv4Address(const YamlMap& map, const std::string& key, const std::string& address) {
  in_addr parsed{};
  if (inet_pton(AF_INET, address.c_str(), &parsed) != 1) {
    map.Fail(key, "expected an IPv4 address such as 10.0.0.2, got '" + address + "'");
  }
}

ProcessRole ParseRole(const std::string& role) {
  if (role == "clock") return ProcessRole::kClock;
  if (role == "observer") return ProcessRole::kObserver;
  return ProcessRole::kParticipant;
}

// The prefixes of the group `name` (a message names `key` of `map` when there is none).
const std::vector<std::string>& GroupPrefixes(const YamlMap& map, const std::string& key,
                                              const std::string& name,
                                              const std::map<std::string, std::vector<std::string>>& groups) {
  const auto group = groups.find(name);
  if (group == groups.end()) {
    std::string known;
    for (const auto& [g, prefixes] : groups) known += (known.empty() ? "" : ", ") + g;
    map.Fail(key, "'" + name +
                      "' is neither a topic prefix (they start with '/') nor a group of recording.groups (" +
                      (known.empty() ? "none" : known) + ")");
  }
  return group->second;
}

// A list of topic prefixes, where a name without the '/' stands for a group's (`groups`, when given).
void ReadTopicList(YamlMap& map, const std::string& key, std::vector<std::string>* topics,
                   const std::map<std::string, std::vector<std::string>>* groups = nullptr) {
  const YAML::Node node = map.Raw(key);
  if (!node) return;
  if (!node.IsSequence()) map.Fail(key, "expected a list of topic prefixes");
  topics->clear();
  for (const auto& item : node) {
    const std::string entry = item.IsScalar() ? item.Scalar() : "";
    if (groups && !entry.empty() && entry[0] != '/') {
      const auto& prefixes = GroupPrefixes(map, key, entry, *groups);
      topics->insert(topics->end(), prefixes.begin(), prefixes.end());
      continue;
    }
    if (entry.empty() || entry[0] != '/') {
      map.Fail(key, "every entry must be a topic prefix starting with '/'" +
                        std::string(groups ? " or a group of recording.groups" : ""));
    }
    topics->push_back(entry);
  }
}

// `after` names processes of the scenario other than the clock owner and itself, without a cycle (which
// would stall the lockstep: each process waiting for the other's ack); `after_previous` the same, with
// cycles allowed (each waits only for acks the clock already waited for)
void CheckStepOrder(const std::vector<ProcessConfig>& processes,
                    const std::map<std::string, YamlMap>& entries) {
  std::map<std::string, const ProcessConfig*> by_name;
  for (const auto& p : processes) by_name[p.name] = &p;
  for (const auto& p : processes) {
    const YamlMap& map = entries.at(p.name);
    for (const auto& peer : p.after) {
      const auto it = by_name.find(peer);
      if (it == by_name.end()) map.Fail("after", "'" + peer + "' is not a process of this scenario");
      if (peer == p.name) map.Fail("after", "a process cannot wait for itself");
      if (it->second->role == ProcessRole::kClock) {
        map.Fail("after", "'" + peer + "' owns the clock: every process already acts after it");
      }
    }
    for (const auto& peer : p.after_previous) {
      const auto it = by_name.find(peer);
      if (it == by_name.end()) map.Fail("after_previous", "'" + peer + "' is not a process of this scenario");
      if (peer == p.name) map.Fail("after_previous", "a process cannot wait for itself");
      if (it->second->role == ProcessRole::kClock || it->second->max_lag_steps > 0) {
        map.Fail("after_previous", "'" + peer +
                                       "' acknowledges no step before the clock's next (the clock owner, "
                                       "or a process that may lag)");
      }
    }
    // depth-first walk of the processes p waits for, directly or not
    std::vector<std::string> stack(p.after.begin(), p.after.end());
    std::set<std::string> seen;
    while (!stack.empty()) {
      const std::string name = stack.back();
      stack.pop_back();
      if (name == p.name) map.Fail("after", "forms a cycle: '" + p.name + "' would wait for itself");
      if (!seen.insert(name).second) continue;
      for (const auto& next : by_name.at(name)->after) stack.push_back(next);
    }
  }
}

// Fills in what `into` lacks from `from`, map by map; a value `into` has (a scalar, a list) stays.
void FillMissing(YAML::Node into, const YAML::Node& from) {
  for (const auto& entry : from) {
    const std::string key = entry.first.Scalar();
    YAML::Node mine = into[key];
    if (!mine.IsDefined() || mine.IsNull()) {
      into[key] = YAML::Clone(entry.second);
    } else if (mine.IsMap() && entry.second.IsMap()) {
      FillMissing(mine, entry.second);
    }
  }
}

// Lays `over` (read from `path`) onto `into`, map by map: a value `over` has (a scalar, a list) replaces
// `into`'s, and a key set to null (`~`) removes `into`'s (a flight that replays commands instead of flying
// the base's trajectory).
void Overlay(YAML::Node into, const YAML::Node& over, const std::string& path, const std::string& key_path) {
  for (const auto& entry : over) {
    const std::string key = entry.first.Scalar();
    YAML::Node mine = into[key];
    if (entry.second.IsNull()) {
      if (!mine.IsDefined() || !into.remove(key)) {
        YamlMap(over, path, key_path).Fail(key, "~ removes a key of the base, which has none here");
      }
    } else if (mine.IsDefined() && mine.IsMap() && entry.second.IsMap()) {
      Overlay(mine, entry.second, path, key_path.empty() ? key : key_path + "." + key);
    } else {
      into[key] = YAML::Clone(entry.second);
    }
  }
}

// `base: FILE`, a scenario beside this one: this scenario is FILE with this file's keys laid over it (a
// data-set scenario plus the processes that consume it, without copying it). The base is validated alone
// first, so that an error in it names its own file.
Scenario Load(const std::string& path, const std::vector<std::string>& overrides,
              std::set<std::string> chain);

YAML::Node WithBase(YAML::Node root, const std::string& path, std::set<std::string> chain) {
  if (!root.IsMap() || !root["base"]) return root;
  YamlMap top(root, path);
  std::string base;
  top.Required("base", &base);
  if (std::filesystem::path(base).has_parent_path()) {
    top.Fail("base", "must be a scenario beside this one (its relative paths are read from this folder)");
  }
  const std::string base_path = (std::filesystem::path(path).parent_path() / base).string();
  chain.insert(std::filesystem::weakly_canonical(path).string());
  if (chain.count(std::filesystem::weakly_canonical(base_path).string()) != 0) {
    top.Fail("base", "'" + base + "' is this scenario or one it is based on (a cycle)");
  }
  Load(base_path, {}, chain);
  YAML::Node merged = WithBase(LoadYamlFile(base_path), base_path, chain);
  root.remove("base");
  Overlay(merged, root, path, "");
  return merged;
}

bool IsYamlFile(const std::string& name) {
  return name.size() > 5 && name.substr(name.size() - 5) == ".yaml";
}

// A profile named NAME is IAPSIM_PROFILE_DIR/NAME.yaml.
std::string ProfilePath(const std::string& name) {
  return std::string(IAPSIM_PROFILE_DIR) + "/" + name + ".yaml";
}

// A profile file with its `base: NAME` (a profile of IAPSIM_PROFILE_DIR) or `base: FILE.yaml` (relative to
// it) laid under it, as a scenario's base is (Overlay: `~` removes one of the base's keys): an arena's
// profile is the outdoor one with other air and another odometry, not a copy of it.
YAML::Node LoadProfile(const std::string& path, std::set<std::string> chain) {
  YAML::Node root = LoadYamlFile(path);
  if (!root.IsMap() || !root["base"]) return root;
  YamlMap top(root, path);
  std::string base;
  top.Required("base", &base);
  const std::string base_path = IsYamlFile(base) ? ReadFilePath(top, "base", path) : ProfilePath(base);
  if (!std::filesystem::exists(base_path)) {
    top.Fail("base", "expected a profile of " + std::string(IAPSIM_PROFILE_DIR) +
                         " (without .yaml) or a profile file ending in .yaml; '" + base + "' is neither");
  }
  chain.insert(std::filesystem::weakly_canonical(path).string());
  if (chain.count(std::filesystem::weakly_canonical(base_path).string()) != 0) {
    top.Fail("base", "'" + base + "' is this profile or one it is based on (a cycle)");
  }
  YAML::Node merged = LoadProfile(base_path, chain);
  root.remove("base");
  Overlay(merged, root, path, "");
  return merged;
}

// `fidelity: NAME` (IAPSIM_PROFILE_DIR/NAME.yaml) or `fidelity: FILE.yaml` (relative to the scenario): each
// process whose exec the profile lists gets the profile's keys for that exec where it does not set them.
void ApplyFidelityProfile(YAML::Node root, const std::string& scenario_path, std::string* fidelity) {
  YamlMap top(root, scenario_path);
  top.Optional("fidelity", fidelity);
  if (*fidelity == "ideal") return;
  std::string path = ProfilePath(*fidelity);
  if (IsYamlFile(*fidelity)) {  // made absolute, so that the run's scenario.resolved.yaml finds it too
    path = ReadFilePath(top, "fidelity", scenario_path);
    *fidelity = path;
    root["fidelity"] = path;
  } else if (!std::filesystem::exists(path)) {
    top.Fail("fidelity", "expected ideal, a profile of " + std::string(IAPSIM_PROFILE_DIR) +
                             " (without .yaml) or a profile file ending in .yaml; '" + *fidelity +
                             "' is neither");
  }
  YamlMap profile(LoadProfile(path, {}), path);
  std::string description;
  profile.Optional("description", &description);
  // a profile's flights may start from a hover settled in its conditions (the scenario's own key wins)
  if (profile.Has("lead_in_s")) {
    double lead_in_s = 0.0;
    profile.OptionalInRange("lead_in_s", &lead_in_s, 0.0, 1e4);
    if (!root["lead_in_s"]) root["lead_in_s"] = lead_in_s;
  }
  const YAML::Node scenario_processes = root["processes"];
  YamlMap by_exec = profile.Map("processes");
  std::set<std::string> found_execs;
  for (const std::string& exec : by_exec.Keys()) {
    const YAML::Node keys = by_exec.Raw(exec);
    if (!keys.IsMap()) by_exec.Fail(exec, "expected the process keys (params, after, ...) this profile sets");
    if (!scenario_processes.IsMap()) continue;  // reported with the rest of the scenario
    for (auto process : scenario_processes) {
      if (!process.second.IsMap() || !process.second["exec"] || process.second["exec"].Scalar() != exec)
        continue;
      // orderings compose: the profile's (a controller reading the sensors' odometry of its step) add to
      // the scenario's own (the same controller reading a replayer's commands), they do not give way
      for (const char* order : {"after", "after_previous"}) {
        YAML::Node mine = process.second[order];
        if (!keys[order] || !keys[order].IsSequence() || !mine.IsSequence()) continue;
        for (const auto& peer : keys[order]) {
          if (std::none_of(mine.begin(), mine.end(),
                           [&](const YAML::Node& n) { return n.Scalar() == peer.Scalar(); })) {
            mine.push_back(peer.Scalar());
          }
        }
      }
      FillMissing(process.second, keys);
      found_execs.insert(exec);
    }
    by_exec.SetResolved(exec, keys);
  }
  // a profile may need a process that only the scenario can give (its vehicle, its rate)
  const YAML::Node requires_execs = profile.Raw("requires");
  if (requires_execs && !requires_execs.IsSequence()) profile.Fail("requires", "expected a list of execs");
  for (const auto& required : requires_execs) {
    const std::string exec = required.Scalar();
    if (found_execs.count(exec) == 0) {
      top.Fail("fidelity",
               "'" + *fidelity + "' (" + path + ") needs a process running " + exec +
                   ": add one to the scenario (configs/regression/three_star_spiral.yaml has one)");
    }
  }
  profile.Finish();
}

// 64-bit FNV-1a, stable across platforms and runs (std::hash is not guaranteed to be)
uint64_t StableHash(const std::string& text, uint64_t seed) {
  uint64_t hash = 1469598103934665603ull ^ seed;
  for (const unsigned char c : text) hash = (hash ^ c) * 1099511628211ull;
  return hash;
}

}  // namespace

const char* ToString(ClockMode mode) {
  switch (mode) {
    case ClockMode::kLockstep:
      return "lockstep";
    case ClockMode::kFast:
      return "fast";
    case ClockMode::kRealtime:
      return "realtime";
  }
  return "?";
}

const char* ToString(ProcessRole role) {
  switch (role) {
    case ProcessRole::kClock:
      return "clock";
    case ProcessRole::kParticipant:
      return "participant";
    case ProcessRole::kObserver:
      return "observer";
  }
  return "?";
}

bool RecordingConfig::Records(const std::string& topic) const {
  const auto starts_with_any = [&](const std::vector<std::string>& prefixes) {
    return std::any_of(prefixes.begin(), prefixes.end(),
                       [&](const std::string& p) { return topic.compare(0, p.size(), p) == 0; });
  };
  return (include.empty() || starts_with_any(include)) && !starts_with_any(exclude);
}

double RecordingConfig::MaxRateHz(const std::string& topic) const {
  double rate_hz = 0.0;
  size_t matched = 0;
  for (const auto& [prefix, hz] : max_rate_hz) {
    if (topic.compare(0, prefix.size(), prefix) == 0 && prefix.size() > matched) {
      rate_hz = hz;
      matched = prefix.size();
    }
  }
  return rate_hz;
}

int64_t Scenario::step_ns() const { return std::llround(clock.step_s * 1e9); }

uint64_t Scenario::last_step() const {
  return static_cast<uint64_t>(std::llround((lead_in_s + duration_s) * 1e9 / static_cast<double>(step_ns())));
}

int64_t Scenario::lead_in_ns() const {
  return std::llround(lead_in_s * 1e9 / static_cast<double>(step_ns())) * step_ns();
}

const ProcessConfig* Scenario::Find(const std::string& process) const {
  for (const auto& p : processes) {
    if (p.name == process) return &p;
  }
  return nullptr;
}

uint64_t Scenario::SeedFor(const std::string& process) const { return StableHash(process, seed); }

Scenario LoadScenario(const std::string& path, const std::vector<std::string>& overrides) {
  return Load(path, overrides, {});
}

namespace {

Scenario Load(const std::string& path, const std::vector<std::string>& overrides,
              std::set<std::string> chain) {
  YAML::Node root = WithBase(LoadYamlFile(path), path, std::move(chain));
  for (const auto& assignment : overrides) ApplyOverride(root, assignment, path);

  Scenario s;
  s.file = path;
  ApplyFidelityProfile(root, path, &s.fidelity);
  YamlMap top(root, path);
  top.Optional("fidelity", &s.fidelity);
  top.Required("name", &s.name);
  top.Optional("description", &s.description);
  std::string mode = "lockstep";
  top.OptionalChoice("mode", &mode, {"lockstep", "fast", "realtime"});
  s.mode = ParseMode(mode);
  top.OptionalInRange("duration_s", &s.duration_s, 1e-6, 1e7);
  top.OptionalInRange("lead_in_s", &s.lead_in_s, 0.0, 1e4);
  top.Optional("seed", &s.seed);

  YamlMap clock = top.Map("clock");
  clock.OptionalInRange("step_s", &s.clock.step_s, 1e-6, 1.0);
  clock.OptionalInRange("ack_timeout_s", &s.clock.ack_timeout_s, 0.01, 3600.0);
  clock.OptionalInRange("realtime_factor", &s.clock.realtime_factor, 1e-3, 1e3);
  clock.Finish();
  using Seconds = std::pair<const char*, double>;
  for (const auto& [key, seconds] :
       {Seconds{"duration_s", s.duration_s}, Seconds{"lead_in_s", s.lead_in_s}}) {
    const double steps = seconds / s.clock.step_s;
    if (std::fabs(steps - std::round(steps)) > 1e-6 * std::max(1.0, steps)) {
      top.Fail(key, "must be a whole number of clock steps (clock.step_s = " +
                        std::to_string(s.clock.step_s) + ")");
    }
  }

  YamlMap bus = top.Map("bus");
  bus.OptionalChoice("transport", &s.bus.transport, {"shm", "ipc", "tcp"});
  bus.OptionalInRange("tcp_base_port", &s.bus.tcp_base_port, 0, 65000);
  bus.Optional("tcp_address", &s.bus.tcp_address);
  RequireIpv4Address(bus, "tcp_address", s.bus.tcp_address);
  if (s.bus.tcp_base_port != 0 && s.bus.tcp_base_port < 1024) {
    bus.Fail("tcp_base_port",
             "must be 0 (free ports) or in [1024, 65000], got " + std::to_string(s.bus.tcp_base_port));
  }
  bus.OptionalInRange("send_hwm", &s.bus.send_hwm, 1, 10000000);
  bus.OptionalInRange("receive_hwm", &s.bus.receive_hwm, 1, 10000000);
  bus.OptionalInRange("spin_us", &s.bus.spin_us, 0, 100000);
  bus.OptionalInRange("shm_queue_max_mib", &s.bus.shm_queue_max_mib, 1, 4096);
  s.bus.message_limits.default_bytes = static_cast<size_t>(s.bus.shm_queue_max_mib) << 20;
  YamlMap limits = bus.Map("max_message_kib");
  for (const auto& key : limits.Keys()) {
    if (key != "default" && (key.empty() || key[0] != '/')) {
      limits.Fail(key, "must be 'default', a topic or a namespace ending in '/' (names start with '/')");
    }
    int kib = 0;
    // a message must fit a connection's queue
    limits.OptionalInRange(key, &kib, 1, s.bus.shm_queue_max_mib * 1024);
    const size_t bytes = static_cast<size_t>(kib) << 10;
    if (key == "default") {
      s.bus.message_limits.default_bytes = bytes;
    } else {
      s.bus.message_limits.topic_bytes[key] = bytes;
    }
  }
  limits.Finish();
  bus.Optional("control_endpoint", &s.bus.control_endpoint);
  YamlMap endpoints = bus.Map("endpoints");
  for (const auto& process : endpoints.Keys()) endpoints.Required(process, &s.bus.endpoints[process]);
  YamlMap observer_endpoints = bus.Map("observer_endpoints");
  for (const auto& process : observer_endpoints.Keys()) {
    observer_endpoints.Required(process, &s.bus.observer_endpoints[process]);
  }
  bus.Finish();

  YamlMap recording = top.Map("recording");
  recording.Optional("enabled", &s.recording.enabled);
  YamlMap groups = recording.Map("groups");
  for (const std::string& name : groups.Keys()) {
    if (name.empty() ||
        name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") != std::string::npos) {
      groups.Fail(name, "group names use lowercase letters, digits and '_'");
    }
    ReadTopicList(groups, name, &s.recording.groups[name]);
  }
  groups.Finish();
  ReadTopicList(recording, "include", &s.recording.include, &s.recording.groups);
  ReadTopicList(recording, "exclude", &s.recording.exclude, &s.recording.groups);
  YamlMap rates = recording.Map("max_rate_hz");
  for (const std::string& key : rates.Keys()) {
    double rate_hz = 0.0;
    rates.OptionalInRange(key, &rate_hz, 1e-3, 1e9);
    if (!key.empty() && key[0] == '/') {
      s.recording.max_rate_hz[key] = rate_hz;
    } else {
      for (const std::string& prefix : GroupPrefixes(rates, key, key, s.recording.groups)) {
        s.recording.max_rate_hz[prefix] = rate_hz;
      }
    }
  }
  rates.Finish();
  recording.OptionalChoice("compression", &s.recording.compression, {"none", "lz4"});
  recording.OptionalInRange("max_lag_steps", &s.recording.max_lag_steps, uint64_t{0}, uint64_t{1000000});
  recording.Finish();

  // what `iapsim run` computes from the recording afterwards; tools/ validates it
  s.evaluation = top.Raw("evaluation");
  if (s.evaluation && !s.evaluation.IsMap())
    top.Fail("evaluation", "expected a map (for example tracking: {...})");

  const YAML::Node processes = top.Raw("processes");
  if (!processes || !processes.IsMap() || processes.size() == 0) {
    top.Fail("processes", "expected a map of process name -> {exec, role, rate_hz, params}");
  }
  YamlMap process_maps = top.Map("processes");
  std::map<std::string, YamlMap> entries;  // for errors found once every process is read
  for (const std::string& name : process_maps.Keys()) {
    if (name.empty() ||
        name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") != std::string::npos) {
      process_maps.Fail(name, "process names use lowercase letters, digits and '_'");
    }
    if (name == kRecorderProcess && s.recording.enabled) {
      process_maps.Fail(name, "'recorder' is added by the launcher when recording.enabled is true");
    }
    ProcessConfig p;
    p.name = name;
    const YAML::Node entry = processes[name];
    p.line = entry.Mark().is_null() ? 0 : entry.Mark().line + 1;
    YamlMap map = process_maps.Map(name);
    map.Required("exec", &p.exec);
    std::string host = "local";
    map.OptionalChoice("host", &host, {"local", "external", "srun"});
    p.host = host == "external" ? ProcessHost::kExternal
             : host == "srun"   ? ProcessHost::kSrun
                                : ProcessHost::kLocal;
    // someone has to start an external process by hand, on another host: minutes, not seconds
    if (p.host == ProcessHost::kExternal) p.startup_timeout_s = 600.0;
    map.Optional("address", &p.address);
    if (!p.address.empty()) {
      RequireIpv4Address(map, "address", p.address);
      if (p.host == ProcessHost::kLocal) {
        map.Fail("address",
                 "only a process with host: external or srun binds an address of its own (the "
                 "others bind bus.tcp_address)");
      }
    }
    map.Optional("slurm_node", &p.slurm_node);
    if (p.host == ProcessHost::kSrun && p.slurm_node.empty()) {
      map.Fail("host", "srun needs slurm_node: the node of the allocation the process runs on");
    }
    if (p.host != ProcessHost::kSrun && !p.slurm_node.empty()) map.Fail("slurm_node", "only for host: srun");
    if ((!p.address.empty() || p.host == ProcessHost::kSrun) && s.bus.transport != "tcp") {
      map.Fail(
          p.address.empty() ? "host" : "address",
          "a process on another host needs bus.transport: tcp (the transport is '" + s.bus.transport + "')");
    }
    std::string role = "participant";
    map.OptionalChoice("role", &role, {"clock", "participant", "observer"});
    p.role = ParseRole(role);
    map.OptionalInRange("rate_hz", &p.rate_hz, 0.0, 1e6);
    map.OptionalInRange("hang_timeout_s", &p.hang_timeout_s, 0.05, 3600.0);
    map.OptionalInRange("startup_timeout_s", &p.startup_timeout_s, 0.1, 3600.0);
    for (auto [key, names] : {std::pair{"after", &p.after}, std::pair{"after_previous", &p.after_previous}}) {
      if (!map.Has(key)) continue;
      const YAML::Node list = map.Raw(key);
      if (!list.IsSequence()) map.Fail(key, "expected a list of process names");
      for (const auto& peer : list) {
        if (!peer.IsScalar()) map.Fail(key, "expected a list of process names");
        names->push_back(peer.Scalar());
      }
      map.SetResolved(key, list);
    }
    p.params = map.Raw("params");
    if (p.params && !p.params.IsMap() && !p.params.IsNull()) map.Fail("params", "expected a map");
    if (!p.params) p.params = YAML::Node(YAML::NodeType::Map);
    map.Finish();

    if (p.rate_hz > 0) {
      if (StepsPerPeriod(p.rate_hz, s.clock.step_s) == 0) {
        map.Fail("rate_hz", "must divide the clock rate " + std::to_string(1.0 / s.clock.step_s) +
                                " Hz (a period of a whole number of clock steps)");
      }
    }
    if (p.role == ProcessRole::kClock) {
      if (!s.clock_owner.empty()) {
        map.Fail("role", "only one process may own the clock ('" + s.clock_owner + "' already does)");
      }
      if (p.rate_hz != 0 && std::fabs(p.rate_hz * s.clock.step_s - 1.0) > 1e-9) {
        map.Fail("rate_hz", "the clock owner runs every clock step; leave rate_hz out");
      }
      s.clock_owner = name;
    }
    entries.emplace(name, map);
    s.processes.push_back(std::move(p));
  }
  if (s.clock_owner.empty()) top.Fail("processes", "no process has role: clock");
  CheckStepOrder(s.processes, entries);
  top.Finish();

  if (s.recording.enabled) {
    ProcessConfig recorder;
    recorder.name = kRecorderProcess;
    recorder.exec = "iapsim_recorder";
    recorder.role = ProcessRole::kObserver;
    recorder.max_lag_steps = s.recording.max_lag_steps;
    recorder.params = YAML::Node(YAML::NodeType::Map);
    s.processes.push_back(recorder);
  }
  s.resolved = top.Resolved();
  return s;
}

}  // namespace

namespace {

// `count` different tcp ports of `address` (this host's) that are free now: each socket is bound to port 0
// (the kernel picks an unused one) and all stay bound until every port is picked, so they differ. The
// processes bind them moments later; a program that takes one in between makes that process fail with a
// bind error naming the endpoint. A process on another host gets one of these too: free here, and most
// likely there (bus.tcp_base_port makes them fixed, for firewalls).
std::vector<int> FreeTcpPorts(size_t count, const std::string& address) {
  std::vector<int> sockets, ports;
  for (size_t i = 0; i < count; ++i) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in bound{};
    bound.sin_family = AF_INET;
    inet_pton(AF_INET, address.c_str(), &bound.sin_addr);
    socklen_t length = sizeof(bound);
    if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&bound), sizeof(bound)) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &length) != 0) {
      const std::string why = std::strerror(errno);
      if (fd >= 0) ::close(fd);
      for (const int s : sockets) ::close(s);
      throw std::runtime_error("bus: no free tcp port on " + address + " (" + why +
                               "); is bus.tcp_address an address of this host? Or set bus.tcp_base_port");
    }
    sockets.push_back(fd);
    ports.push_back(ntohs(bound.sin_port));
  }
  for (const int fd : sockets) ::close(fd);
  return ports;
}

}  // namespace

void AssignEndpoints(Scenario* scenario, const std::string& run_id) {
  YAML::Node bus = scenario->resolved["bus"];
  YAML::Node endpoints(YAML::NodeType::Map), observer_endpoints(YAML::NodeType::Map);
  const std::string& transport = scenario->bus.transport;
  const size_t n = scenario->processes.size();
  // tcp: the processes' ports, their observer ports, then the launcher's control port
  std::vector<int> ports;
  for (size_t i = 0; transport == "tcp" && i < 2 * n + 1; ++i) {
    ports.push_back(scenario->bus.tcp_base_port + static_cast<int>(i));
  }
  if (transport == "tcp" && scenario->bus.tcp_base_port == 0) {
    ports = FreeTcpPorts(2 * n + 1, scenario->bus.tcp_address);
  }
  if (!ports.empty() && ports.back() > 65535) {
    throw std::runtime_error("bus.tcp_base_port " + std::to_string(scenario->bus.tcp_base_port) + ": " +
                             std::to_string(2 * n + 1) +
                             " ports from it (a publisher and an observer port per process, and the "
                             "launcher's) go beyond 65535");
  }
  const auto tcp = [&](const std::string& address, size_t port_index) {
    return "tcp://" + (address.empty() ? scenario->bus.tcp_address : address) + ":" +
           std::to_string(ports[port_index]);
  };
  size_t index = 0;
  for (const auto& p : scenario->processes) {
    // shm and ipc name abstract unix sockets: no files left behind, no path-length limit from a deep run
    // directory
    const std::string name = "iapsim-" + run_id + "-" + p.name;
    const std::string endpoint = transport == "tcp"   ? tcp(p.address, index)
                                 : transport == "shm" ? "shm://" + name
                                                      : "ipc://@" + name;
    scenario->bus.endpoints[p.name] = endpoint;
    endpoints[p.name] = endpoint;
    // shared memory tells observers apart by name (bridge/bus.h)
    if (transport != "shm") {
      const std::string observer_endpoint =
          transport == "tcp" ? tcp(p.address, n + index) : "ipc://@" + name + "-observers";
      scenario->bus.observer_endpoints[p.name] = observer_endpoint;
      observer_endpoints[p.name] = observer_endpoint;
    }
    ++index;
  }
  // tcp: the control channel too, so that a process on another host reaches it (encrypted: CURVE)
  scenario->bus.control_endpoint =
      transport == "tcp" ? tcp("", 2 * n) : "ipc://@iapsim-" + run_id + "-launcher";
  bus["control_endpoint"] = scenario->bus.control_endpoint;
  bus["endpoints"] = endpoints;
  if (transport != "shm") bus["observer_endpoints"] = observer_endpoints;
}

StepSchedule::StepSchedule(const Scenario& scenario) {
  for (const auto& p : scenario.processes) {
    if (p.role == ProcessRole::kClock) continue;
    const uint64_t period = p.rate_hz > 0 ? StepsPerPeriod(p.rate_hz, scenario.clock.step_s) : 1;
    members_.push_back(Member{p.name, p.role, period, p.max_lag_steps});
  }
}

int StepSchedule::IndexOf(const std::string& name) const {
  for (size_t i = 0; i < members_.size(); ++i) {
    if (members_[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

int64_t StepSchedule::AckNeeded(int member, uint64_t k, bool last) const {
  const Member& m = members_[member];
  if (!last && k < m.lag_steps) return -1;
  const uint64_t step = last ? k : k - m.lag_steps;
  return static_cast<int64_t>(step - step % m.period_steps);
}

uint64_t StepSchedule::AckInterval(int member) const {
  const Member& m = members_[member];
  return std::max(m.period_steps, m.lag_steps / 4);
}

bool StepSchedule::Awaited(int member, ClockMode mode) const {
  switch (mode) {
    case ClockMode::kLockstep:
      return true;
    case ClockMode::kFast:
      return members_[member].role == ProcessRole::kParticipant;
    case ClockMode::kRealtime:
      return false;
  }
  return true;
}

}  // namespace iapsim::bridge
