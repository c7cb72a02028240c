#include "bridge/message_schema.h"

#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace iapsim::bridge {
namespace {

struct BuiltinType {
  const char* name;
  FieldKind kind;
};

// ROS1 builtin types (genmsg): byte is a deprecated alias of int8, char of uint8.
constexpr BuiltinType kBuiltins[] = {
    {"bool", FieldKind::kBool},         {"int8", FieldKind::kInt8},     {"byte", FieldKind::kInt8},
    {"uint8", FieldKind::kUint8},       {"char", FieldKind::kUint8},    {"int16", FieldKind::kInt16},
    {"uint16", FieldKind::kUint16},     {"int32", FieldKind::kInt32},   {"uint32", FieldKind::kUint32},
    {"int64", FieldKind::kInt64},       {"uint64", FieldKind::kUint64}, {"float32", FieldKind::kFloat32},
    {"float64", FieldKind::kFloat64},   {"string", FieldKind::kString}, {"time", FieldKind::kTime},
    {"duration", FieldKind::kDuration},
};

bool LookupBuiltin(const std::string& name, FieldKind* kind) {
  for (const auto& b : kBuiltins) {
    if (name == b.name) {
      *kind = b.kind;
      return true;
    }
  }
  return false;
}

std::string Trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t\r");
  return s.substr(begin, end - begin + 1);
}

std::string PackageOf(const std::string& datatype) {
  const auto slash = datatype.find('/');
  return slash == std::string::npos ? "" : datatype.substr(0, slash);
}

// Reads serialized bytes with bounds checks; every read failure is an error, never a crash.
class Cursor {
 public:
  Cursor(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool Take(size_t n, const uint8_t** out) {
    if (n > size_ - pos_) return false;
    *out = data_ + pos_;
    pos_ += n;
    return true;
  }
  bool ReadU32(uint32_t* v) {
    const uint8_t* p;
    if (!Take(4, &p)) return false;
    std::memcpy(v, p, 4);  // ROS1 wire format is little-endian, as is every target we build for
    return true;
  }
  size_t pos() const { return pos_; }
  size_t remaining() const { return size_ - pos_; }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

template <class T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

LeafValue ReadLeaf(FieldKind kind, const uint8_t* p) {
  switch (kind) {
    case FieldKind::kBool:
      return LeafValue(p[0] != 0);
    case FieldKind::kInt8:
      return LeafValue(int64_t{Load<int8_t>(p)});
    case FieldKind::kUint8:
      return LeafValue(uint64_t{Load<uint8_t>(p)});
    case FieldKind::kInt16:
      return LeafValue(int64_t{Load<int16_t>(p)});
    case FieldKind::kUint16:
      return LeafValue(uint64_t{Load<uint16_t>(p)});
    case FieldKind::kInt32:
      return LeafValue(int64_t{Load<int32_t>(p)});
    case FieldKind::kUint32:
      return LeafValue(uint64_t{Load<uint32_t>(p)});
    case FieldKind::kInt64:
      return LeafValue(Load<int64_t>(p));
    case FieldKind::kUint64:
      return LeafValue(Load<uint64_t>(p));
    case FieldKind::kFloat32:
      return LeafValue(double{Load<float>(p)});
    case FieldKind::kFloat64:
      return LeafValue(Load<double>(p));
    case FieldKind::kTime:
      return LeafValue(TimeNs{int64_t{Load<uint32_t>(p)} * 1000000000 + Load<uint32_t>(p + 4)});
    case FieldKind::kDuration:
      return LeafValue(TimeNs{int64_t{Load<int32_t>(p)} * 1000000000 + Load<int32_t>(p + 4)});
    default:
      return LeafValue(false);
  }
}

// One walk does both validation (visitor == nullptr) and visiting. Validation, which every received and
// every decoded message goes through, builds no strings: the path to a field is a stack of references,
// spelled out only for an error (or for a visitor).
class Walker {
 public:
  Walker(const uint8_t* data, size_t size, FieldVisitor* visitor) : cursor_(data, size), visitor_(visitor) {}

  bool WalkMessage(const MessageSchema& schema, int depth) {
    if (depth > kMaxDepth) return Fail("nesting deeper than " + std::to_string(kMaxDepth));
    if (visitor_) visitor_->BeginMessage(Path(), schema);
    for (const auto& field : schema.fields) {
      path_.push_back(Segment{&field.name, 0});
      if (!WalkField(field, depth)) return false;
      path_.pop_back();
    }
    return true;
  }

  bool WalkField(const FieldSchema& field, int depth) {
    if (field.array_size < 0) return WalkElement(field, depth);
    size_t count = static_cast<size_t>(field.array_size);
    if (field.array_size == 0) {
      uint32_t n;
      if (!cursor_.ReadU32(&n)) return Fail("truncated array length");
      count = n;
    }
    const size_t element_size = PrimitiveSize(field.kind);
    // every element takes at least one byte except empty messages, so a count beyond the bytes left is
    // corrupt
    if (element_size > 0 && count > cursor_.remaining() / element_size) {
      return Fail("array of " + std::to_string(count) + " elements does not fit in " +
                  std::to_string(cursor_.remaining()) + " remaining bytes");
    }
    if (field.kind == FieldKind::kUint8 || field.kind == FieldKind::kInt8) {
      const uint8_t* p;
      if (!cursor_.Take(count, &p)) return Fail("truncated byte array");
      if (visitor_) visitor_->Bytes(Path(), field.name, p, count);
      return true;
    }
    if (element_size == 0 && count > cursor_.remaining() && !MayBeEmpty(field)) {
      return Fail("array of " + std::to_string(count) + " elements exceeds the remaining bytes");
    }
    if (visitor_) visitor_->BeginArray(Path(), count);
    for (size_t i = 0; i < count; ++i) {
      path_.push_back(Segment{nullptr, i});
      if (!WalkElement(field, depth + 1)) return false;
      path_.pop_back();
    }
    return true;
  }

  bool WalkElement(const FieldSchema& field, int depth) {
    if (field.kind == FieldKind::kMessage) return WalkMessage(*field.nested, depth + 1);
    if (field.kind == FieldKind::kString) {
      uint32_t n;
      if (!cursor_.ReadU32(&n)) return Fail("truncated string length");
      const uint8_t* p;
      if (!cursor_.Take(n, &p)) return Fail("string of " + std::to_string(n) + " bytes is truncated");
      if (visitor_) Visit(field, LeafValue(std::string(reinterpret_cast<const char*>(p), n)));
      return true;
    }
    const uint8_t* p;
    if (!cursor_.Take(PrimitiveSize(field.kind), &p)) return Fail("truncated value");
    if (visitor_) Visit(field, ReadLeaf(field.kind, p));
    return true;
  }

  bool Finish(std::string* error) {
    if (!error_.empty()) {
      if (error) *error = error_;
      return false;
    }
    if (cursor_.remaining() != 0) {
      if (error) *error = std::to_string(cursor_.remaining()) + " trailing bytes after the message";
      return false;
    }
    return true;
  }

 private:
  static constexpr int kMaxDepth = 64;

  struct Segment {
    const std::string* field;  // nullptr: an array index
    size_t index;
  };

  static bool MayBeEmpty(const FieldSchema& field) {
    return field.kind == FieldKind::kMessage && field.nested->fields.empty();
  }

  // "pose.position.x", "bodies[2].name"
  std::string Path() const {
    std::string path;
    for (const Segment& segment : path_) {
      if (segment.field) {
        if (!path.empty()) path += '.';
        path += *segment.field;
      } else {
        path += "[" + std::to_string(segment.index) + "]";
      }
    }
    return path;
  }

  // a leaf's name is its field's, with the index when it is an array element: "data[3]"
  void Visit(const FieldSchema& field, const LeafValue& value) {
    const Segment& last = path_.back();
    const std::string name = last.field ? field.name : field.name + "[" + std::to_string(last.index) + "]";
    visitor_->Leaf(Path(), name, value);
  }

  bool Fail(const std::string& what) {
    if (error_.empty())
      error_ = "at byte " + std::to_string(cursor_.pos()) + ", field '" + Path() + "': " + what;
    return false;
  }

  std::vector<Segment> path_;
  Cursor cursor_;
  FieldVisitor* visitor_;
  std::string error_;
};

}  // namespace

size_t PrimitiveSize(FieldKind kind) {
  switch (kind) {
    case FieldKind::kBool:
    case FieldKind::kInt8:
    case FieldKind::kUint8:
      return 1;
    case FieldKind::kInt16:
    case FieldKind::kUint16:
      return 2;
    case FieldKind::kInt32:
    case FieldKind::kUint32:
    case FieldKind::kFloat32:
      return 4;
    case FieldKind::kInt64:
    case FieldKind::kUint64:
    case FieldKind::kFloat64:
    case FieldKind::kTime:
    case FieldKind::kDuration:
      return 8;
    case FieldKind::kString:
    case FieldKind::kMessage:
      return 0;
  }
  return 0;
}

std::shared_ptr<const SchemaSet> SchemaSet::Parse(const std::string& datatype,
                                                  const std::string& definition) {
  auto set = std::make_shared<SchemaSet>();
  std::map<std::string, MessageSchema*> by_type;
  auto fail = [&](int line, const std::string& what) {
    throw std::invalid_argument("definition of " + datatype + ", line " + std::to_string(line) + ": " + what);
  };

  // split into sections: the root, then one per "MSG: pkg/Type" header
  auto current = std::make_unique<MessageSchema>();
  current->datatype = datatype;
  by_type[datatype] = current.get();
  std::istringstream in(definition);
  std::string raw;
  int line_number = 0;
  while (std::getline(in, raw)) {
    ++line_number;
    std::string line = Trim(raw);
    if (line.rfind("MSG:", 0) == 0) {
      set->schemas_.push_back(std::move(current));
      current = std::make_unique<MessageSchema>();
      current->datatype = Trim(line.substr(4));
      by_type[current->datatype] = current.get();
      continue;
    }
    if (line.rfind("=====", 0) == 0) continue;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line = Trim(line.substr(0, hash));
    if (line.empty() || line.find('=') != std::string::npos) continue;  // comment or constant

    std::istringstream words(line);
    std::string type, name;
    words >> type >> name;
    if (name.empty()) fail(line_number, "expected '<type> <name>', got '" + line + "'");
    FieldSchema field;
    field.name = name;
    const auto bracket = type.find('[');
    if (bracket != std::string::npos) {
      const auto close = type.find(']', bracket);
      if (close == std::string::npos) fail(line_number, "unclosed '[' in '" + type + "'");
      const std::string size = type.substr(bracket + 1, close - bracket - 1);
      field.array_size = size.empty() ? 0 : std::stoi(size);
      if (field.array_size < 0) fail(line_number, "negative array size");
      type = type.substr(0, bracket);
    }
    if (!LookupBuiltin(type, &field.kind)) {
      field.kind = FieldKind::kMessage;
      if (type == "Header") {
        field.message_type = "std_msgs/Header";
      } else if (type.find('/') == std::string::npos) {
        field.message_type = PackageOf(current->datatype) + "/" + type;
      } else {
        field.message_type = type;
      }
    }
    current->fields.push_back(std::move(field));
  }
  set->schemas_.push_back(std::move(current));

  // resolve nested types; a missing section is an error rather than a silently skipped field
  for (auto& schema : set->schemas_) {
    for (auto& field : schema->fields) {
      if (field.kind != FieldKind::kMessage) continue;
      const auto it = by_type.find(field.message_type);
      if (it == by_type.end()) {
        throw std::invalid_argument("definition of " + datatype + ": type " + field.message_type +
                                    " of field " + schema->datatype + "." + field.name + " is not defined");
      }
      field.nested = it->second;
    }
  }
  set->root_ = by_type[datatype];
  return set;
}

bool SchemaSet::Validate(const uint8_t* data, size_t size, std::string* error) const {
  Walker walker(data, size, nullptr);
  walker.WalkMessage(*root_, 0);
  return walker.Finish(error);
}

void SchemaSet::Walk(const uint8_t* data, size_t size, FieldVisitor& visitor) const {
  Walker walker(data, size, &visitor);
  walker.WalkMessage(*root_, 0);
  std::string error;
  if (!walker.Finish(&error)) throw std::invalid_argument(root_->datatype + ": " + error);
}

int SchemaSet::HeaderStampOffset() const {
  const auto& fields = root_->fields;
  if (fields.empty() || fields[0].kind != FieldKind::kMessage || fields[0].array_size >= 0 ||
      fields[0].message_type != "std_msgs/Header") {
    return -1;
  }
  return 4;  // std_msgs/Header is uint32 seq, time stamp, string frame_id
}

int SchemaSet::StampOffset() const {
  const auto& fields = root_->fields;
  if (!fields.empty() && fields[0].kind == FieldKind::kTime && fields[0].array_size < 0) return 0;
  return HeaderStampOffset();
}

std::optional<int64_t> MessageStampNs(const SchemaSet& schema, const uint8_t* data, size_t size) {
  const int offset = schema.StampOffset();
  if (offset < 0 || size < static_cast<size_t>(offset) + 8) return std::nullopt;
  uint32_t sec, nsec;
  std::memcpy(&sec, data + offset, 4);
  std::memcpy(&nsec, data + offset + 4, 4);
  return int64_t{sec} * 1000000000 + nsec;
}

std::optional<int64_t> MessageTimeNs(const SchemaSet& schema, const uint8_t* data, size_t size) {
  const std::optional<int64_t> stamp_ns = MessageStampNs(schema, data, size);
  if (stamp_ns == 0) return std::nullopt;
  return stamp_ns;
}

}  // namespace iapsim::bridge
