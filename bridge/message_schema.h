#pragma once
// Run-time view of a ROS1 message definition: validates serialized bytes and walks them field by field.
//
// Why our own: roscpp's deserializer resizes a vector from an untrusted length prefix before checking it
// against the buffer, so a corrupt 4-byte length can allocate gigabytes. Walking the bytes against the
// definition first rejects such input cheaply. The same walk serves `iapsim echo` and `iapsim export` for
// any message type. (ros_type_introspection does this too but is not packaged in Debian.)

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace iapsim::bridge {

enum class FieldKind {
  kBool,
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kInt64,
  kUint64,
  kFloat32,
  kFloat64,
  kString,
  kTime,
  kDuration,
  kMessage
};

struct MessageSchema;

struct FieldSchema {
  std::string name;
  FieldKind kind = FieldKind::kBool;
  std::string message_type;               // resolved "pkg/Type" when kind == kMessage
  int array_size = -1;                    // -1: scalar, 0: variable-length array, >0: fixed-length array
  const MessageSchema* nested = nullptr;  // when kind == kMessage
};

struct MessageSchema {
  std::string datatype;  // "pkg/Type"
  std::vector<FieldSchema> fields;
};

/// A leaf value met during a walk. Time and duration are integer nanoseconds.
struct TimeNs {
  int64_t ns = 0;
};
using LeafValue = std::variant<bool, int64_t, uint64_t, double, std::string, TimeNs>;

/// Receives the fields of a message in serialization order. Paths look like "bodies[1].pose_W.position.x".
class FieldVisitor {
 public:
  virtual ~FieldVisitor() = default;
  virtual void BeginMessage(const std::string& /*path*/, const MessageSchema& /*schema*/) {}
  virtual void BeginArray(const std::string& /*path*/, size_t /*count*/) {}
  virtual void Leaf(const std::string& path, const std::string& name, const LeafValue& value) = 0;
  /// Arrays of bytes (uint8/int8) are reported whole, never element by element.
  virtual void Bytes(const std::string& path, const std::string& name, const uint8_t* data, size_t size) = 0;
};

/// All message schemas of one full definition (root message plus every nested "MSG:" section).
class SchemaSet {
 public:
  /// Parses gencpp's full definition text. Throws std::invalid_argument naming the type and line on error.
  static std::shared_ptr<const SchemaSet> Parse(const std::string& datatype, const std::string& definition);

  const MessageSchema& root() const { return *root_; }

  /// True when `bytes` is exactly one well-formed message of this type; otherwise `error` says where not.
  bool Validate(const uint8_t* data, size_t size, std::string* error) const;

  /// Walks a message that Validate accepted (throws std::invalid_argument if it does not parse).
  void Walk(const uint8_t* data, size_t size, FieldVisitor& visitor) const;

  /// Byte offset of header.stamp when the message starts with a std_msgs/Header, else -1.
  int HeaderStampOffset() const;

  /// Byte offset of the sim time the message refers to: header.stamp, or the first field when it is a
  /// `time` (rosgraph_msgs/Clock); -1 for a type without one.
  int StampOffset() const;

 private:
  std::vector<std::unique_ptr<MessageSchema>> schemas_;
  const MessageSchema* root_ = nullptr;
};

/// The sim time (ns) at StampOffset() of a message of `schema`, or nullopt when the type has none or the
/// message is too short to hold it.
std::optional<int64_t> MessageStampNs(const SchemaSet& schema, const uint8_t* data, size_t size);

/// The sim time a message refers to, for recording and replaying it: its stamp, or nullopt when it has none
/// or the stamp is 0, which ROS reads as "not set" (a producer that never stamps its messages; a message
/// of t = 0 is recorded at step 0's time, 0, all the same).
std::optional<int64_t> MessageTimeNs(const SchemaSet& schema, const uint8_t* data, size_t size);

/// Serialized size in bytes of one element of a fixed-size primitive kind (0 for string/message).
size_t PrimitiveSize(FieldKind kind);

}  // namespace iapsim::bridge
