#include "bridge/bag.h"

#include <ros/serialization.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/query.h>
#include <rosbag/view.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <unordered_map>
#include <utility>

namespace iapsim::bridge {
namespace {

BagError ErrorFor(const std::string& path, const std::string& what) {
  return BagError("bag '" + path + "': " + what);
}

int64_t ToNs(const ros::Time& time) { return static_cast<int64_t>(time.toNSec()); }

}  // namespace

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

const std::string& BagReader::path() const { return impl_->path; }

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
