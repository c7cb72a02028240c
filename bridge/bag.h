#pragma once
// ROS1 .bag files of raw (already serialized) messages. The writer and the reader are the project's own
// (bag_writer.cc and bag.cc say why); bag_test.cc checks both against librosbag_storage.

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

enum class BagCompression { kNone, kLz4 };

struct BagWriterOptions {
  BagCompression compression =
      BagCompression::kNone;  // per chunk; rosbag, rqt_bag and python rosbag read lz4
  /// A chunk is written once its records pass this many bytes (before compression); rosbag's default.
  size_t chunk_threshold_bytes = 768 * 1024;
};

/// What writing has cost so far.
struct BagWriterStats {
  uint64_t messages = 0;
  uint64_t chunks = 0;
  uint64_t record_bytes = 0;      // chunk contents before compression
  uint64_t chunk_data_bytes = 0;  // chunk contents as stored (compressed or not)
  uint64_t file_bytes = 0;        // the file's size
  uint64_t write_calls = 0;       // system calls that wrote to the file
  double write_s = 0.0;           // wall time in those calls
  double compress_s = 0.0;
};

/// Writes a ROS bag (format 2.0). Record times are sim time in nanoseconds; a bag cannot hold time 0
/// (ros::TIME_MIN is 1 ns), so a record time of 0 is stored as 1 ns. Message header stamps are payload and
/// stay exact. Messages are kept in memory until their chunk is full; the file only ever grows by whole
/// chunks, so the bag of a writer killed before Close is unindexed but `rosbag reindex` recovers every chunk
/// written.
class BagWriter {
 public:
  /// Creates (truncates) `path`. Throws BagError naming the file.
  explicit BagWriter(const std::string& path, const BagWriterOptions& options = {});
  ~BagWriter();  // closes
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  /// The connection of `topic` carrying `type` from `publisher`, made on first use. `type` must be complete
  /// (datatype, md5, definition): readers rebuild messages from the definition.
  uint32_t Connection(const std::string& topic, const TypeInfo& type, const std::string& publisher);
  /// Appends a message to a connection from Connection(): no lookup, and no allocation once the buffers have
  /// grown.
  void Write(uint32_t connection, int64_t record_time_ns, const uint8_t* data, size_t size);
  void Write(const std::string& topic, const TypeInfo& type, int64_t record_time_ns, const uint8_t* data,
             size_t size, const std::string& publisher);
  /// Writes the last chunk and the index; the file is complete and readable afterwards. Idempotent.
  void Close();
  const std::string& path() const;
  const BagWriterStats& stats() const;

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
  const std::string& publisher;  // the connection's callerid (empty when the bag has none)
};

class BagReader {
 public:
  /// Opens `path` for reading. Throws BagError naming the file (and the byte) when it is missing, not a bag
  /// or damaged.
  explicit BagReader(const std::string& path);
  ~BagReader();
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  const std::string& path() const;
  /// Topics sorted by name.
  std::vector<BagTopicInfo> Topics() const;
  int64_t start_time_ns() const;
  int64_t end_time_ns() const;
  /// Empty for a bag read as written; otherwise how it was read (an unindexed bag, the one a killed writer
  /// leaves, is read by walking its chunks: every whole chunk's messages, the last one cut short skipped).
  const std::string& note() const;

  /// Visits the messages of `topics` (all when empty) in record-time order; stop early by returning false.
  void ForEach(const std::vector<std::string>& topics,
               const std::function<bool(const BagMessage&)>& visit) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Writes to `out` an indexed copy of the bag at `in` as BagReader reads it (an unindexed bag, a killed
/// writer's, by walking its whole chunks): every connection (topic, type, publisher) and every message at its
/// record time. Returns the number of messages. Throws BagError naming the file.
uint64_t ReindexBag(const std::string& in, const std::string& out, const BagWriterOptions& options = {});

}  // namespace iapsim::bridge
