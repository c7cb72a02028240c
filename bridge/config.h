#pragma once
// Strict YAML configuration reading: every key is known, typed and range-checked, and every error names the
// file, the line and the key. Values read (defaults included) are recorded, so the resolved configuration
// can be written back out exactly as it was used.

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace iapsim::bridge {

/// Bad configuration. what() reads "FILE:LINE:COLUMN: KEY: what was expected".
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A YAML mapping being read into a config struct.
class YamlMap {
 public:
  /// `node` must be a map (or null, read as empty). `file` and `key_path` are for error messages.
  YamlMap(const YAML::Node& node, std::string file, std::string key_path = "");

  /// Reads `key` into `value` when present (keeping `value` as the default otherwise).
  template <class T>
  void Optional(const std::string& key, T* value) {
    known_.insert(key);
    const YAML::Node child = Child(key);
    if (child) *value = Convert<T>(child, key);
    resolved_[key] = *value;
  }

  template <class T>
  void Required(const std::string& key, T* value) {
    if (!Child(key)) Fail(key, "is required");
    Optional(key, value);
  }

  /// Numeric value within [lo, hi].
  template <class T>
  void OptionalInRange(const std::string& key, T* value, T lo, T hi) {
    Optional(key, value);
    if (*value < lo || *value > hi) {
      Fail(key, "must be in [" + YAML::Dump(YAML::Node(lo)) + ", " + YAML::Dump(YAML::Node(hi)) + "], got " +
                    YAML::Dump(YAML::Node(*value)));
    }
  }

  /// One of `choices`.
  void OptionalChoice(const std::string& key, std::string* value, const std::vector<std::string>& choices);

  /// A nested map (empty when absent). Its resolved values appear under `key` in this map's Resolved().
  YamlMap Map(const std::string& key);
  /// Keys of a nested map, in file order.
  std::vector<std::string> Keys() const;
  bool Has(const std::string& key) const { return static_cast<bool>(Child(key)); }
  /// The raw node of a key, marked as known (for sections another component validates).
  YAML::Node Raw(const std::string& key);

  /// Unknown keys are errors (with a spelling suggestion). Call after reading every key.
  void Finish();
  /// Records `value` as the resolved value of `key` (for values the reader completes, such as a path made
  /// absolute, or a list it read from Raw()).
  void SetResolved(const std::string& key, const YAML::Node& value) { resolved_[key] = value; }
  /// What was read, defaults included, in reading order.
  YAML::Node Resolved() const { return resolved_; }

  [[noreturn]] void Fail(const std::string& key, const std::string& what) const;
  /// Fails at `node` (an element of `key`'s value) instead of at the key.
  [[noreturn]] void FailAt(const YAML::Node& node, const std::string& key, const std::string& what) const;
  const std::string& file() const { return file_; }
  std::string PathOf(const std::string& key) const { return key_path_.empty() ? key : key_path_ + "." + key; }

 private:
  YAML::Node Child(const std::string& key) const;
  std::string Where(const YAML::Node& node) const;

  template <class T>
  T Convert(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) Fail(key, "expected " + TypeName<T>() + ", got a " + KindOf(node));
    T out{};
    if (!YAML::convert<T>::decode(node, out)) {
      Fail(key, "expected " + TypeName<T>() + ", got '" + node.Scalar() + "'");
    }
    // one rule for every number: .nan and .inf are never a setting (a NaN timeout or rate would turn a check
    // off rather than fail it)
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(out)) Fail(key, "expected a finite number, got '" + node.Scalar() + "'");
    }
    return out;
  }

  template <class T>
  static std::string TypeName() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    if constexpr (std::is_integral_v<T>) return "an integer";
    if constexpr (std::is_floating_point_v<T>) return "a number";
    return "a string";
  }
  static std::string KindOf(const YAML::Node& node);

  YAML::Node node_;
  std::string file_;
  std::string key_path_;
  std::set<std::string> known_;
  YAML::Node resolved_;
};

/// The list of numbers under `key` (required), with as many entries as one of `sizes`: each must be a finite
/// number, and an error points at the entry ("KEY[1]: expected a finite number, got '.nan'").
std::vector<double> ReadNumberList(YamlMap& map, const std::string& key, const std::vector<size_t>& sizes);

/// Reads the file name under `key` (required) and finds it: absolute, or relative to the folder of
/// `relative_to` (the scenario file), or to the working folder. Records the absolute path as the resolved
/// value (so a run restarts from its scenario.resolved.yaml) and returns it; fails naming the key.
std::string ReadFilePath(YamlMap& map, const std::string& key, const std::string& relative_to);

/// How many steps of `step_s` one period of `rate_hz` spans; 0 when that is not a whole number of at least
/// one (a rate that does not divide the step's rate).
uint64_t StepsPerPeriod(double rate_hz, double step_s);

/// The edits (insertions, deletions, substitutions) that turn `a` into `b` (Levenshtein): how "did you mean"
/// picks the keys and commands closest to a mistyped one.
size_t EditDistance(const std::string& a, const std::string& b);

/// Loads a YAML file; a missing, malformed or oversized (over kMaxYamlFileBytes) file is a ConfigError naming
/// it (and the line of a syntax error).
YAML::Node LoadYamlFile(const std::string& path);
/// yaml-cpp parses about 0.4 MB/s here: a configuration file is kilobytes, and a bigger one is the wrong file
/// (a log, a bag) that would otherwise keep a run from starting for minutes.
inline constexpr uint64_t kMaxYamlFileBytes = 2 << 20;

/// Applies "a.b.c=value" (value parsed as YAML) onto `root`; missing map keys are created (and validated with
/// the rest of the file), a list's entry is named by its index ("vehicles.1.position_m=[0, 1, 2]").
void ApplyOverride(YAML::Node root, const std::string& assignment, const std::string& file);

}  // namespace iapsim::bridge
