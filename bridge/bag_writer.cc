// The bag writer: ROS bag format 2.0 (http://wiki.ros.org/Bags/Format/2.0), written here rather than through
// librosbag_storage. rosbag::Bag::write cost about 20 us a message on the project's machine (the three-star
// spiral: 559,011 messages, 12.7 s recorded against 1.3 s unrecorded): for every message it copies the
// connection's header map (message definition included), builds a std::map record header, and seeks to the
// end of the file, which flushes stdio's buffer, so every message costs write system calls. Here a chunk is
// built in memory (buffers reused from chunk to chunk) and written with its index in one system call; a
// message costs a 46-byte record header and one copy of its bytes.
//
// Layout, field for field as rosbag_storage 1.15 writes it (bag_test.cc compares the two byte for byte):
//   "#ROSBAG V2.0\n"
//   bag header record (op 0x03: index_pos, conn_count, chunk_count), padded to 4096 bytes so that Close can
//     rewrite it in place
//   per chunk: a chunk record (op 0x05: compression, size = uncompressed size) whose data holds a connection
//     record (op 0x07) before each connection's first message in the bag, and message data records (op 0x02:
//     conn, time); then one index data record (op 0x04, ver 1) per connection of the chunk, in connection
//     order: count x (time, offset of the message's record in the uncompressed chunk), by time
//   at Close: every connection record, one chunk info record (op 0x06, ver 1: chunk_pos, start_time,
//     end_time, count; count x (conn, messages)) per chunk, then the bag header with index_pos, the position
//     of the first of those.
// A record is a header (u32 length, then fields: u32 length, "name=", value) and data (u32 length, bytes),
// little-endian. Until Close the bag header says index_pos 0: the bag of a killed writer is unindexed, and as
// the file only grows by whole chunks (each with its index), `rosbag reindex` recovers every chunk written.

#include <fcntl.h>
#include <roslz4/lz4s.h>
#include <spdlog/spdlog.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <limits>
#include <string_view>
#include <unordered_map>

#include "bridge/bag.h"
#include "bridge/internal/bag_format.h"

namespace iapsim::bridge {
namespace {

using namespace bag_format;  // NOLINT: the format's constants, used throughout

using Clock = std::chrono::steady_clock;

constexpr uint32_t kBagHeaderBytes = 4096;  // header fields plus padding
// roslz4's frame with 1 MiB blocks, as rosbag's writer uses: the same blocks, so the same compressed bytes
constexpr int kLz4BlockSizeId = 6;
constexpr size_t kLz4BlockBytes = size_t{1} << 20;
// a chunk's size is a u32: with at most 1 GiB of records before a message of at most 2 GiB, it always fits
constexpr size_t kMaxChunkThresholdBytes = size_t{1} << 30;
constexpr size_t kMaxMessageBytes = size_t{1} << 31;

// a bag's times are u32 seconds and u32 nanoseconds
struct BagTime {
  uint32_t sec;
  uint32_t nsec;
};
BagTime ToBagTime(int64_t time_ns) {
  return {static_cast<uint32_t>(time_ns / 1000000000), static_cast<uint32_t>(time_ns % 1000000000)};
}

void Append(std::vector<uint8_t>* out, const void* data, size_t size) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  out->insert(out->end(), bytes, bytes + size);
}

void AppendU32(std::vector<uint8_t>* out, uint32_t value) { Append(out, &value, sizeof(value)); }

// Appends a record header field by field; End() fills in its length.
class Header {
 public:
  explicit Header(std::vector<uint8_t>* out) : out_(out), start_(out->size()) { AppendU32(out, 0); }

  Header& Bytes(std::string_view name, const void* value, size_t size) {
    AppendU32(out_, static_cast<uint32_t>(name.size() + 1 + size));
    Append(out_, name.data(), name.size());
    out_->push_back('=');
    Append(out_, value, size);
    return *this;
  }
  template <class T>
  Header& Value(std::string_view name, T value) {
    return Bytes(name, &value, sizeof(value));
  }
  Header& Text(std::string_view name, const std::string& value) {
    return Bytes(name, value.data(), value.size());
  }
  Header& Time(std::string_view name, int64_t time_ns) { return Value(name, ToBagTime(time_ns)); }

  /// Length of the fields, as the header's first u32 now says.
  uint32_t End() {
    const auto length = static_cast<uint32_t>(out_->size() - start_ - 4);
    std::memcpy(out_->data() + start_, &length, 4);
    return length;
  }

 private:
  std::vector<uint8_t>* out_;
  size_t start_;
};

struct ConnectionInfo {
  std::string topic;
  std::string publisher;
  TypeInfo type;
  int64_t id = -1;              // in the bag: numbered in order of first message, as rosbag does
  std::vector<uint8_t> record;  // the connection record, encoded at first message
  // the header of its message data records, whose last field is the time: a message copies it and sets
  // the time
  std::vector<uint8_t> message_header;
};

struct IndexEntry {
  int64_t time_ns;
  uint32_t offset;  // of the message's record in the uncompressed chunk
};

struct ChunkInfo {
  uint64_t position;
  int64_t start_ns;
  int64_t end_ns;
  size_t counts_begin;  // its (connection, messages) pairs in chunk_counts
  size_t counts_end;
};

}  // namespace

struct BagWriter::Impl {
  std::string path;
  BagWriterOptions options;
  int fd = -1;  // -1 once closed
  BagWriterStats stats;

  std::vector<ConnectionInfo> connections;            // by handle (Connection's result)
  std::unordered_map<std::string, uint32_t> handles;  // topic, publisher, datatype, md5 -> handle
  std::string key;                                    // scratch for the lookup
  std::vector<uint32_t> by_id;                        // handles in bag id order

  // the chunk being filled
  std::vector<uint8_t> chunk;
  std::vector<std::vector<IndexEntry>> chunk_index;  // by bag id
  std::vector<uint32_t> chunk_ids;                   // bag ids with messages in this chunk
  int64_t chunk_start_ns = 0;
  int64_t chunk_end_ns = 0;
  // scratch for writing one chunk: its header, its compressed data, its index records
  std::vector<uint8_t> head;
  std::vector<uint8_t> compressed;
  std::vector<uint8_t> tail;

  std::vector<ChunkInfo> chunks;
  std::vector<std::pair<uint32_t, uint32_t>> chunk_counts;

  // Writes `parts` at the end of the file, retrying partial writes.
  void WriteAtEnd(std::vector<iovec> parts) {
    size_t first = 0;
    while (first < parts.size()) {
      const auto start = Clock::now();
      const ssize_t wrote = ::writev(fd, &parts[first], static_cast<int>(parts.size() - first));
      stats.write_s += std::chrono::duration<double>(Clock::now() - start).count();
      ++stats.write_calls;
      if (wrote < 0) {
        if (errno == EINTR) continue;
        throw ErrorFor(path, std::string("write failed: ") + std::strerror(errno));
      }
      stats.file_bytes += static_cast<uint64_t>(wrote);
      // drop what was written: whole parts, then the front of a partial one
      auto left = static_cast<size_t>(wrote);
      while (first < parts.size() && left >= parts[first].iov_len) left -= parts[first++].iov_len;
      if (left > 0) {
        parts[first].iov_base = static_cast<uint8_t*>(parts[first].iov_base) + left;
        parts[first].iov_len -= left;
      }
    }
  }

  // The bag header record into `head`: its size never changes, so Close rewrites it in place.
  void BuildBagHeader(uint64_t index_position) {
    head.clear();
    Header header(&head);
    header.Value("chunk_count", static_cast<uint32_t>(chunks.size()))
        .Value("conn_count", static_cast<uint32_t>(by_id.size()))
        .Value("index_pos", index_position)
        .Value("op", kOpBagHeader);
    const uint32_t padding = kBagHeaderBytes - header.End();
    AppendU32(&head, padding);
    head.resize(head.size() + padding, ' ');
  }

  void RewriteBagHeader(uint64_t index_position) {
    BuildBagHeader(index_position);
    const off_t at = sizeof(kVersionLine) - 1;
    size_t done = 0;
    while (done < head.size()) {
      const auto start = Clock::now();
      const ssize_t wrote =
          ::pwrite(fd, head.data() + done, head.size() - done, at + static_cast<off_t>(done));
      stats.write_s += std::chrono::duration<double>(Clock::now() - start).count();
      ++stats.write_calls;
      if (wrote < 0 && errno == EINTR) continue;
      if (wrote < 0)
        throw ErrorFor(path, std::string("writing the bag header failed: ") + std::strerror(errno));
      done += static_cast<size_t>(wrote);
    }
  }

  void BeginConnection(ConnectionInfo& connection) {
    connection.id = static_cast<int64_t>(by_id.size());
    by_id.push_back(static_cast<uint32_t>(&connection - connections.data()));
    chunk_index.emplace_back();
    std::vector<uint8_t>& record = connection.record;
    Header(&record)
        .Value("conn", static_cast<uint32_t>(connection.id))
        .Value("op", kOpConnection)
        .Text("topic", connection.topic)
        .End();
    // the data is the connection header that a ROS subscriber would have received
    Header(&record)
        .Text("callerid", connection.publisher)
        .Text("md5sum", connection.type.md5)
        .Text("message_definition", connection.type.definition)
        .Text("topic", connection.topic)
        .Text("type", connection.type.datatype)
        .End();
    Header(&connection.message_header)
        .Value("conn", static_cast<uint32_t>(connection.id))
        .Value("op", kOpMessageData)
        .Time("time", 0)
        .End();
  }

  void FlushChunk() {
    if (chunk.empty()) return;
    const auto uncompressed_size = static_cast<uint32_t>(chunk.size());
    const uint8_t* data = chunk.data();
    uint32_t data_size = uncompressed_size;
    if (options.compression == BagCompression::kLz4) {
      const auto start = Clock::now();
      // the frame's bound: a 7-byte header, a 4-byte size before each block (stored raw when it does not
      // shrink), an 8-byte end mark and checksum
      const size_t bound = chunk.size() + 4 * (chunk.size() / kLz4BlockBytes + 1) + 15;
      if (compressed.size() < bound) compressed.resize(bound);
      unsigned int size = static_cast<unsigned int>(compressed.size());
      const int status =
          roslz4_buffToBuffCompress(reinterpret_cast<char*>(chunk.data()), uncompressed_size,
                                    reinterpret_cast<char*>(compressed.data()), &size, kLz4BlockSizeId);
      stats.compress_s += std::chrono::duration<double>(Clock::now() - start).count();
      if (status != ROSLZ4_OK)
        throw ErrorFor(path, "lz4 compression failed (" + std::to_string(status) + ")");
      data = compressed.data();
      data_size = size;
    }

    head.clear();
    Header(&head)
        .Text("compression", options.compression == BagCompression::kLz4 ? "lz4" : "none")
        .Value("op", kOpChunk)
        .Value("size", uncompressed_size)
        .End();
    AppendU32(&head, data_size);

    // the chunk's index, connection by connection; entries by time, ties in write order
    std::sort(chunk_ids.begin(), chunk_ids.end());
    tail.clear();
    const size_t counts_begin = chunk_counts.size();
    for (const uint32_t id : chunk_ids) {
      std::vector<IndexEntry>& index = chunk_index[id];
      const auto by_time = [](const IndexEntry& a, const IndexEntry& b) { return a.time_ns < b.time_ns; };
      if (!std::is_sorted(index.begin(), index.end(), by_time)) {
        std::stable_sort(index.begin(), index.end(), by_time);
      }
      const auto count = static_cast<uint32_t>(index.size());
      Header(&tail)
          .Value("conn", id)
          .Value("count", count)
          .Value("op", kOpIndexData)
          .Value("ver", kIndexVersion)
          .End();
      AppendU32(&tail, count * 12);
      for (const IndexEntry& entry : index) {
        const BagTime time = ToBagTime(entry.time_ns);
        Append(&tail, &time, sizeof(time));
        Append(&tail, &entry.offset, sizeof(entry.offset));
      }
      chunk_counts.emplace_back(id, count);
      index.clear();
    }

    const uint64_t position = stats.file_bytes;
    WriteAtEnd(
        {{head.data(), head.size()}, {const_cast<uint8_t*>(data), data_size}, {tail.data(), tail.size()}});
    chunks.push_back({position, chunk_start_ns, chunk_end_ns, counts_begin, chunk_counts.size()});
    ++stats.chunks;
    stats.record_bytes += uncompressed_size;
    stats.chunk_data_bytes += data_size;
    chunk.clear();
    chunk_ids.clear();
  }

  void WriteIndex() {
    FlushChunk();
    const uint64_t index_position = stats.file_bytes;
    tail.clear();
    for (const uint32_t handle : by_id)
      Append(&tail, connections[handle].record.data(), connections[handle].record.size());
    for (const ChunkInfo& info : chunks) {
      const auto count = static_cast<uint32_t>(info.counts_end - info.counts_begin);
      Header(&tail)
          .Value("chunk_pos", info.position)
          .Value("count", count)
          .Time("end_time", info.end_ns)
          .Value("op", kOpChunkInfo)
          .Time("start_time", info.start_ns)
          .Value("ver", kChunkInfoVersion)
          .End();
      AppendU32(&tail, count * 8);
      for (size_t i = info.counts_begin; i < info.counts_end; ++i) {
        Append(&tail, &chunk_counts[i].first, 4);
        Append(&tail, &chunk_counts[i].second, 4);
      }
    }
    WriteAtEnd({{tail.data(), tail.size()}});
    RewriteBagHeader(index_position);
  }
};

BagWriter::BagWriter(const std::string& path, const BagWriterOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& impl = *impl_;
  impl.path = path;
  impl.options = options;
  if (options.chunk_threshold_bytes > kMaxChunkThresholdBytes) {
    throw ErrorFor(
        path, "chunk threshold " + std::to_string(options.chunk_threshold_bytes) + " bytes is above 1 GiB");
  }
  impl.fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (impl.fd < 0) throw ErrorFor(path, std::string("cannot create: ") + std::strerror(errno));
  impl.chunk.reserve(options.chunk_threshold_bytes + (64 << 10));
  // an empty bag, unindexed until Close
  impl.BuildBagHeader(0);
  impl.WriteAtEnd(
      {{const_cast<char*>(kVersionLine), sizeof(kVersionLine) - 1}, {impl.head.data(), impl.head.size()}});
}

BagWriter::~BagWriter() {
  try {
    Close();
  } catch (const std::exception& e) {
    // a destructor must not throw; the caller who needs the error calls Close() first
    spdlog::error("closing bag failed: {}", e.what());
  }
}

uint32_t BagWriter::Connection(const std::string& topic, const TypeInfo& type, const std::string& publisher) {
  Impl& impl = *impl_;
  if (topic.empty()) throw ErrorFor(impl.path, "empty topic name");
  if (type.datatype.empty() || type.md5.empty() || type.definition.empty()) {
    throw ErrorFor(impl.path, "incomplete type '" + type.datatype + "' on '" + topic +
                                  "': datatype, md5 and definition are all required");
  }
  // rosbag keys connections by their header's contents: these four decide it
  impl.key.assign(topic)
      .append(1, '\0')
      .append(publisher)
      .append(1, '\0')
      .append(type.datatype)
      .append(1, '\0')
      .append(type.md5);
  const auto [it, inserted] =
      impl.handles.try_emplace(impl.key, static_cast<uint32_t>(impl.connections.size()));
  if (inserted) impl.connections.push_back({topic, publisher, type, -1, {}, {}});
  return it->second;
}

void BagWriter::Write(uint32_t connection, int64_t record_time_ns, const uint8_t* data, size_t size) {
  Impl& impl = *impl_;
  if (impl.fd < 0) throw ErrorFor(impl.path, "write after Close()");
  if (connection >= impl.connections.size()) {
    throw ErrorFor(impl.path, "no connection " + std::to_string(connection));
  }
  ConnectionInfo& info = impl.connections[connection];
  if (size > kMaxMessageBytes) throw ErrorFor(impl.path, "message on '" + info.topic + "' exceeds 2 GiB");
  if (size > 0 && data == nullptr) throw ErrorFor(impl.path, "null data on '" + info.topic + "'");
  if (record_time_ns < 0) {
    throw ErrorFor(impl.path, "negative record time " + std::to_string(record_time_ns) + " ns");
  }
  if (record_time_ns > kMaxTimeNs) {
    throw ErrorFor(impl.path,
                   "record time " + std::to_string(record_time_ns) + " ns is beyond ros::TIME_MAX");
  }
  const int64_t time_ns = std::max<int64_t>(record_time_ns, 1);  // ros::TIME_MIN

  std::vector<uint8_t>& chunk = impl.chunk;
  if (chunk.empty()) impl.chunk_start_ns = impl.chunk_end_ns = time_ns;
  if (info.id < 0) {
    impl.BeginConnection(info);
    Append(&chunk, info.record.data(), info.record.size());
  }
  const auto id = static_cast<uint32_t>(info.id);
  std::vector<IndexEntry>& index = impl.chunk_index[id];
  if (index.empty()) impl.chunk_ids.push_back(id);
  index.push_back({time_ns, static_cast<uint32_t>(chunk.size())});
  Append(&chunk, info.message_header.data(), info.message_header.size());
  const BagTime time = ToBagTime(time_ns);
  std::memcpy(chunk.data() + chunk.size() - sizeof(time), &time, sizeof(time));
  AppendU32(&chunk, static_cast<uint32_t>(size));
  Append(&chunk, data, size);
  impl.chunk_start_ns = std::min(impl.chunk_start_ns, time_ns);
  impl.chunk_end_ns = std::max(impl.chunk_end_ns, time_ns);
  ++impl.stats.messages;
  if (chunk.size() > impl.options.chunk_threshold_bytes) impl.FlushChunk();
}

void BagWriter::Write(const std::string& topic, const TypeInfo& type, int64_t record_time_ns,
                      const uint8_t* data, size_t size, const std::string& publisher) {
  if (impl_->fd < 0) throw ErrorFor(impl_->path, "write to '" + topic + "' after Close()");
  Write(Connection(topic, type, publisher), record_time_ns, data, size);
}

void BagWriter::Close() {
  Impl& impl = *impl_;
  if (impl.fd < 0) return;
  const int fd = impl.fd;
  try {
    impl.WriteIndex();
  } catch (...) {
    impl.fd = -1;
    ::close(fd);
    throw;
  }
  impl.fd = -1;
  if (::close(fd) != 0) throw ErrorFor(impl.path, std::string("close failed: ") + std::strerror(errno));
}

const std::string& BagWriter::path() const { return impl_->path; }

const BagWriterStats& BagWriter::stats() const { return impl_->stats; }

}  // namespace iapsim::bridge
