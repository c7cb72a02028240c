// The bag reader: ROS bag format 2.0 (the layout is in bag_writer.cc), read here rather than through
// librosbag_storage. Opening a bag with rosbag::Bag and summarising it through a rosbag::View took 0.3-0.9 s
// for a regression flight's bag (300-460 MB, 0.5-1.4 million messages): the view builds a sorted set over
// every message of the bag, and every evaluation, replay and echo opens one. Here opening reads the
// connection and chunk info records at the end of the file and the index data records after each chunk (a
// few system calls per chunk); reading merges the chunks' indexes by time, holding the entries of the
// chunks that overlap in time and one chunk's data at a time in sorted bags.
//
// What rosbag writes is read as well (bag_test.cc checks this against librosbag_storage's own reader):
// chunks uncompressed, lz4 (roslz4's frame) or bz2, several connections on a topic, chunks out of time order.

#include "bridge/bag.h"

#include <bzlib.h>
#include <fcntl.h>
#include <roslz4/lz4s.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>
#include <map>
#include <queue>
#include <set>
#include <string_view>
#include <unordered_map>
#include <utility>

#include "bridge/internal/bag_format.h"

namespace iapsim::bridge {
namespace {

using namespace bag_format;  // NOLINT: the format's constants, used throughout

// a record header's fields, name -> value, viewing the bytes they were parsed from
class HeaderFields {
 public:
  // false when the fields do not tile the bytes
  bool Parse(const uint8_t* data, size_t size) {
    fields_.clear();
    size_t pos = 0;
    while (pos < size) {
      uint32_t length;
      if (size - pos < 4) return false;
      std::memcpy(&length, data + pos, 4);
      pos += 4;
      if (length > size - pos) return false;
      const std::string_view field(reinterpret_cast<const char*>(data + pos), length);
      const auto equals = field.find('=');
      if (equals == std::string_view::npos) return false;
      fields_.emplace_back(field.substr(0, equals), field.substr(equals + 1));
      pos += length;
    }
    return true;
  }

  const std::string_view* Find(std::string_view name) const {
    for (const auto& [key, value] : fields_) {
      if (key == name) return &value;
    }
    return nullptr;
  }

  template <class T>
  bool Get(std::string_view name, T* value) const {
    const std::string_view* field = Find(name);
    if (field == nullptr || field->size() != sizeof(T)) return false;
    std::memcpy(value, field->data(), sizeof(T));
    return true;
  }

  bool GetTime(std::string_view name, int64_t* time_ns) const {
    uint32_t parts[2];
    const std::string_view* field = Find(name);
    if (field == nullptr || field->size() != sizeof(parts)) return false;
    std::memcpy(parts, field->data(), sizeof(parts));
    *time_ns = int64_t{parts[0]} * 1000000000 + parts[1];
    return true;
  }

 private:
  std::vector<std::pair<std::string_view, std::string_view>> fields_;
};

// One record in a buffer: its header's fields and its data.
struct Record {
  HeaderFields header;
  const uint8_t* data = nullptr;
  uint32_t data_size = 0;
  uint8_t op = 0;
  size_t end = 0;  // the offset after it in the buffer
};

// the record at `pos` of a buffer; false when it does not fit or its header is malformed
bool ParseRecord(const uint8_t* buffer, size_t size, size_t pos, Record* record) {
  uint32_t header_size, data_size;
  if (pos > size || size - pos < 4) return false;
  std::memcpy(&header_size, buffer + pos, 4);
  pos += 4;
  if (header_size > size - pos || !record->header.Parse(buffer + pos, header_size)) return false;
  pos += header_size;
  if (size - pos < 4) return false;
  std::memcpy(&data_size, buffer + pos, 4);
  pos += 4;
  if (data_size > size - pos) return false;
  record->data = buffer + pos;
  record->data_size = data_size;
  record->end = pos + data_size;
  return record->header.Get("op", &record->op);
}

struct Connection {
  std::string topic;
  TypeInfo type;
  std::string publisher;  // the connection's callerid; empty when it has none
};

struct Chunk {
  uint64_t position = 0;
  int64_t start_ns = 0;
  std::vector<std::pair<uint32_t, uint32_t>> counts;  // (connection id, messages)
  uint64_t index_end = 0;                             // its index data records end here
};

// a message found in a chunk's index: merged across chunks by (time, chunk, offset)
struct Entry {
  int64_t time_ns;
  uint32_t chunk;  // in Impl::chunks, which is sorted by start time
  uint32_t offset;
  uint32_t connection;
  bool operator>(const Entry& other) const {
    return std::tie(time_ns, chunk, offset) > std::tie(other.time_ns, other.chunk, other.offset);
  }
};

}  // namespace

struct BagReader::Impl {
  std::string path;
  int fd = -1;
  uint64_t file_size = 0;
  std::unordered_map<uint32_t, Connection> connections;
  std::vector<Chunk> chunks;  // by start time, then position
  std::vector<BagTopicInfo> topics;
  int64_t start_time_ns = 0;
  int64_t end_time_ns = 0;
  std::string note;  // how a bag was read that was not read as written

  [[noreturn]] void Fail(const std::string& what) const { throw ErrorFor(path, what); }

  void ReadAt(uint64_t offset, size_t size, std::vector<uint8_t>* out) const {
    if (offset > file_size || size > file_size - offset) {
      Fail("truncated: " + std::to_string(size) + " bytes at byte " + std::to_string(offset) +
           " lie beyond its " + std::to_string(file_size) + " bytes");
    }
    out->resize(size);
    size_t done = 0;
    while (done < size) {
      const ssize_t n = ::pread(fd, out->data() + done, size - done, static_cast<off_t>(offset + done));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) Fail("read at byte " + std::to_string(offset + done) + " failed: " + std::strerror(errno));
      done += static_cast<size_t>(n);
    }
  }

  // the size of the record at `position` (its two lengths and what they count), read with two small reads
  uint64_t RecordBytes(uint64_t position, std::vector<uint8_t>* scratch) const {
    uint32_t header_size, data_size;
    ReadAt(position, 4, scratch);
    std::memcpy(&header_size, scratch->data(), 4);
    ReadAt(position + 4 + header_size, 4, scratch);
    std::memcpy(&data_size, scratch->data(), 4);
    return 8 + uint64_t{header_size} + data_size;
  }

  void Open() {
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) Fail(std::string("cannot open: ") + std::strerror(errno));
    struct stat info;
    if (::fstat(fd, &info) != 0) Fail(std::string("cannot stat: ") + std::strerror(errno));
    file_size = static_cast<uint64_t>(info.st_size);

    std::vector<uint8_t> buffer;
    const size_t version_bytes = sizeof(kVersionLine) - 1;
    if (file_size < version_bytes) Fail("not a ROS bag: shorter than its version line");
    ReadAt(0, version_bytes, &buffer);
    if (std::memcmp(buffer.data(), kVersionLine, version_bytes) != 0) {
      Fail("not a ROS bag of format 2.0: it does not start with '#ROSBAG V2.0'");
    }
    // the bag header: at most the 4096 bytes writers pad it to, or the file's end
    ReadAt(version_bytes, std::min<uint64_t>(4096 + 8, file_size - version_bytes), &buffer);
    Record record;
    uint64_t index_position = 0;
    uint32_t connection_count = 0, chunk_count = 0;
    if (!ParseRecord(buffer.data(), buffer.size(), 0, &record) || record.op != kOpBagHeader ||
        !record.header.Get("index_pos", &index_position) ||
        !record.header.Get("conn_count", &connection_count) ||
        !record.header.Get("chunk_count", &chunk_count)) {
      Fail("malformed bag header record at byte " + std::to_string(version_bytes));
    }
    if (index_position == 0) {
      Scan(version_bytes + RecordBytes(version_bytes, &buffer));
    } else {
      ReadIndex(index_position, connection_count, chunk_count);
    }
    SortChunks();
    Summarize();
  }

  // The lengths of the record at `position`, when they and what they count lie within the file.
  bool RecordFits(uint64_t position, uint64_t* bytes, std::vector<uint8_t>* scratch) const {
    if (position > file_size || file_size - position < 8) return false;
    uint32_t header_size, data_size;
    ReadAt(position, 4, scratch);
    std::memcpy(&header_size, scratch->data(), 4);
    if (header_size > file_size - position - 8) return false;
    ReadAt(position + 4 + header_size, 4, scratch);
    std::memcpy(&data_size, scratch->data(), 4);
    *bytes = 8 + uint64_t{header_size} + data_size;
    return *bytes <= file_size - position;
  }

  // An unindexed bag (its writer was killed before it closed the bag): walks the chunks from `position`, each
  // with the index data records the writer puts after it, and takes the connections from the chunks' own
  // records. A chunk is kept only when it is whole and its index counts every message it holds; the first
  // that is not (the one the writer was writing when it died) ends the walk, and what follows is skipped.
  void Scan(uint64_t position) {
    std::vector<uint8_t> scratch, stored, records;
    Record record;
    while (true) {
      uint64_t bytes = 0;
      if (!RecordFits(position, &bytes, &scratch)) break;
      ReadAt(position, bytes, &scratch);
      if (!ParseRecord(scratch.data(), scratch.size(), 0, &record) || record.op != kOpChunk) break;
      Chunk chunk;
      chunk.position = position;
      chunk.start_ns = std::numeric_limits<int64_t>::max();
      std::map<uint32_t, uint32_t> indexed;  // per connection: messages its index data records list
      uint64_t next = position + bytes;
      while (RecordFits(next, &bytes, &scratch)) {
        ReadAt(next, bytes, &scratch);
        uint32_t version, id, count;
        if (!ParseRecord(scratch.data(), scratch.size(), 0, &record) || record.op != kOpIndexData ||
            !record.header.Get("ver", &version) || version != kIndexVersion ||
            !record.header.Get("conn", &id) || !record.header.Get("count", &count) ||
            record.data_size != size_t{count} * 12) {
          break;
        }
        for (uint32_t k = 0; k < count; ++k) {
          uint32_t entry[3];  // time (sec, nsec), offset
          std::memcpy(entry, record.data + size_t{k} * 12, 12);
          chunk.start_ns = std::min(chunk.start_ns, int64_t{entry[0]} * 1000000000 + entry[1]);
        }
        indexed[id] += count;
        next += bytes;
      }
      // what the chunk holds: its connection records and how many messages of each
      chunks.push_back(chunk);
      std::map<uint32_t, uint32_t> held;
      try {
        ReadChunk(static_cast<uint32_t>(chunks.size() - 1), &stored, &records);
        for (size_t pos = 0; pos < records.size(); pos = record.end) {
          const std::string where = " in the chunk at byte " + std::to_string(position);
          if (!ParseRecord(records.data(), records.size(), pos, &record)) Fail("malformed record" + where);
          uint32_t id;
          if (record.op == kOpConnection) ReadConnection(record, where);
          if (record.op == kOpMessageData && record.header.Get("conn", &id)) ++held[id];
        }
      } catch (const BagError&) {
        held.clear();  // damaged: not kept
      }
      if (held.empty() || held != indexed) {
        chunks.pop_back();
        break;
      }
      chunks.back().counts.assign(indexed.begin(), indexed.end());
      chunks.back().index_end = next;
      position = next;
    }
    for (const Chunk& chunk : chunks) {
      for (const auto& [id, count] : chunk.counts) {
        if (connections.count(id) == 0) {
          Fail("unindexed, and chunk at byte " + std::to_string(chunk.position) +
               " holds messages of connection " + std::to_string(id) + " that no chunk describes");
        }
      }
    }
    note = "unindexed (its writer did not close it, as a killed run's): read by walking its " +
           std::to_string(chunks.size()) + " whole chunks";
    if (position < file_size) {
      note += "; the last " + std::to_string(file_size - position) +
              " bytes (the chunk being written when it stopped) are skipped";
    }
  }

  // the connection records and chunk info records from index_pos to the end of the file
  void ReadIndex(uint64_t index_position, uint32_t connection_count, uint32_t chunk_count) {
    if (index_position > file_size)
      Fail("truncated: its index at byte " + std::to_string(index_position) + " is missing");
    std::vector<uint8_t> buffer;
    ReadAt(index_position, file_size - index_position, &buffer);
    size_t pos = 0;
    Record record;
    for (uint32_t i = 0; i < connection_count + chunk_count; ++i) {
      const std::string where = " at byte " + std::to_string(index_position + pos);
      if (!ParseRecord(buffer.data(), buffer.size(), pos, &record)) Fail("malformed index record" + where);
      pos = record.end;
      if (record.op == kOpConnection) {
        ReadConnection(record, where);
      } else if (record.op == kOpChunkInfo) {
        ReadChunkInfo(record, where);
      } else {
        Fail("expected a connection or chunk info record" + where + ", found op " +
             std::to_string(record.op));
      }
    }
    if (chunks.size() != chunk_count || connections.size() != connection_count) {
      Fail("its header counts " + std::to_string(connection_count) + " connections and " +
           std::to_string(chunk_count) + " chunks, its index holds " + std::to_string(connections.size()) +
           " and " + std::to_string(chunks.size()));
    }
    // a chunk's index data records fill the space up to the next chunk (or the index)
    std::vector<uint64_t> positions;
    for (const Chunk& chunk : chunks) positions.push_back(chunk.position);
    positions.push_back(index_position);
    std::sort(positions.begin(), positions.end());
    for (Chunk& chunk : chunks) {
      chunk.index_end = *std::upper_bound(positions.begin(), positions.end(), chunk.position);
    }
  }

  void SortChunks() {
    std::sort(chunks.begin(), chunks.end(), [](const Chunk& a, const Chunk& b) {
      return std::tie(a.start_ns, a.position) < std::tie(b.start_ns, b.position);
    });
  }

  void ReadConnection(const Record& record, const std::string& where) {
    uint32_t id;
    HeaderFields fields;
    const std::string_view* topic = record.header.Find("topic");
    if (!record.header.Get("conn", &id) || topic == nullptr || !fields.Parse(record.data, record.data_size)) {
      Fail("malformed connection record" + where);
    }
    Connection connection;
    connection.topic = std::string(*topic);
    for (const auto& [name, value] :
         {std::pair{"type", &connection.type.datatype}, std::pair{"md5sum", &connection.type.md5},
          std::pair{"message_definition", &connection.type.definition}}) {
      const std::string_view* field = fields.Find(name);
      if (field == nullptr) Fail("connection " + std::to_string(id) + where + " has no " + name);
      *value = std::string(*field);
    }
    if (const std::string_view* callerid = fields.Find("callerid"))
      connection.publisher = std::string(*callerid);
    connections[id] = std::move(connection);
  }

  void ReadChunkInfo(const Record& record, const std::string& where) {
    Chunk chunk;
    uint32_t version, count;
    if (!record.header.Get("ver", &version) || version != kChunkInfoVersion ||
        !record.header.Get("chunk_pos", &chunk.position) ||
        !record.header.GetTime("start_time", &chunk.start_ns) || !record.header.Get("count", &count) ||
        record.data_size != size_t{count} * 8) {
      Fail("malformed chunk info record" + where);
    }
    chunk.counts.resize(count);
    for (uint32_t k = 0; k < count; ++k) {
      uint32_t id_and_count[2];
      std::memcpy(id_and_count, record.data + size_t{k} * 8, 8);
      chunk.counts[k] = {id_and_count[0], id_and_count[1]};
    }
    chunks.push_back(std::move(chunk));
  }

  // The index data records of chunk `c` (its position is found here: they follow its record), each entry of
  // a connection in `wanted` (all when null) passed to `take`.
  template <class Take>
  void ReadChunkIndex(uint32_t c, const std::set<uint32_t>* wanted, std::vector<uint8_t>* buffer,
                      const Take& take) const {
    const Chunk& chunk = chunks[c];
    const uint64_t index_begin = chunk.position + RecordBytes(chunk.position, buffer);
    if (index_begin > chunk.index_end)
      Fail("chunk at byte " + std::to_string(chunk.position) + " overruns the next");
    ReadAt(index_begin, chunk.index_end - index_begin, buffer);
    size_t pos = 0;
    Record record;
    for (size_t i = 0; i < chunk.counts.size(); ++i) {
      const std::string where = " at byte " + std::to_string(index_begin + pos);
      uint32_t version, id, count;
      if (!ParseRecord(buffer->data(), buffer->size(), pos, &record) || record.op != kOpIndexData ||
          !record.header.Get("ver", &version) || version != kIndexVersion ||
          !record.header.Get("conn", &id) || !record.header.Get("count", &count) ||
          record.data_size != size_t{count} * 12) {
        Fail("malformed index data record" + where);
      }
      pos = record.end;
      if (connections.count(id) == 0)
        Fail("index data record" + where + " names unknown connection " + std::to_string(id));
      if (wanted && wanted->count(id) == 0) continue;
      for (uint32_t k = 0; k < count; ++k) {
        uint32_t entry[3];  // time (sec, nsec), offset
        std::memcpy(entry, record.data + size_t{k} * 12, 12);
        take(Entry{int64_t{entry[0]} * 1000000000 + entry[1], c, entry[2], id});
      }
    }
  }

  // per topic: messages, first and last time, and the type of its first connection
  void Summarize() {
    std::map<std::string, BagTopicInfo> by_topic;
    std::map<uint32_t, std::pair<int64_t, int64_t>> times;  // per connection: first, last
    std::map<uint32_t, uint64_t> counts;
    std::vector<uint8_t> buffer;
    for (uint32_t c = 0; c < chunks.size(); ++c) {
      ReadChunkIndex(c, nullptr, &buffer, [&](const Entry& e) {
        auto [it, inserted] = times.try_emplace(e.connection, e.time_ns, e.time_ns);
        it->second.first = std::min(it->second.first, e.time_ns);
        it->second.second = std::max(it->second.second, e.time_ns);
        ++counts[e.connection];
      });
    }
    for (const auto& [id, span] : times) {
      const Connection& connection = connections.at(id);
      auto [it, inserted] = by_topic.try_emplace(connection.topic);
      BagTopicInfo& info = it->second;
      if (inserted) {
        info.topic = connection.topic;
        info.datatype = connection.type.datatype;
        info.md5 = connection.type.md5;
        info.definition = connection.type.definition;
        info.first_time_ns = span.first;
        info.last_time_ns = span.second;
      }
      info.count += counts[id];
      info.first_time_ns = std::min(info.first_time_ns, span.first);
      info.last_time_ns = std::max(info.last_time_ns, span.second);
    }
    for (auto& [name, info] : by_topic) {
      if (topics.empty()) {
        start_time_ns = info.first_time_ns;
        end_time_ns = info.last_time_ns;
      }
      start_time_ns = std::min(start_time_ns, info.first_time_ns);
      end_time_ns = std::max(end_time_ns, info.last_time_ns);
      topics.push_back(std::move(info));
    }
  }

  // chunk `c`'s records, uncompressed, into `out`
  void ReadChunk(uint32_t c, std::vector<uint8_t>* stored, std::vector<uint8_t>* out) const {
    const Chunk& chunk = chunks[c];
    const std::string where = "chunk at byte " + std::to_string(chunk.position);
    ReadAt(chunk.position, RecordBytes(chunk.position, stored), stored);
    Record record;
    uint32_t size;
    const std::string_view* compression = nullptr;
    if (!ParseRecord(stored->data(), stored->size(), 0, &record) || record.op != kOpChunk ||
        !record.header.Get("size", &size) || (compression = record.header.Find("compression")) == nullptr) {
      Fail("malformed " + where);
    }
    auto* data = reinterpret_cast<char*>(const_cast<uint8_t*>(record.data));
    unsigned int out_size = size;
    // a damaged size must not make the reader allocate gigabytes: uncompressed data is exactly its size,
    // and lz4 cannot compress by more than 255:1 (bz2 can, so its size is taken as stated)
    const bool lz4 = *compression == "lz4";
    if ((*compression == "none" && record.data_size != size) ||
        (lz4 && size > 255 * uint64_t{record.data_size} + (1 << 16))) {
      Fail(where + ": holds " + std::to_string(record.data_size) + " bytes, cannot be " +
           std::to_string(size) + " uncompressed");
    }
    out->resize(size);
    if (*compression == "none") {
      std::memcpy(out->data(), record.data, size);
    } else if (lz4) {
      const int status = roslz4_buffToBuffDecompress(data, record.data_size,
                                                     reinterpret_cast<char*>(out->data()), &out_size);
      if (status != ROSLZ4_OK || out_size != size) Fail(where + ": lz4 data does not decompress to its size");
    } else if (*compression == "bz2") {
      const int status = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(out->data()), &out_size, data,
                                                    record.data_size, 0, 0);
      if (status != BZ_OK || out_size != size) Fail(where + ": bz2 data does not decompress to its size");
    } else {
      Fail(where + ": unknown compression '" + std::string(*compression) + "' (none, lz4 and bz2 are read)");
    }
  }
};

BagReader::BagReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->Open();
}

BagReader::~BagReader() {
  if (impl_->fd >= 0) ::close(impl_->fd);
}

const std::string& BagReader::path() const { return impl_->path; }

std::vector<BagTopicInfo> BagReader::Topics() const { return impl_->topics; }

int64_t BagReader::start_time_ns() const { return impl_->start_time_ns; }

int64_t BagReader::end_time_ns() const { return impl_->end_time_ns; }

const std::string& BagReader::note() const { return impl_->note; }

void BagReader::ForEach(const std::vector<std::string>& topics,
                        const std::function<bool(const BagMessage&)>& visit) const {
  const Impl& impl = *impl_;
  std::set<uint32_t> wanted;
  for (const auto& [id, connection] : impl.connections) {
    if (topics.empty() || std::find(topics.begin(), topics.end(), connection.topic) != topics.end()) {
      wanted.insert(id);
    }
  }
  // k-way merge of the chunks' indexes: a chunk's entries join once the merge reaches its start time, so
  // only the chunks that overlap in time are held at once (one, in a bag written in time order)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> pending;
  std::vector<uint8_t> buffer, stored, records, bytes;
  int64_t loaded = -1;  // the chunk in `records`
  Record record;
  uint32_t next_chunk = 0;
  while (true) {
    while (next_chunk < impl.chunks.size() &&
           (pending.empty() || impl.chunks[next_chunk].start_ns <= pending.top().time_ns)) {
      const Chunk& chunk = impl.chunks[next_chunk];
      const bool has_wanted = std::any_of(chunk.counts.begin(), chunk.counts.end(),
                                          [&](const auto& count) { return wanted.count(count.first) > 0; });
      if (has_wanted)
        impl.ReadChunkIndex(next_chunk, &wanted, &buffer, [&](const Entry& e) { pending.push(e); });
      ++next_chunk;
    }
    if (pending.empty()) return;
    const Entry entry = pending.top();
    pending.pop();
    if (loaded != entry.chunk) {
      impl.ReadChunk(entry.chunk, &stored, &records);
      loaded = entry.chunk;
    }
    uint32_t id;
    if (!ParseRecord(records.data(), records.size(), entry.offset, &record) || record.op != kOpMessageData ||
        !record.header.Get("conn", &id) || id != entry.connection) {
      impl.Fail("the index of chunk at byte " + std::to_string(impl.chunks[entry.chunk].position) +
                " points at no message of connection " + std::to_string(entry.connection) + " at offset " +
                std::to_string(entry.offset));
    }
    bytes.assign(record.data, record.data + record.data_size);
    const Connection& connection = impl.connections.at(id);
    if (!visit(BagMessage{connection.topic, connection.type, entry.time_ns, bytes, connection.publisher}))
      return;
  }
}

uint64_t ReindexBag(const std::string& in, const std::string& out, const BagWriterOptions& options) {
  const BagReader reader(in);
  BagWriter writer(out, options);
  uint64_t messages = 0;
  reader.ForEach({}, [&](const BagMessage& m) {
    writer.Write(m.topic, m.type, m.record_time_ns, m.bytes.data(), m.bytes.size(), m.publisher);
    ++messages;
    return true;
  });
  writer.Close();
  return messages;
}

}  // namespace iapsim::bridge
