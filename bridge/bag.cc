#include "bridge/bag.h"

#include <ros/message_traits.h>
#include <ros/serialization.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/query.h>
#include <rosbag/view.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <tuple>
#include <unordered_map>
#include <utility>

namespace iapsim::bridge {
namespace {

// one already serialized message of a type known only at run time
struct RawPayload {
  const TypeInfo* type;
  const uint8_t* data;
  uint32_t size;
};

}  // namespace
}  // namespace iapsim::bridge

// rosbag takes the type identity and the bytes of a message through these traits
namespace ros {
namespace message_traits {

template <>
struct MD5Sum<iapsim::bridge::RawPayload> {
  static const char* value(const iapsim::bridge::RawPayload& m) { return m.type->md5.c_str(); }
};

template <>
struct DataType<iapsim::bridge::RawPayload> {
  static const char* value(const iapsim::bridge::RawPayload& m) { return m.type->datatype.c_str(); }
};

template <>
struct Definition<iapsim::bridge::RawPayload> {
  static const char* value(const iapsim::bridge::RawPayload& m) { return m.type->definition.c_str(); }
};

}  // namespace message_traits

namespace serialization {

template <>
struct Serializer<iapsim::bridge::RawPayload> {
  template <typename Stream>
  static void write(Stream& stream, const iapsim::bridge::RawPayload& m) {
    // advance() checks the bound before the copy
    if (m.size > 0) std::memcpy(stream.advance(m.size), m.data, m.size);
  }

  static uint32_t serializedLength(const iapsim::bridge::RawPayload& m) { return m.size; }
};

}  // namespace serialization
}  // namespace ros

namespace iapsim::bridge {
namespace {

BagError ErrorFor(const std::string& path, const std::string& what) {
  return BagError("bag '" + path + "': " + what);
}

// a bag cannot store times below ros::TIME_MIN (1 ns) nor above ros::TIME_MAX
ros::Time ToBagTime(const std::string& path, int64_t time_ns) {
  if (time_ns < 0) throw ErrorFor(path, "negative record time " + std::to_string(time_ns) + " ns");
  if (time_ns == 0) return ros::TIME_MIN;
  if (static_cast<uint64_t>(time_ns) > ros::TIME_MAX.toNSec()) {
    throw ErrorFor(path, "record time " + std::to_string(time_ns) + " ns is beyond ros::TIME_MAX");
  }
  ros::Time time;
  time.fromNSec(static_cast<uint64_t>(time_ns));
  return time;
}

int64_t ToNs(const ros::Time& time) { return static_cast<int64_t>(time.toNSec()); }

}  // namespace

struct BagWriter::Impl {
  using ConnectionKey = std::tuple<std::string, std::string, std::string, std::string>;

  std::string path;
  // null once closed; heap-held so a bag whose close failed can be abandoned (see Close)
  std::unique_ptr<rosbag::Bag> bag;
  // one header per (topic, publisher, datatype, md5): rosbag keys its connections by header contents
  std::map<ConnectionKey, boost::shared_ptr<ros::M_string>> headers;

  const boost::shared_ptr<ros::M_string>& HeaderFor(const std::string& topic, const TypeInfo& type,
                                                    const std::string& publisher) {
    auto [it, inserted] =
        headers.try_emplace(ConnectionKey{topic, publisher, type.datatype, type.md5}, nullptr);
    if (inserted) {
      it->second = boost::make_shared<ros::M_string>();
      ros::M_string& header = *it->second;
      header["callerid"] = publisher;
      header["topic"] = topic;
      header["type"] = type.datatype;
      header["md5sum"] = type.md5;
      header["message_definition"] = type.definition;
    }
    return it->second;
  }
};

BagWriter::BagWriter(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  try {
    impl_->bag = std::make_unique<rosbag::Bag>();
    impl_->bag->open(path, rosbag::bagmode::Write);
  } catch (const std::exception& e) {
    throw ErrorFor(path, std::string("cannot create: ") + e.what());
  }
}

BagWriter::~BagWriter() {
  try {
    Close();
  } catch (const std::exception& e) {
    // a destructor must not throw; the caller who needs the error calls Close() first
    spdlog::error("closing bag failed: {}", e.what());
  }
}

void BagWriter::Write(const std::string& topic, const TypeInfo& type, int64_t record_time_ns,
                      const uint8_t* data, size_t size, const std::string& publisher) {
  if (!impl_->bag) throw ErrorFor(impl_->path, "write to '" + topic + "' after Close()");
  if (topic.empty()) throw ErrorFor(impl_->path, "empty topic name");
  if (type.datatype.empty() || type.md5.empty() || type.definition.empty()) {
    throw ErrorFor(impl_->path, "incomplete type '" + type.datatype + "' on '" + topic +
                                    "': datatype, md5 and definition are all required");
  }
  if (size > std::numeric_limits<uint32_t>::max()) {
    throw ErrorFor(impl_->path, "message on '" + topic + "' exceeds 4 GiB");
  }
  if (size > 0 && data == nullptr) throw ErrorFor(impl_->path, "null data on '" + topic + "'");
  const ros::Time time = ToBagTime(impl_->path, record_time_ns);
  const RawPayload payload{&type, data, static_cast<uint32_t>(size)};
  try {
    impl_->bag->write(topic, time, payload, impl_->HeaderFor(topic, type, publisher));
  } catch (const std::exception& e) {
    throw ErrorFor(impl_->path, "writing '" + topic + "' failed: " + e.what());
  }
}

void BagWriter::Close() {
  if (!impl_->bag) return;
  try {
    impl_->bag->close();
  } catch (const std::exception& e) {
    // rosbag::Bag's destructor would retry the failed close and throw out of it: abandon the object
    static_cast<void>(impl_->bag.release());
    throw ErrorFor(impl_->path, std::string("close failed: ") + e.what());
  }
  impl_->bag.reset();
}

const std::string& BagWriter::path() const { return impl_->path; }

struct BagReader::Impl {
  std::string path;
  std::unique_ptr<rosbag::Bag> bag;
  // summary built once at open from the in-memory index
  std::vector<BagTopicInfo> topics;
  int64_t start_time_ns = 0;
  int64_t end_time_ns = 0;

  void Summarize() {
    std::map<std::string, BagTopicInfo> by_topic;
    rosbag::View view(*bag);
    // iterating a view reads only the index; no message data is loaded
    for (const rosbag::MessageInstance& m : view) {
      const int64_t time_ns = ToNs(m.getTime());
      auto [it, inserted] = by_topic.try_emplace(m.getTopic());
      BagTopicInfo& info = it->second;
      if (inserted) {
        info.topic = m.getTopic();
        info.datatype = m.getDataType();
        info.md5 = m.getMD5Sum();
        info.definition = m.getMessageDefinition();
        info.first_time_ns = time_ns;
        info.last_time_ns = time_ns;
      }
      ++info.count;
      info.first_time_ns = std::min(info.first_time_ns, time_ns);
      info.last_time_ns = std::max(info.last_time_ns, time_ns);
    }
    topics.reserve(by_topic.size());
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
};

BagReader::BagReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  try {
    impl_->bag = std::make_unique<rosbag::Bag>();
    impl_->bag->open(path, rosbag::bagmode::Read);
    impl_->Summarize();
  } catch (const std::exception& e) {
    throw ErrorFor(path, std::string("cannot open: ") + e.what());
  }
}

BagReader::~BagReader() {
  try {
    impl_->bag->close();
  } catch (const std::exception& e) {
    // as in BagWriter::Close: rosbag::Bag's destructor would retry and throw
    spdlog::error("closing bag '{}' failed: {}", impl_->path, e.what());
    static_cast<void>(impl_->bag.release());
  }
}

std::vector<BagTopicInfo> BagReader::Topics() const { return impl_->topics; }

int64_t BagReader::start_time_ns() const { return impl_->start_time_ns; }

int64_t BagReader::end_time_ns() const { return impl_->end_time_ns; }

void BagReader::ForEach(const std::vector<std::string>& topics,
                        const std::function<bool(const BagMessage&)>& visit) const {
  std::unique_ptr<rosbag::View> view;
  if (topics.empty()) {
    view = std::make_unique<rosbag::View>(*impl_->bag);
  } else {
    view = std::make_unique<rosbag::View>(*impl_->bag, rosbag::TopicQuery(topics));
  }
  // getters return references into the bag's connection records, so a field's address names the connection
  std::unordered_map<const std::string*, TypeInfo> types;
  std::vector<uint8_t> bytes;
  for (const rosbag::MessageInstance& m : *view) {
    auto [it, inserted] = types.try_emplace(&m.getMessageDefinition());
    if (inserted) it->second = TypeInfo{m.getDataType(), m.getMD5Sum(), m.getMessageDefinition()};
    // only the data read touches the file; the visitor's own exceptions pass through untouched
    try {
      const uint32_t size = m.size();
      bytes.resize(size);
      ros::serialization::OStream stream(bytes.data(), size);
      m.write(stream);
    } catch (const std::exception& e) {
      throw ErrorFor(impl_->path, "reading '" + m.getTopic() + "' at " + std::to_string(ToNs(m.getTime())) +
                                      " ns failed: " + e.what());
    }
    if (!visit(BagMessage{m.getTopic(), it->second, ToNs(m.getTime()), bytes})) return;
  }
}

}  // namespace iapsim::bridge
