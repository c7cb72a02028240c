#include "bridge/pose_file.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "bridge/config.h"
#include "bridge/message_format.h"

namespace iapsim::bridge {
namespace {

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

bool IsBlank(const std::string& line) { return line.find_first_not_of(" \t") == std::string::npos; }

// Collects the samples of a recorded trajectory file, checking each; errors name the file and the line.
class SampleReader {
 public:
  explicit SampleReader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void Fail(size_t line, const std::string& what) const {
    throw ConfigError(path_ + ":" + std::to_string(line) + ": " + what);
  }

  double Parse(const std::string& text, size_t line, const std::string& column) const {
    const size_t begin = text.find_first_not_of(" \t");
    const size_t end = text.find_last_not_of(" \t");
    const std::string trimmed = begin == std::string::npos ? "" : text.substr(begin, end - begin + 1);
    char* parsed_end = nullptr;
    const double value = std::strtod(trimmed.c_str(), &parsed_end);
    if (trimmed.empty() || parsed_end != trimmed.c_str() + trimmed.size() || !std::isfinite(value)) {
      Fail(line, column + ": expected a finite number, got '" + trimmed + "'");
    }
    return value;
  }

  // values: t, x, y, z, qx, qy, qz, qw
  void Add(size_t line, const std::array<double, 8>& values) {
    TimedPose sample;
    sample.t_s = values[0];
    if (!samples_.empty() && !(sample.t_s > samples_.back().t_s)) {
      Fail(line, "time " + Number(sample.t_s) + " s is not after the previous sample's " +
                     Number(samples_.back().t_s) + " s");
    }
    sample.position_m = Eigen::Vector3d(values[1], values[2], values[3]);
    sample.orientation = Eigen::Quaterniond(values[7], values[4], values[5], values[6]);
    const double norm = sample.orientation.norm();
    // recorders print a few digits; anything further off is not an attitude
    if (!(std::abs(norm - 1.0) <= 1e-3)) {
      Fail(line, "quaternion (qx qy qz qw) has norm " + Number(norm) + ", expected a unit quaternion");
    }
    sample.orientation.normalize();
    samples_.push_back(sample);
  }

  std::vector<TimedPose> Samples() const {
    if (samples_.empty()) throw ConfigError(path_ + ": holds no pose");
    return samples_;
  }

 private:
  std::string path_;
  std::vector<TimedPose> samples_;
};

// Calls `use(line_number, line)` for every line, without a trailing '\r'.
void ForEachLine(const std::string& path, const std::function<void(size_t, const std::string&)>& use) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the file");
  std::string line;
  for (size_t number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    use(number, line);
  }
}

// TUM: "t x y z qx qy qz qw" per line, '#' comments.
std::vector<TimedPose> ReadTum(const std::string& path) {
  SampleReader reader(path);
  ForEachLine(path, [&](size_t number, const std::string& line) {
    if (IsBlank(line) || line[line.find_first_not_of(" \t")] == '#') return;
    std::istringstream fields(line);
    std::vector<std::string> tokens;
    for (std::string token; fields >> token;) tokens.push_back(token);
    if (tokens.size() != 8) {
      reader.Fail(number, "expected 8 values (t x y z qx qy qz qw), got " + std::to_string(tokens.size()));
    }
    std::array<double, 8> values;
    for (size_t i = 0; i < 8; ++i) {
      values[i] = reader.Parse(tokens[i], number, "value " + std::to_string(i + 1));
    }
    reader.Add(number, values);
  });
  return reader.Samples();
}

// One CSV line split into fields; a quoted field may not span lines.
std::vector<std::string> SplitCsv(const std::string& line, size_t number, const SampleReader& reader) {
  bool unterminated = false;
  std::vector<std::string> fields = bridge::SplitCsvLine(line, &unterminated);
  if (unterminated) reader.Fail(number, "a quoted field does not end on its line");
  return fields;
}

// "pose.position.x" and "position.x" end with the component "position.x"; "myposition.x" does not
bool EndsWithComponent(const std::string& name, const std::string& component) {
  if (name.size() < component.size() ||
      name.compare(name.size() - component.size(), component.size(), component)) {
    return false;
  }
  return name.size() == component.size() || name[name.size() - component.size() - 1] == '.';
}

// Columns of t, x, y, z, qx, qy, qz, qw: t_s (or time_s) and x_m, y_m, z_m, qx, qy, qz, qw, or else the
// first pose of a topic that `iapsim export --format csv` wrote (time_s, ...position.x .. orientation.w, or
// a transform's translation and rotation).
std::optional<std::array<size_t, 8>> FindPoseColumns(const std::vector<std::string>& header) {
  const auto find = [&](const std::vector<std::string>& names) -> std::optional<std::array<size_t, 8>> {
    std::array<size_t, 8> columns;
    for (size_t i = 0; i < 8; ++i) {
      const auto at = std::find(header.begin(), header.end(), names[i]);
      if (at == header.end()) return std::nullopt;
      columns[i] = static_cast<size_t>(at - header.begin());
    }
    return columns;
  };
  const std::string time = std::find(header.begin(), header.end(), "t_s") != header.end() ? "t_s" : "time_s";
  if (auto named = find({time, "x_m", "y_m", "z_m", "qx", "qy", "qz", "qw"})) return named;
  const std::array<std::pair<std::string, std::string>, 2> kPoseParts{
      {{"position", "orientation"}, {"translation", "rotation"}}};
  for (const std::string& column : header) {
    for (const auto& [position, orientation] : kPoseParts) {
      if (!EndsWithComponent(column, position + ".x")) continue;
      const std::string prefix = column.substr(0, column.size() - position.size() - 2);
      if (auto exported =
              find({time, prefix + position + ".x", prefix + position + ".y", prefix + position + ".z",
                    prefix + orientation + ".x", prefix + orientation + ".y", prefix + orientation + ".z",
                    prefix + orientation + ".w"})) {
        return exported;
      }
    }
  }
  return std::nullopt;
}

std::vector<TimedPose> ReadCsv(const std::string& path) {
  SampleReader reader(path);
  std::vector<std::string> header;
  std::array<size_t, 8> columns{};
  ForEachLine(path, [&](size_t number, const std::string& line) {
    if (IsBlank(line)) return;
    const std::vector<std::string> fields = SplitCsv(line, number, reader);
    if (header.empty()) {
      header = fields;
      const auto found = FindPoseColumns(header);
      if (!found) {
        reader.Fail(number,
                    "the header needs the columns t_s, x_m, y_m, z_m, qx, qy, qz, qw (or time_s and a "
                    "pose, as `iapsim export --format csv` writes them)");
      }
      columns = *found;
      return;
    }
    if (fields.size() != header.size()) {
      reader.Fail(number, "expected " + std::to_string(header.size()) + " fields as in the header, got " +
                              std::to_string(fields.size()));
    }
    std::array<double, 8> values;
    for (size_t i = 0; i < 8; ++i) values[i] = reader.Parse(fields[columns[i]], number, header[columns[i]]);
    reader.Add(number, values);
  });
  return reader.Samples();
}

}  // namespace

std::vector<TimedPose> ReadPoseFile(const std::string& path, const std::string& format) {
  if (format == "tum") return ReadTum(path);
  if (format == "csv") return ReadCsv(path);
  throw std::invalid_argument("pose file format '" + format + "': expected tum or csv");
}

void WriteTumFile(const std::string& path, const std::vector<StampedPose>& poses,
                  const std::string& comment) {
  std::ofstream file(path);
  file << "# " << comment << "\n";
  for (const StampedPose& p : poses) file << FormatTum(p) << "\n";
  if (!file) throw std::runtime_error(path + ": cannot write");
}

}  // namespace iapsim::bridge
