#include "bridge/config.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

namespace iapsim::bridge {

size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

namespace {

std::string JoinKeys(const std::set<std::string>& keys) {
  std::string out;
  for (const auto& k : keys) out += (out.empty() ? "" : ", ") + k;
  return out;
}

}  // namespace

YamlMap::YamlMap(const YAML::Node& node, std::string file, std::string key_path)
    : node_(node), file_(std::move(file)), key_path_(std::move(key_path)), resolved_(YAML::NodeType::Map) {
  if (node_ && !node_.IsNull() && !node_.IsMap()) {
    throw ConfigError(Where(node_) + (key_path_.empty() ? "document" : key_path_) +
                      ": expected a map of keys, got a " + KindOf(node_));
  }
  // yaml-cpp keeps a repeated key and finds the first: the second would be ignored without a word
  if (!node_ || !node_.IsMap()) return;
  std::map<std::string, YAML::Mark> seen;
  for (const auto& entry : node_) {
    const auto [first, inserted] = seen.emplace(entry.first.Scalar(), entry.first.Mark());
    if (inserted) continue;
    const std::string also =
        first->second.is_null() ? "" : " (first at line " + std::to_string(first->second.line + 1) + ")";
    throw ConfigError(Where(entry.first) + PathOf(entry.first.Scalar()) + ": given twice" + also);
  }
}

std::string YamlMap::KindOf(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Map:
      return "map";
    case YAML::NodeType::Sequence:
      return "list";
    case YAML::NodeType::Scalar:
      return "value";
    default:
      return "null value";
  }
}

std::string YamlMap::Where(const YAML::Node& node) const {
  const YAML::Mark mark = node ? node.Mark() : YAML::Mark::null_mark();
  if (mark.is_null()) return file_ + ": ";
  return file_ + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1) + ": ";
}

YAML::Node YamlMap::Child(const std::string& key) const {
  if (!node_ || !node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  const YAML::Node& map = node_;
  for (const auto& entry : map) {
    if (entry.first.Scalar() == key) return entry.second;
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

void YamlMap::Fail(const std::string& key, const std::string& what) const {
  const YAML::Node child = Child(key);
  FailAt(child ? child : node_, key, what);
}

void YamlMap::FailAt(const YAML::Node& node, const std::string& key, const std::string& what) const {
  std::string location = Where(node);
  if (!node.is(node_) && node.Mark().is_null()) location = file_ + ": (set on the command line) ";
  throw ConfigError(location + PathOf(key) + ": " + what);
}

void YamlMap::OptionalChoice(const std::string& key, std::string* value,
                             const std::vector<std::string>& choices) {
  Optional(key, value);
  if (std::find(choices.begin(), choices.end(), *value) == choices.end()) {
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
    Fail(key, "must be one of " + list + ", got '" + *value + "'");
  }
}

YamlMap YamlMap::Map(const std::string& key) {
  known_.insert(key);
  YamlMap child(Child(key), file_, PathOf(key));
  resolved_[key] = child.resolved_;  // nodes share identity: the child fills it in as it is read
  return child;
}

std::vector<std::string> YamlMap::Keys() const {
  std::vector<std::string> keys;
  if (node_ && node_.IsMap()) {
    for (const auto& entry : node_) keys.push_back(entry.first.Scalar());
  }
  return keys;
}

YAML::Node YamlMap::Raw(const std::string& key) {
  known_.insert(key);
  YAML::Node child = Child(key);
  if (child) resolved_[key] = child;
  return child;
}

void YamlMap::Finish() {
  if (!node_ || !node_.IsMap()) return;
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    if (known_.count(key)) continue;
    std::string message = "unknown key";
    const std::set<std::string>& candidates = known_;
    std::string best;
    size_t best_distance = 3;
    for (const auto& c : candidates) {
      const size_t d = EditDistance(key, c);
      if (d < best_distance) best_distance = d, best = c;
    }
    if (!best.empty()) {
      message += " (did you mean '" + best + "'?)";
    } else if (!candidates.empty()) {
      message += "; known keys here: " + JoinKeys(candidates);
    }
    throw ConfigError(Where(entry.first) + PathOf(key) + ": " + message);
  }
}

YAML::Node LoadYamlFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the file");
  std::error_code error;
  if (const auto bytes = std::filesystem::file_size(path, error); !error && bytes > kMaxYamlFileBytes) {
    throw ConfigError(path + ": " + std::to_string(bytes) + " bytes; a configuration file may have at most " +
                      std::to_string(kMaxYamlFileBytes >> 20) + " MiB (is it the right file?)");
  }
  try {
    return YAML::Load(in);
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
                      ": YAML syntax error: " + e.msg);
  }
}

void ApplyOverride(YAML::Node root, const std::string& assignment, const std::string& file) {
  const auto equals = assignment.find('=');
  if (equals == std::string::npos || equals == 0) {
    throw ConfigError(file + ": --set '" + assignment +
                      "': expected KEY=VALUE (for example clock.step_s=0.002)");
  }
  const std::string path = assignment.substr(0, equals);
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(equals + 1));
  } catch (const YAML::Exception& e) {
    throw ConfigError(file + ": --set '" + assignment + "': value is not valid YAML: " + e.msg);
  }
  // walk the dotted path; keys are created as needed and validated with the rest of the file afterwards
  std::vector<std::string> keys;
  size_t start = 0;
  while (true) {
    const auto dot = path.find('.', start);
    keys.push_back(path.substr(start, dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  // a list's entry is named by its index (processes.physics.params.vehicles.1.position_m)
  const auto entry = [&](const YAML::Node& list, const std::string& key) {
    const bool digits = !key.empty() && key.find_first_not_of("0123456789") == std::string::npos;
    if (!digits || std::stoul(key) >= list.size()) {
      throw ConfigError(file + ": --set '" + assignment + "': '" + key + "' names no entry of a list of " +
                        std::to_string(list.size()) + " (expected an index from 0)");
    }
    return std::stoul(key);
  };
  std::vector<YAML::Node> chain{root};
  for (size_t i = 0; i + 1 < keys.size(); ++i) {
    if (chain.back().IsSequence()) {
      chain.push_back(chain.back()[entry(chain.back(), keys[i])]);
      continue;
    }
    YAML::Node next = chain.back()[keys[i]];
    if (!next.IsDefined() || next.IsNull()) next = YAML::Node(YAML::NodeType::Map);
    if (!next.IsMap() && !next.IsSequence()) {
      throw ConfigError(file + ": --set '" + assignment + "': '" + keys[i] +
                        "' is not a map of keys or a list");
    }
    chain.back()[keys[i]] = next;
    chain.push_back(next);
  }
  if (chain.back().IsSequence()) {
    chain.back()[entry(chain.back(), keys.back())] = value;
  } else {
    chain.back()[keys.back()] = value;
  }
}

uint64_t StepsPerPeriod(double rate_hz, double step_s) {
  const double period_steps = 1.0 / (rate_hz * step_s);
  if (!(period_steps >= 1.0 - 1e-9) || std::fabs(period_steps - std::round(period_steps)) > 1e-6) return 0;
  return static_cast<uint64_t>(std::llround(period_steps));
}

std::vector<double> ReadNumberList(YamlMap& map, const std::string& key, const std::vector<size_t>& sizes) {
  const YAML::Node node = map.Raw(key);
  std::string expected;
  for (const size_t n : sizes) expected += (expected.empty() ? "" : " or ") + std::to_string(n);
  if (!node || !node.IsSequence()) map.Fail(key, "expected a list of " + expected + " numbers");
  std::vector<double> values;
  for (size_t i = 0; i < node.size(); ++i) {
    const YAML::Node item = node[i];
    double value = 0.0;
    if (!item.IsScalar() || !YAML::convert<double>::decode(item, value) || !std::isfinite(value)) {
      map.FailAt(
          item, key + "[" + std::to_string(i) + "]",
          "expected a finite number, got " + (item.IsScalar() ? "'" + item.Scalar() + "'" : "a list or map"));
    }
    values.push_back(value);
  }
  if (std::find(sizes.begin(), sizes.end(), values.size()) == sizes.end()) {
    map.Fail(key, "expected " + expected + " numbers, got " + std::to_string(values.size()));
  }
  return values;
}

std::string ReadFilePath(YamlMap& map, const std::string& key, const std::string& relative_to) {
  namespace fs = std::filesystem;
  std::string name;
  map.Required(key, &name);
  const fs::path path(name);
  std::vector<fs::path> candidates{path};
  if (!path.is_absolute())
    candidates = {fs::path(relative_to).parent_path() / path, fs::current_path() / path};
  for (const auto& candidate : candidates) {
    std::error_code error;
    if (fs::is_regular_file(candidate, error)) {
      const std::string absolute = fs::canonical(candidate).string();
      map.SetResolved(key, YAML::Node(absolute));
      return absolute;
    }
  }
  map.Fail(key, "no file '" + name + "' (looked next to " + relative_to + " and in the working folder)");
}

}  // namespace iapsim::bridge
