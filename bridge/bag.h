#pragma once
// ROS1 .bag files of raw (already serialized) messages. librosbag_storage stays behind this interface.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "bridge/message.h"

namespace iapsim::bridge {

class BagError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Writes a bag. Record times are sim time in nanoseconds; a bag cannot hold time 0 (ros::TIME_MIN is
/// 1 ns), so a record time of 0 is stored as 1 ns. Message header stamps are payload and stay exact.
class BagWriter {
 public:
  /// Creates (truncates) `path`. Throws BagError naming the file.
  explicit BagWriter(const std::string& path);
  ~BagWriter();  // closes
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  /// `type` must be complete (datatype, md5, definition): readers rebuild messages from the definition.
  void Write(const std::string& topic, const TypeInfo& type, int64_t record_time_ns, const uint8_t* data,
             size_t size, const std::string& publisher);
  /// Writes the index; the file is complete and readable afterwards. Idempotent.
  void Close();
  const std::string& path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct BagTopicInfo {
  std::string topic;
  std::string datatype;
  std::string md5;
  std::string definition;
  uint64_t count = 0;
  int64_t first_time_ns = 0;
  int64_t last_time_ns = 0;
};

struct BagMessage {
  const std::string& topic;
  const TypeInfo& type;
  int64_t record_time_ns;
  const std::vector<uint8_t>& bytes;
};

class BagReader {
 public:
  /// Opens `path` for reading. Throws BagError naming the file when it is missing or not a bag.
  explicit BagReader(const std::string& path);
  ~BagReader();
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  /// Topics sorted by name.
  std::vector<BagTopicInfo> Topics() const;
  int64_t start_time_ns() const;
  int64_t end_time_ns() const;

  /// Visits the messages of `topics` (all when empty) in record-time order; stop early by returning false.
  void ForEach(const std::vector<std::string>& topics,
               const std::function<bool(const BagMessage&)>& visit) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iapsim::bridge
