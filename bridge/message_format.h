#pragma once
// Text views of messages of any type, driven by their definition: YAML for `iapsim echo`, CSV rows and
// TUM trajectory lines for `iapsim export`.

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "bridge/message_schema.h"

namespace iapsim::bridge {

/// rostopic-echo-like YAML of one message. Byte arrays longer than `max_bytes_shown` are summarized as
/// "<N bytes>"; times print as seconds with 9 decimals. Throws std::invalid_argument on malformed bytes.
std::string FormatYaml(const SchemaSet& schema, const uint8_t* data, size_t size,
                       size_t max_bytes_shown = 16);

/// Flattened leaves in serialization order: column names like "bodies[0].pose_W.position.x" and their text.
/// Byte arrays become one column holding their length.
struct FlatMessage {
  std::vector<std::string> columns;
  std::vector<std::string> values;
};
FlatMessage Flatten(const SchemaSet& schema, const uint8_t* data, size_t size);

/// Writes a topic as CSV: a header row from the first message, then one row per message, first column the
/// record time in seconds. A message whose columns differ from the header (variable-length arrays that
/// changed size) throws std::invalid_argument naming the row, so a CSV never has misaligned columns.
class CsvWriter {
 public:
  explicit CsvWriter(std::ostream& out) : out_(out) {}
  void Write(int64_t record_time_ns, const FlatMessage& message);

 private:
  std::ostream& out_;
  std::vector<std::string> header_;
  uint64_t rows_ = 0;
};

/// Splits one line of a CSV file like CsvWriter's into fields (RFC 4180 quoting: a quoted field may hold
/// commas, "" is a quote; '\r' is dropped). `unterminated` (if given) tells whether a quote was left open:
/// a quoted field may not span lines here.
std::vector<std::string> SplitCsvLine(const std::string& line, bool* unterminated = nullptr);

/// A pose at a time, for TUM trajectory files ("t x y z qx qy qz qw").
struct StampedPose {
  int64_t time_ns = 0;
  double position[3] = {0, 0, 0};
  double orientation_xyzw[4] = {0, 0, 0, 1};
};

/// The first geometry_msgs/Pose (or Transform: translation/rotation) found in the message, in field order,
/// stamped by its header.stamp when it has one, else by `record_time_ns`. `pose_field` selects a particular
/// field path instead ("bodies[0].pose_W"). nullopt when the message holds no pose.
std::optional<StampedPose> ExtractPose(const SchemaSet& schema, const uint8_t* data, size_t size,
                                       int64_t record_time_ns, const std::string& pose_field = "");

/// One TUM line with nanosecond-exact time ("%.9f" seconds) and full double precision.
std::string FormatTum(const StampedPose& pose);

}  // namespace iapsim::bridge
