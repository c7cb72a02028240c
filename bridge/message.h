#pragma once
// Messages are ROS1 value types (gencpp structs); this is their codec in the ROS1 wire format.

#include <ros/message_traits.h>
#include <ros/serialization.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bridge/message_schema.h"

namespace iapsim::bridge {

/// Identity of a message type on the wire and in bags.
struct TypeInfo {
  std::string datatype;    // "pkg/Type"
  std::string md5;         // 32 hex characters, as ROS computes it
  std::string definition;  // full definition text (root plus nested "MSG:" sections)
};

template <class M>
const TypeInfo& TypeInfoOf() {
  // immutable per-type constant, built once
  static const TypeInfo info{ros::message_traits::DataType<M>::value(),
                             ros::message_traits::MD5Sum<M>::value(),
                             ros::message_traits::Definition<M>::value()};
  return info;
}

/// Parsed schema of M, built once per type.
template <class M>
const SchemaSet& SchemaOf() {
  static const std::shared_ptr<const SchemaSet> schema =
      SchemaSet::Parse(TypeInfoOf<M>().datatype, TypeInfoOf<M>().definition);
  return *schema;
}

/// A serialized message of any type: what the bus carries and what a bag stores.
struct RawMessage {
  std::string datatype;
  std::string md5;
  std::vector<uint8_t> bytes;
};

/// Serializes `message` into `out` (resized to fit; its capacity is reused across calls).
template <class M>
void EncodeInto(const M& message, std::vector<uint8_t>* out) {
  const uint32_t size = ros::serialization::serializationLength(message);
  out->resize(size);
  ros::serialization::OStream stream(out->data(), size);
  ros::serialization::serialize(stream, message);
}

template <class M>
std::vector<uint8_t> Encode(const M& message) {
  std::vector<uint8_t> bytes;
  EncodeInto(message, &bytes);
  return bytes;
}

/// Decodes exactly one M from `data`. Malformed, truncated or oversized input returns false with a
/// reason in `error`; it never throws, crashes or allocates beyond the input's own size.
template <class M>
bool Decode(const uint8_t* data, size_t size, M* out, std::string* error) {
  if (!SchemaOf<M>().Validate(data, size, error)) return false;
  try {
    ros::serialization::IStream stream(const_cast<uint8_t*>(data), static_cast<uint32_t>(size));
    ros::serialization::deserialize(stream, *out);
  } catch (const std::exception& e) {
    if (error) *error = e.what();
    return false;
  }
  return true;
}

template <class M>
bool Decode(const std::vector<uint8_t>& bytes, M* out, std::string* error) {
  return Decode(bytes.data(), bytes.size(), out, error);
}

}  // namespace iapsim::bridge
