// iapsim_allan: the Allan deviation of the columns of a CSV file (a header line, then rows whose first
// column is the time in seconds, as `iapsim export --format csv` writes them) and the Kalibr noise
// parameters fitted to it.
//
//   iapsim_allan imu.csv [--columns NAME|INDEX ...] [--rate HZ] [--table]
//
// For a static IMU log the fit of the gyroscope columns is gyroscope_noise_density (rad/s/√Hz) and
// gyroscope_random_walk (rad/s²/√Hz), that of the accelerometer columns the accelerometer ones.

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bridge/cli_usage.h"
#include "bridge/message_format.h"
#include "sensors/allan.h"

namespace {

// text columns (a message's frame_id) may sit among the numbers: only the columns asked for are parsed
struct Table {
  std::vector<std::string> names;
  std::vector<std::vector<std::string>> rows;
};

bool ParseNumber(const std::string& text, double* value) {
  try {
    size_t used = 0;
    *value = std::stod(text, &used);
    return text.find_first_not_of(" \t", used) == std::string::npos;
  } catch (const std::exception&) {
    return false;
  }
}

Table ReadCsv(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw std::runtime_error("cannot open " + path);
  Table table;
  std::string line;
  size_t line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    if (line.empty() || line == "\r") continue;
    std::vector<std::string> fields = iapsim::bridge::SplitCsvLine(line);
    if (table.names.empty()) {
      table.names = std::move(fields);
      continue;
    }
    if (fields.size() != table.names.size()) {
      throw std::runtime_error(path + ":" + std::to_string(line_number) + ": " +
                               std::to_string(fields.size()) + " fields, the header has " +
                               std::to_string(table.names.size()));
    }
    table.rows.push_back(std::move(fields));
  }
  if (table.names.size() < 2 || table.rows.size() < 3) {
    throw std::runtime_error(path + ": needs a header, a time column, a value column and at least 3 rows");
  }
  return table;
}

std::vector<double> NumericColumn(const Table& table, size_t column, const std::string& path) {
  std::vector<double> values(table.rows.size());
  for (size_t row = 0; row < table.rows.size(); ++row) {
    if (!ParseNumber(table.rows[row][column], &values[row])) {
      throw std::runtime_error(path + ": row " + std::to_string(row + 1) + " of column '" +
                               table.names[column] + "' is not a number");
    }
  }
  return values;
}

size_t ColumnIndex(const Table& table, const std::string& name_or_index) {
  for (size_t i = 1; i < table.names.size(); ++i) {
    if (table.names[i] == name_or_index) return i;
  }
  double index = 0.0;
  if (ParseNumber(name_or_index, &index) && index >= 1 && index < table.names.size() &&
      index == std::floor(index)) {
    return static_cast<size_t>(index);
  }
  throw std::runtime_error("no value column '" + name_or_index + "'");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("iapsim_allan: overlapping Allan deviation of CSV columns and the Kalibr noise fit");
  std::string path;
  std::vector<std::string> column_names;
  double rate_hz = 0.0;
  bool print_table = false;
  app.add_option("csv", path, "CSV file: a header, then rows of time (s) and values")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--columns", column_names, "value columns by name or index (default: every numeric one)");
  app.add_option("--rate", rate_hz, "sample rate in Hz (default: from the time column)");
  app.add_flag("--table", print_table, "also print σ(τ) of every column");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return iapsim::bridge::AnswerParseError(app, e);
  }

  try {
    const Table table = ReadCsv(path);
    const std::vector<double> time_s = NumericColumn(table, 0, path);
    const size_t count = time_s.size();
    if (rate_hz <= 0.0) {
      const double duration_s = time_s.back() - time_s.front();
      if (!(duration_s > 0.0)) throw std::runtime_error("the time column does not increase; give --rate");
      rate_hz = static_cast<double>(count - 1) / duration_s;
    }
    std::vector<size_t> columns;
    for (const auto& name : column_names) columns.push_back(ColumnIndex(table, name));
    if (columns.empty()) {
      double unused = 0.0;
      for (size_t i = 1; i < table.names.size(); ++i) {
        if (ParseNumber(table.rows[0][i], &unused)) columns.push_back(i);
      }
    }

    std::printf("%s: %zu samples at %.6g Hz (%.6g s)\n", path.c_str(), count, rate_hz,
                static_cast<double>(count) / rate_hz);
    std::printf(
        "noise_density: σ(1 s) of the −1/2 line, unit/√Hz; random_walk: σ(3 s) of the +1/2 line, "
        "unit/s/√Hz\n");
    std::printf("%-32s %16s %16s\n", "column", "noise_density", "random_walk");
    for (const size_t c : columns) {
      const auto points = iapsim::sensors::OverlappingAllanDeviation(NumericColumn(table, c, path), rate_hz);
      const auto fit = iapsim::sensors::FitWhiteNoiseAndRandomWalk(points);
      std::printf("%-32s %16.6e %16.6e\n", table.names[c].c_str(), fit.noise_density, fit.random_walk);
      if (print_table) {
        for (const auto& p : points) std::printf("  tau %12.6g s   sigma %14.6e\n", p.tau_s, p.deviation);
      }
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "iapsim_allan: %s\n", e.what());
    return 2;
  }
}
