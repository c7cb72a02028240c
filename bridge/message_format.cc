#include "bridge/message_format.h"

#include <charconv>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string_view>
#include <utility>

namespace iapsim::bridge {
namespace {

constexpr const char* kPoseType = "geometry_msgs/Pose";
constexpr const char* kTransformType = "geometry_msgs/Transform";

// yaml needs .inf/.nan to keep the float type; csv and tum readers (numpy, pandas, python) expect inf/nan
enum class TextStyle { kYaml, kPlain };

// True when `path` lies inside the message or array at `container` (the root "" contains everything).
bool Contains(const std::string& container, const std::string& path) {
  if (container.empty()) return true;
  return path.size() > container.size() && path.compare(0, container.size(), container) == 0 &&
         (path[container.size()] == '.' || path[container.size()] == '[');
}

// Last component of a path, "bodies[1].pose_W" -> "pose_W"; array elements keep their index.
std::string LastComponent(const std::string& path) {
  const auto dot = path.rfind('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

std::string FormatDouble(double value, bool single_precision, TextStyle style) {
  const bool yaml = style == TextStyle::kYaml;
  if (std::isnan(value)) return yaml ? ".nan" : "nan";
  if (std::isinf(value)) return value > 0 ? (yaml ? ".inf" : "inf") : (yaml ? "-.inf" : "-inf");
  char buffer[64];
  // shortest text that reads back to the same value; float32 fields round-trip as floats, not widened doubles
  const auto result = single_precision
                          ? std::to_chars(buffer, buffer + sizeof(buffer), static_cast<float>(value))
                          : std::to_chars(buffer, buffer + sizeof(buffer), value);
  std::string text(buffer, result.ptr);
  // keep integral values looking like floats so yaml and csv readers do not type them as integers
  if (text.find_first_of(".eE") == std::string::npos) text += ".0";
  return text;
}

// Exact decimal seconds from integer nanoseconds; going through a double would lose nanoseconds.
std::string FormatSeconds(int64_t ns) {
  const bool negative = ns < 0;
  // unsigned negation is defined for INT64_MIN too
  const uint64_t magnitude = negative ? 0 - static_cast<uint64_t>(ns) : static_cast<uint64_t>(ns);
  char buffer[48];
  std::snprintf(buffer, sizeof(buffer), "%s%" PRIu64 ".%09" PRIu64, negative ? "-" : "",
                magnitude / 1000000000u, magnitude % 1000000000u);
  return buffer;
}

bool IsValidUtf8(std::string_view s) {
  size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    size_t extra = 0;
    if (c < 0x80) {
      extra = 0;
    } else if (c >= 0xc2 && c <= 0xdf) {
      extra = 1;
    } else if (c >= 0xe0 && c <= 0xef) {
      extra = 2;
    } else if (c >= 0xf0 && c <= 0xf4) {
      extra = 3;
    } else {
      return false;
    }
    if (extra > s.size() - i - 1) return false;
    for (size_t k = 1; k <= extra; ++k) {
      if ((static_cast<unsigned char>(s[i + k]) & 0xc0) != 0x80) return false;
    }
    i += extra + 1;
  }
  return true;
}

bool IsYamlKeyword(const std::string& s) {
  // yaml 1.1 booleans and nulls, compared case-insensitively (a superset of what parsers accept)
  static const char* const kKeywords[] = {"true", "false", "yes", "no", "on", "off", "y", "n", "null", "~"};
  for (const char* keyword : kKeywords) {
    if (s.size() != std::strlen(keyword)) continue;
    bool same = true;
    for (size_t i = 0; i < s.size() && same; ++i) {
      const char c = s[i] >= 'A' && s[i] <= 'Z' ? static_cast<char>(s[i] - 'A' + 'a') : s[i];
      same = c == keyword[i];
    }
    if (same) return true;
  }
  return false;
}

bool NeedsYamlQuotes(const std::string& s) {
  if (s.empty() || IsYamlKeyword(s)) return true;
  if (s.front() == ' ' || s.front() == '\t' || s.back() == ' ' || s.back() == '\t') return true;
  // indicators that cannot start a plain scalar
  if (std::strchr("-?:,[]{}#&*!|>'\"%@`", s.front()) != nullptr) return true;
  // a leading digit, sign or dot may read as a number, date or sexagesimal: quote rather than guess
  if (std::strchr("0123456789+.", s.front()) != nullptr) return true;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    // ':' and '#' can end a plain scalar; flow indicators would break inline lists
    if (c == ':' || c == '#' || c == ',' || c == '[' || c == ']' || c == '{' || c == '}') return true;
    if (u < 0x20 || u == 0x7f) return true;
  }
  return !IsValidUtf8(s);
}

std::string QuoteYaml(const std::string& s) {
  if (!NeedsYamlQuotes(s)) return s;
  // invalid utf-8 cannot appear raw in yaml, so its high bytes are escaped too (shown, not round-tripped)
  const bool escape_high = !IsValidUtf8(s);
  std::string out = "\"";
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c == '\r') {
      out += "\\r";
    } else if (u < 0x20 || u == 0x7f || (escape_high && u >= 0x80)) {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", static_cast<unsigned>(u));
      out += escaped;
    } else {
      out += c;
    }
  }
  out += '"';
  return out;
}

std::string FormatLeaf(const LeafValue& value, const FieldSchema* field, TextStyle style) {
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  if (const auto* i = std::get_if<int64_t>(&value)) return std::to_string(*i);
  if (const auto* u = std::get_if<uint64_t>(&value)) return std::to_string(*u);
  if (const auto* d = std::get_if<double>(&value)) {
    return FormatDouble(*d, field != nullptr && field->kind == FieldKind::kFloat32, style);
  }
  if (const auto* t = std::get_if<TimeNs>(&value)) return FormatSeconds(t->ns);
  const auto& s = std::get<std::string>(value);
  return style == TextStyle::kYaml ? QuoteYaml(s) : s;
}

std::string KindName(FieldKind kind) {
  switch (kind) {
    case FieldKind::kBool:
      return "bool";
    case FieldKind::kInt8:
      return "int8";
    case FieldKind::kUint8:
      return "uint8";
    case FieldKind::kInt16:
      return "int16";
    case FieldKind::kUint16:
      return "uint16";
    case FieldKind::kInt32:
      return "int32";
    case FieldKind::kUint32:
      return "uint32";
    case FieldKind::kInt64:
      return "int64";
    case FieldKind::kUint64:
      return "uint64";
    case FieldKind::kFloat32:
      return "float32";
    case FieldKind::kFloat64:
      return "float64";
    case FieldKind::kString:
      return "string";
    case FieldKind::kTime:
      return "time";
    case FieldKind::kDuration:
      return "duration";
    case FieldKind::kMessage:
      return "message";
  }
  return "unknown";
}

// Finds the schema of the field behind each leaf: the walk reports values, not their declared types,
// and float32 vs float64 or int8 vs uint8 bytes print differently.
class FieldTracker {
 public:
  void Enter(const std::string& path, const MessageSchema& schema) {
    PopTo(path);
    stack_.push_back({path, &schema});
  }

  // `name` is the leaf's name as the walk reports it, "ranges_m[3]" for array elements.
  const FieldSchema* Find(const std::string& path, const std::string& name) {
    PopTo(path);
    if (stack_.empty()) return nullptr;
    const std::string base = name.substr(0, name.find('['));
    for (const auto& field : stack_.back().schema->fields) {
      if (field.name == base) return &field;
    }
    return nullptr;
  }

 private:
  struct Open {
    std::string path;
    const MessageSchema* schema;
  };

  void PopTo(const std::string& path) {
    while (!stack_.empty() && !Contains(stack_.back().path, path)) stack_.pop_back();
  }

  std::vector<Open> stack_;
};

struct YamlNode {
  enum class Kind { kMessage, kArray, kScalar };
  Kind kind = Kind::kMessage;
  std::string name;
  std::string text;  // rendered value of a scalar
  std::vector<YamlNode> children;
};

// Builds a tree from the walk: the walk has no end-of-message events, and empty messages and arrays
// need to know they are empty before their line is written.
class YamlBuilder : public FieldVisitor {
 public:
  explicit YamlBuilder(size_t max_bytes_shown) : max_bytes_shown_(max_bytes_shown) {}

  void BeginMessage(const std::string& path, const MessageSchema& schema) override {
    tracker_.Enter(path, schema);
    if (path.empty()) {
      open_.assign(1, {path, &root_});
      return;
    }
    Add(path, YamlNode{YamlNode::Kind::kMessage, LastComponent(path), "", {}}, true);
  }

  void BeginArray(const std::string& path, size_t count) override {
    YamlNode node{YamlNode::Kind::kArray, LastComponent(path), "", {}};
    node.children.reserve(count);
    Add(path, std::move(node), true);
  }

  void Leaf(const std::string& path, const std::string& name, const LeafValue& value) override {
    const FieldSchema* field = tracker_.Find(path, name);
    Add(path, YamlNode{YamlNode::Kind::kScalar, name, FormatLeaf(value, field, TextStyle::kYaml), {}}, false);
  }

  void Bytes(const std::string& path, const std::string& name, const uint8_t* data, size_t size) override {
    std::string text;
    if (size > max_bytes_shown_) {
      text = "\"<" + std::to_string(size) + " bytes>\"";
    } else {
      const FieldSchema* field = tracker_.Find(path, name);
      const bool is_signed = field != nullptr && field->kind == FieldKind::kInt8;
      text = "[";
      for (size_t i = 0; i < size; ++i) {
        if (i > 0) text += ", ";
        text += is_signed ? std::to_string(static_cast<int8_t>(data[i])) : std::to_string(data[i]);
      }
      text += "]";
    }
    Add(path, YamlNode{YamlNode::Kind::kScalar, name, std::move(text), {}}, false);
  }

  const YamlNode& root() const { return root_; }

 private:
  struct Open {
    std::string path;
    YamlNode* node;
  };

  void Add(const std::string& path, YamlNode node, bool is_container) {
    while (open_.size() > 1 && !Contains(open_.back().path, path)) open_.pop_back();
    // only the innermost open node grows, so pointers to its open ancestors stay valid
    auto& children = open_.back().node->children;
    children.push_back(std::move(node));
    if (is_container) open_.push_back({path, &children.back()});
  }

  size_t max_bytes_shown_;
  FieldTracker tracker_;
  YamlNode root_;
  std::vector<Open> open_;
};

class YamlEmitter {
 public:
  std::string Emit(const YamlNode& root) {
    if (root.children.empty()) return "{}\n";
    Fields(root, 0);
    return std::move(out_);
  }

 private:
  void Fields(const YamlNode& message, int indent) {
    for (const auto& child : message.children) Field(child, indent);
  }

  void Field(const YamlNode& node, int indent) {
    Indent(indent);
    out_ += node.name;
    out_ += ':';
    switch (node.kind) {
      case YamlNode::Kind::kScalar:
        out_ += ' ';
        out_ += node.text;
        out_ += '\n';
        return;
      case YamlNode::Kind::kMessage:
        if (node.children.empty()) {
          out_ += " {}\n";
          return;
        }
        out_ += '\n';
        Fields(node, indent + 2);
        return;
      case YamlNode::Kind::kArray:
        Array(node, indent);
        return;
    }
  }

  void Array(const YamlNode& node, int indent) {
    if (node.children.empty()) {
      out_ += " []\n";
      return;
    }
    if (node.children.front().kind == YamlNode::Kind::kScalar) {
      out_ += " [";
      for (size_t i = 0; i < node.children.size(); ++i) {
        if (i > 0) out_ += ", ";
        out_ += node.children[i].text;
      }
      out_ += "]\n";
      return;
    }
    out_ += '\n';
    for (const auto& element : node.children) {
      // the element's first line carries the "- " marker in place of its last two spaces of indent
      dash_ = true;
      if (element.children.empty()) {
        Indent(indent + 4);
        out_ += "{}\n";
      } else {
        Fields(element, indent + 4);
      }
    }
  }

  void Indent(int indent) {
    if (dash_) {
      out_.append(static_cast<size_t>(indent - 2), ' ');
      out_ += "- ";
      dash_ = false;
    } else {
      out_.append(static_cast<size_t>(indent), ' ');
    }
  }

  std::string out_;
  bool dash_ = false;
};

class Flattener : public FieldVisitor {
 public:
  explicit Flattener(FlatMessage* out) : out_(out) {}

  void BeginMessage(const std::string& path, const MessageSchema& schema) override {
    tracker_.Enter(path, schema);
  }

  void Leaf(const std::string& path, const std::string& name, const LeafValue& value) override {
    out_->columns.push_back(path);
    out_->values.push_back(FormatLeaf(value, tracker_.Find(path, name), TextStyle::kPlain));
  }

  void Bytes(const std::string& path, const std::string&, const uint8_t*, size_t size) override {
    out_->columns.push_back(path);
    out_->values.push_back(std::to_string(size));
  }

 private:
  FlatMessage* out_;
  FieldTracker tracker_;
};

bool IsPoseType(const std::string& datatype) { return datatype == kPoseType || datatype == kTransformType; }

class PoseFinder : public FieldVisitor {
 public:
  PoseFinder(std::string pose_field, std::string stamp_path)
      : pose_field_(std::move(pose_field)), stamp_path_(std::move(stamp_path)) {}

  void BeginMessage(const std::string& path, const MessageSchema& schema) override {
    tracker_.Enter(path, schema);
    if (matched_) return;
    if (pose_field_.empty() ? IsPoseType(schema.datatype) : path == pose_field_) {
      matched_ = true;
      matched_type_ = schema.datatype;
      target_ = path;
    }
  }

  void BeginArray(const std::string& path, size_t) override {
    if (!matched_ && !pose_field_.empty() && path == pose_field_) Mismatch("an array");
  }

  void Leaf(const std::string& path, const std::string& name, const LeafValue& value) override {
    if (!stamp_path_.empty() && path == stamp_path_) {
      if (const auto* t = std::get_if<TimeNs>(&value)) stamp_ns_ = t->ns;
    }
    if (!matched_ && !pose_field_.empty() && path == pose_field_) {
      const FieldSchema* field = tracker_.Find(path, name);
      Mismatch("a " + (field != nullptr ? KindName(field->kind) : std::string("scalar")) + " field");
      return;
    }
    if (!IsPoseType(matched_type_) || !Contains(target_, path)) return;
    const auto* number = std::get_if<double>(&value);
    if (number == nullptr) return;
    const std::string rest = target_.empty() ? path : path.substr(target_.size() + 1);
    Store(rest, *number);
  }

  void Bytes(const std::string& path, const std::string&, const uint8_t*, size_t) override {
    if (!matched_ && !pose_field_.empty() && path == pose_field_) Mismatch("a byte array");
  }

  bool matched() const { return matched_; }
  const std::string& matched_type() const { return matched_type_; }
  const std::optional<int64_t>& stamp_ns() const { return stamp_ns_; }
  const StampedPose& pose() const { return pose_; }

 private:
  void Mismatch(const std::string& what) {
    matched_ = true;
    matched_type_ = what;
  }

  void Store(const std::string& rest, double value) {
    const auto dot = rest.find('.');
    if (dot == std::string::npos || rest.size() != dot + 2) return;
    const std::string part = rest.substr(0, dot);
    const char axis = rest[dot + 1];
    if (part == "position" || part == "translation") {
      if (axis >= 'x' && axis <= 'z') pose_.position[axis - 'x'] = value;
    } else if (part == "orientation" || part == "rotation") {
      if (axis >= 'x' && axis <= 'z') pose_.orientation_xyzw[axis - 'x'] = value;
      if (axis == 'w') pose_.orientation_xyzw[3] = value;
    }
  }

  std::string pose_field_;
  std::string stamp_path_;
  FieldTracker tracker_;
  bool matched_ = false;
  std::string matched_type_;  // datatype of the matched message, or a description of a non-message field
  std::string target_;
  std::optional<int64_t> stamp_ns_;
  StampedPose pose_;
};

void AppendCsvField(const std::string& value, std::string* line) {
  // rfc 4180: quote fields holding a separator, a quote or a line break, doubling inner quotes
  if (value.find_first_of(",\"\r\n") == std::string::npos) {
    *line += value;
    return;
  }
  *line += '"';
  for (const char c : value) {
    if (c == '"') *line += '"';
    *line += c;
  }
  *line += '"';
}

std::string DescribeColumnDifference(const std::vector<std::string>& header,
                                     const std::vector<std::string>& row) {
  size_t i = 0;
  while (i < header.size() && i < row.size() && header[i] == row[i]) ++i;
  const std::string counts =
      " (" + std::to_string(row.size()) + " columns, header has " + std::to_string(header.size()) + ")";
  // csv column numbers are 1-based and time_s is column 1
  const std::string where = "column " + std::to_string(i + 2);
  if (i < header.size() && i < row.size()) {
    return where + " is '" + row[i] + "' where the header has '" + header[i] + "'" + counts;
  }
  if (i < row.size()) return "extra " + where + " '" + row[i] + "'" + counts;
  return "missing " + where + " '" + header[i] + "'" + counts;
}

}  // namespace

std::string FormatYaml(const SchemaSet& schema, const uint8_t* data, size_t size, size_t max_bytes_shown) {
  YamlBuilder builder(max_bytes_shown);
  schema.Walk(data, size, builder);
  return YamlEmitter().Emit(builder.root());
}

FlatMessage Flatten(const SchemaSet& schema, const uint8_t* data, size_t size) {
  FlatMessage flat;
  Flattener flattener(&flat);
  schema.Walk(data, size, flattener);
  return flat;
}

std::vector<std::string> SplitCsvLine(const std::string& line, bool* unterminated) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else if (c != '\r') {
      fields.back() += c;
    }
  }
  if (unterminated) *unterminated = quoted;
  return fields;
}

void CsvWriter::Write(int64_t record_time_ns, const FlatMessage& message) {
  if (message.columns.size() != message.values.size()) {
    throw std::invalid_argument("CSV row " + std::to_string(rows_ + 1) + ": " +
                                std::to_string(message.columns.size()) + " columns but " +
                                std::to_string(message.values.size()) + " values");
  }
  std::string text;
  if (rows_ == 0) {
    header_ = message.columns;
    text = "time_s";
    for (const auto& column : header_) {
      text += ',';
      AppendCsvField(column, &text);
    }
    text += '\n';
  } else if (message.columns != header_) {
    throw std::invalid_argument(
        "CSV row " + std::to_string(rows_ + 1) + " (record time " + FormatSeconds(record_time_ns) +
        " s) does not match the header: " + DescribeColumnDifference(header_, message.columns));
  }
  text += FormatSeconds(record_time_ns);
  for (const auto& value : message.values) {
    text += ',';
    AppendCsvField(value, &text);
  }
  text += '\n';
  // one write per row, so a failed row never leaves a partial line behind
  out_.write(text.data(), static_cast<std::streamsize>(text.size()));
  ++rows_;
}

std::optional<StampedPose> ExtractPose(const SchemaSet& schema, const uint8_t* data, size_t size,
                                       int64_t record_time_ns, const std::string& pose_field) {
  const auto& root = schema.root();
  const std::string stamp_path = schema.HeaderStampOffset() >= 0 ? root.fields.front().name + ".stamp" : "";
  PoseFinder finder(pose_field, stamp_path);
  schema.Walk(data, size, finder);
  if (!pose_field.empty()) {
    if (!finder.matched()) {
      throw std::invalid_argument("pose field '" + pose_field + "' does not exist in this " + root.datatype +
                                  " message");
    }
    if (!IsPoseType(finder.matched_type())) {
      throw std::invalid_argument("pose field '" + pose_field + "' of " + root.datatype + " is " +
                                  finder.matched_type() + ", not " + kPoseType + " or " + kTransformType);
    }
  } else if (!finder.matched()) {
    return std::nullopt;
  }
  StampedPose pose = finder.pose();
  pose.time_ns = finder.stamp_ns().value_or(record_time_ns);
  return pose;
}

std::string FormatTum(const StampedPose& pose) {
  std::string line = FormatSeconds(pose.time_ns);
  for (const double v : pose.position) {
    line += ' ';
    line += FormatDouble(v, false, TextStyle::kPlain);
  }
  for (const double v : pose.orientation_xyzw) {
    line += ' ';
    line += FormatDouble(v, false, TextStyle::kPlain);
  }
  return line;
}

}  // namespace iapsim::bridge
