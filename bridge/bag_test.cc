#include "bridge/bag.h"

#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <iapsim_msgs/IapState.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <rosgraph_msgs/Clock.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "bridge/message_format.h"
#include "bridge/message_schema.h"

namespace iapsim::bridge {
namespace {

// One serialized message of a type known only at run time: how the tests hand raw bytes to rosbag_storage's
// writer, the reference that BagWriter's bytes are compared with.
struct RawPayload {
  const TypeInfo* type;
  const uint8_t* data;
  uint32_t size;
};

}  // namespace
}  // namespace iapsim::bridge

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
    if (m.size > 0) std::memcpy(stream.advance(m.size), m.data, m.size);
  }
  static uint32_t serializedLength(const iapsim::bridge::RawPayload& m) { return m.size; }
};

}  // namespace serialization
}  // namespace ros

namespace iapsim::bridge {
namespace {

// removes every file TempPath handed out once the tests of this process are done
class TempFiles : public ::testing::Environment {
 public:
  static std::vector<std::string>& paths() {
    static std::vector<std::string> paths;
    return paths;
  }
  void TearDown() override {
    for (const std::string& path : paths()) std::remove(path.c_str());
  }
};
[[maybe_unused]] ::testing::Environment* const kTempFiles =
    ::testing::AddGlobalTestEnvironment(new TempFiles);

// unique per test and process so parallel ctest runs never share a file
std::string TempPath(const std::string& name) {
  const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string path = ::testing::TempDir() + "iapsim_" + test->test_suite_name() + "_" + test->name() + "_" +
                     std::to_string(::getpid()) + "_" + name;
  TempFiles::paths().push_back(path);
  return path;
}

std::vector<char> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

iapsim_msgs::IapState MakeState(uint64_t step) {
  iapsim_msgs::IapState state;
  state.header.stamp.fromNSec(step * 5000000);
  state.header.frame_id = "W";
  state.step = step;
  state.bodies.resize(4);
  for (size_t i = 0; i < state.bodies.size(); ++i) {
    state.bodies[i].name = i == 0 ? "platform" : "sub" + std::to_string(i);
    state.bodies[i].pose_W.position.x = 0.48 * static_cast<double>(i) + 1e-3 * static_cast<double>(step);
    state.bodies[i].pose_W.orientation.w = 1.0;
  }
  state.joints.resize(3);
  state.external_wrench_P.force.z = 19.62;
  return state;
}

geometry_msgs::PoseStamped MakePose(double x_m) {
  geometry_msgs::PoseStamped pose;
  pose.header.frame_id = "W";
  pose.header.stamp.fromNSec(0);  // header stamps are payload: 0 must survive
  pose.pose.position.x = x_m;
  pose.pose.orientation.w = 1.0;
  return pose;
}

rosgraph_msgs::Clock MakeClock(int64_t t_ns) {
  rosgraph_msgs::Clock clock;
  clock.clock.fromNSec(static_cast<uint64_t>(t_ns));
  return clock;
}

struct Record {
  std::string topic;
  const TypeInfo* type;
  int64_t time_ns;
  std::vector<uint8_t> bytes;
  std::string publisher;
};

void WriteAll(const std::string& path, const std::vector<Record>& records,
              const BagWriterOptions& options = {}) {
  BagWriter writer(path, options);
  for (const Record& r : records) {
    writer.Write(r.topic, *r.type, r.time_ns, r.bytes.data(), r.bytes.size(), r.publisher);
  }
  writer.Close();
}

// three types on three topics, times strictly increasing so the read order is fully defined
std::vector<Record> MixedRecords() {
  std::vector<Record> records;
  const TypeInfo& state = TypeInfoOf<iapsim_msgs::IapState>();
  const TypeInfo& pose = TypeInfoOf<geometry_msgs::PoseStamped>();
  const TypeInfo& clock = TypeInfoOf<rosgraph_msgs::Clock>();
  records.push_back({"/clock", &clock, 1000, Encode(MakeClock(1000)), "/sim"});
  records.push_back({"/iap/state", &state, 5000000, Encode(MakeState(1)), "/physics"});
  records.push_back({"/uav1/pose", &pose, 5000001, Encode(MakePose(0.5)), "/vio1"});
  records.push_back({"/clock", &clock, 6000000, Encode(MakeClock(6000000)), "/sim"});
  records.push_back({"/iap/state", &state, 10000000, Encode(MakeState(2)), "/physics"});
  records.push_back({"/uav1/pose", &pose, 12000000, Encode(MakePose(-0.25)), "/vio1"});
  records.push_back({"/iap/state", &state, 15000000, Encode(MakeState(3)), "/physics"});
  return records;
}

TEST(BagRoundTrip, SeveralTypesKeepExactBytesAndSummary) {
  const std::string path = TempPath("mixed.bag");
  const std::vector<Record> records = MixedRecords();
  WriteAll(path, records);

  const BagReader reader(path);
  const std::vector<BagTopicInfo> topics = reader.Topics();
  ASSERT_EQ(topics.size(), 3u);
  EXPECT_EQ(topics[0].topic, "/clock");
  EXPECT_EQ(topics[1].topic, "/iap/state");
  EXPECT_EQ(topics[2].topic, "/uav1/pose");
  EXPECT_EQ(topics[0].datatype, "rosgraph_msgs/Clock");
  EXPECT_EQ(topics[1].datatype, "iapsim_msgs/IapState");
  EXPECT_EQ(topics[1].md5, TypeInfoOf<iapsim_msgs::IapState>().md5);
  EXPECT_EQ(topics[1].definition, TypeInfoOf<iapsim_msgs::IapState>().definition);
  EXPECT_EQ(topics[2].datatype, "geometry_msgs/PoseStamped");
  EXPECT_EQ(topics[0].count, 2u);
  EXPECT_EQ(topics[1].count, 3u);
  EXPECT_EQ(topics[2].count, 2u);
  EXPECT_EQ(topics[0].first_time_ns, 1000);
  EXPECT_EQ(topics[0].last_time_ns, 6000000);
  EXPECT_EQ(topics[1].first_time_ns, 5000000);
  EXPECT_EQ(topics[1].last_time_ns, 15000000);
  EXPECT_EQ(topics[2].first_time_ns, 5000001);
  EXPECT_EQ(topics[2].last_time_ns, 12000000);
  EXPECT_EQ(reader.start_time_ns(), 1000);
  EXPECT_EQ(reader.end_time_ns(), 15000000);

  size_t index = 0;
  reader.ForEach({}, [&](const BagMessage& m) {
    EXPECT_LT(index, records.size());
    if (index >= records.size()) return false;
    const Record& expected = records[index++];
    EXPECT_EQ(m.topic, expected.topic);
    EXPECT_EQ(m.record_time_ns, expected.time_ns);
    EXPECT_EQ(m.type.datatype, expected.type->datatype);
    EXPECT_EQ(m.type.md5, expected.type->md5);
    EXPECT_EQ(m.type.definition, expected.type->definition);
    EXPECT_EQ(m.bytes, expected.bytes);
    return true;
  });
  EXPECT_EQ(index, records.size());

  // the bytes decode back to the message written
  iapsim_msgs::IapState state;
  std::string error;
  bool found = false;
  reader.ForEach({"/iap/state"}, [&](const BagMessage& m) {
    found = Decode(m.bytes, &state, &error);
    return false;
  });
  ASSERT_TRUE(found) << error;
  EXPECT_EQ(state, MakeState(1));
}

TEST(BagTime, ZeroIsStoredAsOneNanosecondAndNegativeIsRejected) {
  const std::string path = TempPath("zero.bag");
  const auto bytes = Encode(MakePose(1.0));
  {
    BagWriter writer(path);
    writer.Write("/pose", TypeInfoOf<geometry_msgs::PoseStamped>(), 0, bytes.data(), bytes.size(), "/a");
    EXPECT_THROW(
        writer.Write("/pose", TypeInfoOf<geometry_msgs::PoseStamped>(), -1, bytes.data(), bytes.size(), "/a"),
        BagError);
    writer.Close();
  }
  const BagReader reader(path);
  ASSERT_EQ(reader.Topics().size(), 1u);
  EXPECT_EQ(reader.Topics()[0].count, 1u);
  EXPECT_EQ(reader.Topics()[0].first_time_ns, 1);
  EXPECT_EQ(reader.start_time_ns(), 1);
  int64_t time_ns = -1;
  std::vector<uint8_t> read_bytes;
  reader.ForEach({}, [&](const BagMessage& m) {
    time_ns = m.record_time_ns;
    read_bytes = m.bytes;
    return true;
  });
  EXPECT_EQ(time_ns, 1);
  // the header stamp inside the payload keeps its 0
  EXPECT_EQ(read_bytes, bytes);
}

TEST(BagForEach, FiltersTopicsAndStopsEarly) {
  const std::string path = TempPath("filter.bag");
  WriteAll(path, MixedRecords());
  const BagReader reader(path);

  std::vector<std::tuple<std::string, int64_t>> seen;
  reader.ForEach({"/iap/state", "/uav1/pose"}, [&](const BagMessage& m) {
    seen.emplace_back(m.topic, m.record_time_ns);
    return true;
  });
  const std::vector<std::tuple<std::string, int64_t>> expected = {{"/iap/state", 5000000},
                                                                  {"/uav1/pose", 5000001},
                                                                  {"/iap/state", 10000000},
                                                                  {"/uav1/pose", 12000000},
                                                                  {"/iap/state", 15000000}};
  EXPECT_EQ(seen, expected);

  int visits = 0;
  reader.ForEach({}, [&](const BagMessage&) { return ++visits < 2; });
  EXPECT_EQ(visits, 2);

  visits = 0;
  reader.ForEach({"/no/such/topic"}, [&](const BagMessage&) { return ++visits > 0; });
  EXPECT_EQ(visits, 0);
}

TEST(BagForEach, EqualTimesOnOneConnectionKeepWriteOrder) {
  const std::string path = TempPath("ties.bag");
  std::vector<Record> records;
  for (int k = 0; k < 5; ++k) {
    records.push_back({"/clock", &TypeInfoOf<rosgraph_msgs::Clock>(), 42, Encode(MakeClock(k)), "/sim"});
  }
  WriteAll(path, records);
  std::vector<std::vector<uint8_t>> seen;
  BagReader(path).ForEach({}, [&](const BagMessage& m) {
    seen.push_back(m.bytes);
    return true;
  });
  ASSERT_EQ(seen.size(), records.size());
  for (size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], records[i].bytes) << i;
}

TEST(BagWriter, IdenticalWritesGiveByteIdenticalFiles) {
  // enough data for several rosbag chunks (768 KiB each by default)
  std::vector<Record> records = MixedRecords();
  const TypeInfo& state = TypeInfoOf<iapsim_msgs::IapState>();
  auto big = MakeState(4);
  big.bodies.resize(200);
  for (int k = 0; k < 300; ++k) {
    big.step = static_cast<uint64_t>(k);
    records.push_back({"/iap/state", &state, 20000000 + 5000000LL * k, Encode(big), "/physics"});
  }
  const std::string path_a = TempPath("a.bag");
  const std::string path_b = TempPath("b.bag");
  WriteAll(path_a, records);
  WriteAll(path_b, records);
  const std::vector<char> a = ReadFile(path_a);
  const std::vector<char> b = ReadFile(path_b);
  ASSERT_GT(a.size(), 2u * 768u * 1024u);
  EXPECT_TRUE(a == b) << "bags differ: " << a.size() << " vs " << b.size() << " bytes";
  EXPECT_EQ(BagReader(path_a).Topics()[1].count, 303u);
}

TEST(BagWriter, DestructorClosesAndCloseIsIdempotent) {
  const std::string path = TempPath("dtor.bag");
  const auto bytes = Encode(MakeClock(7));
  {
    BagWriter writer(path);
    EXPECT_EQ(writer.path(), path);
    writer.Write("/clock", TypeInfoOf<rosgraph_msgs::Clock>(), 7, bytes.data(), bytes.size(), "/sim");
  }
  EXPECT_EQ(BagReader(path).Topics().at(0).count, 1u);

  BagWriter writer(TempPath("closed.bag"));
  writer.Close();
  writer.Close();
  EXPECT_THROW(
      writer.Write("/clock", TypeInfoOf<rosgraph_msgs::Clock>(), 7, bytes.data(), bytes.size(), "/sim"),
      BagError);
}

TEST(BagWriter, RejectsIncompleteTypes) {
  BagWriter writer(TempPath("incomplete.bag"));
  const auto bytes = Encode(MakeClock(7));
  TypeInfo type = TypeInfoOf<rosgraph_msgs::Clock>();
  type.definition.clear();
  EXPECT_THROW(writer.Write("/clock", type, 7, bytes.data(), bytes.size(), "/sim"), BagError);
}

TEST(BagErrors, CreatingInMissingFolderNamesThePath) {
  const std::string path = TempPath("no_such_folder/x.bag");
  try {
    BagWriter writer(path);
    FAIL() << "expected BagError";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(BagErrors, MissingFileNamesThePath) {
  const std::string path = TempPath("missing.bag");
  try {
    BagReader reader(path);
    FAIL() << "expected BagError";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(BagErrors, GarbageAndEmptyFilesNameThePath) {
  const std::string garbage = TempPath("garbage.bag");
  {
    std::ofstream out(garbage, std::ios::binary);
    // a small record length: rosbag allocates whatever length a record claims before reading it
    const char junk[] = "#ROSBAG V2.0\n\x0c\0\0\0not a header and then some";
    out.write(junk, sizeof(junk) - 1);
  }
  const std::string text = TempPath("text.bag");
  {
    std::ofstream out(text, std::ios::binary);
    out << "hello\n";
  }
  const std::string empty = TempPath("empty.bag");
  { std::ofstream out(empty, std::ios::binary); }
  for (const std::string& path : {garbage, text, empty}) {
    SCOPED_TRACE(path);
    try {
      BagReader reader(path);
      FAIL() << "expected BagError";
    } catch (const BagError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

TEST(BagReader, EmptyBagHasNoTopics) {
  const std::string path = TempPath("nothing.bag");
  BagWriter(path).Close();
  const BagReader reader(path);
  EXPECT_TRUE(reader.Topics().empty());
  EXPECT_EQ(reader.start_time_ns(), 0);
  EXPECT_EQ(reader.end_time_ns(), 0);
  int visits = 0;
  reader.ForEach({}, [&](const BagMessage&) { return ++visits > 0; });
  EXPECT_EQ(visits, 0);
}

// runs a shell command, collecting its output; false when it cannot run or exits non-zero
bool RunCommand(const std::string& command, std::string* output) {
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return false;
  std::array<char, 4096> buffer;
  size_t n = 0;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) output->append(buffer.data(), n);
  return ::pclose(pipe) == 0;
}

bool HavePythonRosbag() { return std::system("/usr/bin/python3 -c 'import rosbag' >/dev/null 2>&1") == 0; }

// runs `script` with Debian's python (the one with python3-rosbag), the arguments quoted
bool RunPython(const std::string& script, const std::vector<std::string>& args, std::string* output) {
  const std::string path = TempPath("script.py");
  std::ofstream(path) << script;
  std::string command = "/usr/bin/python3 '" + path + "'";
  for (const std::string& arg : args) command += " '" + arg + "'";
  return RunCommand(command + " 2>&1", output);
}

TEST(BagPython, DebianRosbagReadsTheBag) {
  if (!HavePythonRosbag()) GTEST_SKIP() << "/usr/bin/python3 cannot import rosbag";
  const std::string path = TempPath("python.bag");
  WriteAll(path, MixedRecords());
  // messages are rebuilt from the stored definitions, so this also checks type, md5 and payload
  const std::string script =
      "import sys, rosbag\n"
      "bag = rosbag.Bag(sys.argv[1])\n"
      "info = bag.get_type_and_topic_info().topics\n"
      "steps = [m.step for _, m, _ in bag.read_messages(topics=['/iap/state'])]\n"
      "poses = [m.pose.position.x for _, m, _ in bag.read_messages(topics=['/uav1/pose'])]\n"
      "n = sum(1 for _ in bag.read_messages())\n"
      "print(n, bag.get_message_count(), info['/iap/state'].msg_type, steps, poses)\n";
  std::string output;
  ASSERT_TRUE(RunPython(script, {path}, &output)) << output;
  EXPECT_EQ(output, "7 7 iapsim_msgs/IapState [1, 2, 3] [0.5, -0.25]\n");
}

// Many connections over many chunks: three publishers on seven topics (one topic from two of them),
// messages from 13 bytes to 12 KiB, several at each record time, one written out of time order.
std::vector<Record> ManyRecords() {
  const TypeInfo& state = TypeInfoOf<iapsim_msgs::IapState>();
  const TypeInfo& pose = TypeInfoOf<geometry_msgs::PoseStamped>();
  const TypeInfo& clock = TypeInfoOf<rosgraph_msgs::Clock>();
  std::vector<Record> records;
  for (int step = 0; step < 400; ++step) {
    const int64_t t_ns = step * 1000000LL;
    records.push_back({"/clock", &clock, t_ns, Encode(MakeClock(t_ns)), "/physics"});
    iapsim_msgs::IapState s = MakeState(static_cast<uint64_t>(step));
    s.bodies.resize(static_cast<size_t>(1 + step % 40));
    records.push_back({"/iap/state", &state, t_ns, Encode(s), "/physics"});
    if (step % 5 == 0) records.push_back({"/iap/pose_cmd", &pose, t_ns, Encode(MakePose(step)), "/control"});
    if (step % 7 == 0) records.push_back({"/iap/pose_cmd", &pose, t_ns, Encode(MakePose(-step)), "/pilot"});
    if (step % 3 == 0) {
      records.push_back(
          {"/sub" + std::to_string(step % 4) + "/pose", &pose, t_ns, Encode(MakePose(0.5 * step)), "/vio"});
    }
  }
  records.push_back({"/clock", &clock, 150000000, Encode(MakeClock(1)), "/physics"});
  return records;
}

std::string Hex(const std::string& bytes) {
  static const char kDigits[] = "0123456789abcdef";
  std::string hex;
  for (const unsigned char c : bytes) hex += {kDigits[c >> 4], kDigits[c & 15]};
  return hex;
}

std::string Hex(const std::vector<uint8_t>& bytes) { return Hex(std::string(bytes.begin(), bytes.end())); }

// One line per message (topic, type, md5, record time, bytes), sorted: what any reader must give back.
std::vector<std::string> MessageLines(const std::vector<Record>& records) {
  std::vector<std::string> lines;
  for (const Record& r : records) {
    lines.push_back(r.topic + " " + r.type->datatype + " " + r.type->md5 + " " +
                    std::to_string(std::max<int64_t>(1, r.time_ns)) + " " + Hex(r.bytes));
  }
  std::sort(lines.begin(), lines.end());
  return lines;
}

std::vector<std::string> MessageLines(const BagReader& reader) {
  std::vector<std::string> lines;
  reader.ForEach({}, [&](const BagMessage& m) {
    lines.push_back(m.topic + " " + m.type.datatype + " " + m.type.md5 + " " +
                    std::to_string(m.record_time_ns) + " " + Hex(m.bytes));
    return true;
  });
  std::sort(lines.begin(), lines.end());
  return lines;
}

// equal line lists, or the first difference (the lists are long: gtest would print all of both)
void ExpectSameLines(const std::vector<std::string>& actual, const std::vector<std::string>& expected) {
  EXPECT_EQ(actual.size(), expected.size());
  const auto differ = std::mismatch(actual.begin(), actual.end(), expected.begin(), expected.end());
  if (differ.first != actual.end() || differ.second != expected.end()) {
    ADD_FAILURE() << "first difference at line " << differ.first - actual.begin() << ":\n  read:     "
                  << (differ.first != actual.end() ? differ.first->substr(0, 300) : "(end)")
                  << "\n  expected: "
                  << (differ.second != expected.end() ? differ.second->substr(0, 300) : "(end)");
  }
}

std::vector<std::string> SplitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// writes `records` through librosbag_storage's writer, the reference for the format
void WriteWithRosbag(const std::string& path, const std::vector<Record>& records,
                     size_t chunk_threshold_bytes, rosbag::compression::CompressionType compression) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  bag.setChunkThreshold(static_cast<uint32_t>(chunk_threshold_bytes));
  bag.setCompression(compression);
  for (const Record& r : records) {
    // the connection header a ROS subscriber would receive; rosbag finds the connection by its contents
    auto header = boost::make_shared<ros::M_string>();
    (*header)["callerid"] = r.publisher;
    (*header)["topic"] = r.topic;
    (*header)["type"] = r.type->datatype;
    (*header)["md5sum"] = r.type->md5;
    (*header)["message_definition"] = r.type->definition;
    ros::Time time;
    time.fromNSec(static_cast<uint64_t>(std::max<int64_t>(1, r.time_ns)));
    bag.write(r.topic, time, RawPayload{r.type, r.bytes.data(), static_cast<uint32_t>(r.bytes.size())},
              header);
  }
  bag.close();
}

void WriteWithRosbag(const std::string& path, const std::vector<Record>& records,
                     const BagWriterOptions& options) {
  WriteWithRosbag(path, records, options.chunk_threshold_bytes,
                  options.compression == BagCompression::kLz4 ? rosbag::compression::LZ4
                                                              : rosbag::compression::Uncompressed);
}

struct Variant {
  const char* name;
  BagWriterOptions options;
};
const Variant kVariants[] = {{"none", {BagCompression::kNone, 16 << 10}},
                             {"lz4", {BagCompression::kLz4, 16 << 10}},
                             {"none_default_chunks", {}},
                             {"lz4_default_chunks", {BagCompression::kLz4, 768 << 10}}};

TEST(BagWriterFormat, SameBytesAsLibrosbagStorage) {
  for (const Variant& variant : kVariants) {
    SCOPED_TRACE(variant.name);
    for (const auto& records : {MixedRecords(), ManyRecords()}) {
      const std::string ours = TempPath(std::string(variant.name) + "_ours.bag");
      const std::string reference = TempPath(std::string(variant.name) + "_rosbag.bag");
      WriteAll(ours, records, variant.options);
      WriteWithRosbag(reference, records, variant.options);
      const std::vector<char> a = ReadFile(ours);
      const std::vector<char> b = ReadFile(reference);
      ASSERT_EQ(a.size(), b.size());
      const auto differ = std::mismatch(a.begin(), a.end(), b.begin());
      EXPECT_TRUE(differ.first == a.end()) << "first difference at byte " << differ.first - a.begin();
    }
  }
}

TEST(BagWriterFormat, ManyChunksAndConnectionsReadBackExactly) {
  const std::vector<Record> records = ManyRecords();
  for (const Variant& variant : kVariants) {
    SCOPED_TRACE(variant.name);
    const std::string path = TempPath(std::string(variant.name) + ".bag");
    BagWriter writer(path, variant.options);
    for (const Record& r : records) {
      writer.Write(writer.Connection(r.topic, *r.type, r.publisher), r.time_ns, r.bytes.data(),
                   r.bytes.size());
    }
    writer.Close();
    const BagWriterStats& stats = writer.stats();
    EXPECT_EQ(stats.messages, records.size());
    EXPECT_EQ(stats.file_bytes, ReadFile(path).size());
    if (variant.options.chunk_threshold_bytes == 16 << 10) {
      EXPECT_GT(stats.chunks, 20u);
    }
    if (variant.options.compression == BagCompression::kLz4) {
      EXPECT_LT(stats.chunk_data_bytes, stats.record_bytes);
    }

    const BagReader reader(path);
    std::map<std::string, uint64_t> counts;
    for (const Record& r : records) ++counts[r.topic];
    const std::vector<BagTopicInfo> topics = reader.Topics();
    ASSERT_EQ(topics.size(), counts.size());
    for (const BagTopicInfo& topic : topics) {
      EXPECT_EQ(topic.count, counts[topic.topic]) << topic.topic;
      const TypeInfo& type = topic.topic == "/clock"       ? TypeInfoOf<rosgraph_msgs::Clock>()
                             : topic.topic == "/iap/state" ? TypeInfoOf<iapsim_msgs::IapState>()
                                                           : TypeInfoOf<geometry_msgs::PoseStamped>();
      EXPECT_EQ(topic.datatype, type.datatype) << topic.topic;
      EXPECT_EQ(topic.md5, type.md5) << topic.topic;
      EXPECT_EQ(topic.definition, type.definition) << topic.topic;
    }
    ExpectSameLines(MessageLines(reader), MessageLines(records));
  }
}

// BagReader against librosbag_storage's reader, on bags rosbag wrote: every compression rosbag writes, small
// chunks, two connections on a topic, and a message written out of time order (its chunk overlaps others).
TEST(BagReaderFormat, ReadsWhatRosbagWroteAsRosbagReadsIt) {
  const std::vector<Record> records = ManyRecords();
  for (const auto& [name, compression] :
       {std::pair{"none", rosbag::compression::Uncompressed}, std::pair{"lz4", rosbag::compression::LZ4},
        std::pair{"bz2", rosbag::compression::BZ2}}) {
    SCOPED_TRACE(name);
    const std::string path = TempPath(std::string("rosbag_") + name + ".bag");
    WriteWithRosbag(path, records, 16 << 10, compression);

    // the reference: rosbag's view, in its order, and its per-topic summary
    std::vector<std::string> expected;
    std::map<std::string, BagTopicInfo> expected_topics;
    {
      rosbag::Bag bag(path, rosbag::bagmode::Read);
      rosbag::View view(bag);
      for (const rosbag::MessageInstance& m : view) {
        std::vector<uint8_t> bytes(m.size());
        ros::serialization::OStream stream(bytes.data(), m.size());
        m.write(stream);
        const auto time_ns = static_cast<int64_t>(m.getTime().toNSec());
        expected.push_back(m.getTopic() + " " + m.getDataType() + " " + m.getMD5Sum() + " " +
                           std::to_string(time_ns) + " " + Hex(bytes));
        BagTopicInfo& info = expected_topics[m.getTopic()];
        info.first_time_ns = info.count == 0 ? time_ns : std::min(info.first_time_ns, time_ns);
        info.last_time_ns = info.count == 0 ? time_ns : std::max(info.last_time_ns, time_ns);
        ++info.count;
      }
    }
    const BagReader reader(path);
    std::vector<std::string> read;
    int64_t last_ns = 0;
    reader.ForEach({}, [&](const BagMessage& m) {
      EXPECT_GE(m.record_time_ns, last_ns) << "out of time order";
      last_ns = m.record_time_ns;
      read.push_back(m.topic + " " + m.type.datatype + " " + m.type.md5 + " " +
                     std::to_string(m.record_time_ns) + " " + Hex(m.bytes));
      return true;
    });
    // equal times may come in another order than rosbag's heap gives them: compare as sets, order by time
    std::sort(read.begin(), read.end());
    std::sort(expected.begin(), expected.end());
    ExpectSameLines(read, expected);
    const std::vector<BagTopicInfo> topics = reader.Topics();
    ASSERT_EQ(topics.size(), expected_topics.size());
    for (const BagTopicInfo& topic : topics) {
      const BagTopicInfo& want = expected_topics[topic.topic];
      EXPECT_EQ(topic.count, want.count) << topic.topic;
      EXPECT_EQ(topic.first_time_ns, want.first_time_ns) << topic.topic;
      EXPECT_EQ(topic.last_time_ns, want.last_time_ns) << topic.topic;
    }
  }
}

// A bag cut short or with a damaged index is an error naming the file, never a crash or a wrong message.
TEST(BagErrors, TruncatedOrDamagedBagsNameTheFile) {
  const std::string whole = TempPath("whole.bag");
  WriteAll(whole, ManyRecords(), {BagCompression::kNone, 16 << 10});
  const std::vector<char> bytes = ReadFile(whole);
  auto write = [](const std::string& path, const std::vector<char>& content) {
    std::ofstream(path, std::ios::binary).write(content.data(), static_cast<std::streamsize>(content.size()));
  };
  for (const size_t cut : {size_t{20}, size_t{5000}, bytes.size() / 2, bytes.size() - 10}) {
    const std::string path = TempPath("cut_" + std::to_string(cut) + ".bag");
    write(path, std::vector<char>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(cut)));
    try {
      BagReader reader(path);
      FAIL() << "a bag cut at byte " << cut << " opened";
    } catch (const BagError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  // a byte flipped in the last chunks or the index: an error naming the file or, where it hit a payload,
  // messages; never a crash
  for (size_t i = 1; i <= 12; ++i) {
    std::vector<char> flipped = bytes;
    const size_t at = bytes.size() - i * (bytes.size() / 60);
    flipped[at] = static_cast<char>(flipped[at] ^ 0x5a);
    const std::string path = TempPath("flipped_" + std::to_string(i) + ".bag");
    write(path, flipped);
    try {
      const BagReader reader(path);
      reader.ForEach({}, [](const BagMessage&) { return true; });
    } catch (const BagError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

// Issue 20: no damaged bag crashes a tool. 400 seeded variants of a bag in three chunkings (bits flipped
// anywhere, a run of bytes overwritten, most of them in the record headers, connections and index that are a
// small part of the file; the file cut short), each opened, summarised and read through what `iapsim info`,
// `echo`, `export` and `replay --as-pose` do with a message: its definition parsed, the bytes validated,
// walked to YAML, flattened and searched for a pose. Every failure must be an exception, never a crash or a
// hang.
TEST(BagFuzz, DamagedBagsFailWithAnErrorNeverACrash) {
  std::vector<Record> records = ManyRecords();
  records.resize(100);
  const std::string base_path = TempPath("base.bag");
  const BagWriterOptions chunkings[] = {
      {BagCompression::kNone, 2 << 10}, {BagCompression::kLz4, 2 << 10}, {BagCompression::kNone, 64 << 10}};
  std::vector<std::vector<char>> bases;
  for (const BagWriterOptions& options : chunkings) {
    WriteAll(base_path, records, options);
    bases.push_back(ReadFile(base_path));
  }
  // a tool parses a definition once per connection: so does this test (per variant, as the text may differ)
  std::map<std::string, std::pair<std::shared_ptr<const SchemaSet>, std::string>> schemas;  // or its error
  std::mt19937 random(20);
  int opened = 0, read_whole = 0, messages = 0;
  std::map<std::string, int> errors;  // the start of each kind of message, numbers left out
  const auto kind = [](const std::string& what) {
    std::string out;
    for (const char c : what.substr(0, 40)) {
      if (!std::isdigit(static_cast<unsigned char>(c))) out += c;
    }
    return out;
  };
  for (int variant = 0; variant < 400; ++variant) {
    std::vector<char> bytes = bases[variant % 3];
    schemas.clear();
    const auto anywhere = [&] { return std::uniform_int_distribution<size_t>(0, bytes.size() - 1)(random); };
    // the 4 kB bag header and the index at the end (where the connection records repeat) hold the structure
    const auto structure = [&] {
      const size_t at = std::uniform_int_distribution<size_t>(0, 2 * 4096 - 1)(random);
      return at < 4096 ? at : bytes.size() - 1 - (at - 4096) % bytes.size();
    };
    switch (variant % 4) {
      case 0:  // a few bits flipped anywhere
        for (int i = 0; i < 1 + variant % 3; ++i) bytes[anywhere()] ^= static_cast<char>(1 << (random() % 8));
        break;
      case 1:  // a bit flipped in the structure
        bytes[structure()] ^= static_cast<char>(1 << (random() % 8));
        break;
      case 2: {  // a run of random bytes in the structure
        const size_t at = structure();
        for (size_t i = at; i < std::min(bytes.size(), at + 1 + random() % 16); ++i)
          bytes[i] = static_cast<char>(random());
        break;
      }
      default:  // cut short, and a bit flipped before the cut
        bytes.resize(anywhere());
        if (!bytes.empty()) bytes[anywhere()] ^= 0x10;
    }
    const std::string path = TempPath("variant.bag");
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    try {
      const BagReader reader(path);
      ++opened;
      for (const BagTopicInfo& topic : reader.Topics()) static_cast<void>(topic.count);
      reader.ForEach({}, [&](const BagMessage& m) {
        ++messages;
        try {
          auto [parsed, inserted] = schemas.try_emplace(m.type.datatype + '\n' + m.type.definition);
          auto& [schema, parse_error] = parsed->second;
          if (inserted) {
            try {
              schema = SchemaSet::Parse(m.type.datatype, m.type.definition);
            } catch (const std::invalid_argument& e) {
              parse_error = e.what();
            }
          }
          if (!schema) throw std::invalid_argument(parse_error);
          std::string invalid;
          if (!schema->Validate(m.bytes.data(), m.bytes.size(), &invalid))
            throw std::invalid_argument(invalid);
          static_cast<void>(FormatYaml(*schema, m.bytes.data(), m.bytes.size()));
          static_cast<void>(Flatten(*schema, m.bytes.data(), m.bytes.size()));
          static_cast<void>(ExtractPose(*schema, m.bytes.data(), m.bytes.size(), m.record_time_ns));
        } catch (const std::invalid_argument& e) {
          ++errors["message: " + kind(e.what())];
        }
        return true;
      });
      ++read_whole;
    } catch (const BagError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      const std::string what = e.what();
      ++errors["bag: " + kind(what.substr(what.find(path) + path.size() + 3))];
    }
  }
  std::printf("400 damaged bags: %d opened, %d read to the end, %d messages; errors:\n", opened, read_whole,
              messages);
  for (const auto& [what, count] : errors) std::printf("  %5d  %s...\n", count, what.c_str());
  EXPECT_GT(read_whole, 100);  // payload damage leaves a readable bag
  EXPECT_LT(read_whole, 300);  // structure damage does not
}

// what python rosbag reads: one line per message and per connection (its publisher and definition)
constexpr char kPythonDump[] =
    "import sys, rosbag\n"
    "bag = rosbag.Bag(sys.argv[1])\n"
    "lines = []\n"
    "for topic, (datatype, data, md5, _, _), t in bag.read_messages(raw=True):\n"
    "    lines.append('%s %s %s %d %s' % (topic, datatype, md5, t.to_nsec(), data.hex()))\n"
    "for c in bag._get_connections():\n"
    "    publisher = c.header['callerid'].decode()\n"
    "    definition = c.msg_def.encode().hex()\n"
    "    lines.append(' '.join(['connection', c.topic, publisher, c.datatype, c.md5sum, definition]))\n"
    "print('\\n'.join(sorted(lines)))\n";

TEST(BagPython, DebianRosbagReadsEveryChunkAndConnection) {
  if (!HavePythonRosbag()) GTEST_SKIP() << "/usr/bin/python3 cannot import rosbag";
  const std::vector<Record> records = ManyRecords();
  std::vector<std::string> expected = MessageLines(records);
  std::set<std::string> connections;
  for (const Record& r : records) {
    connections.insert("connection " + r.topic + " " + r.publisher + " " + r.type->datatype + " " +
                       r.type->md5 + " " + Hex(r.type->definition));
  }
  expected.insert(expected.end(), connections.begin(), connections.end());
  std::sort(expected.begin(), expected.end());
  for (const Variant& variant : kVariants) {
    SCOPED_TRACE(variant.name);
    const std::string path = TempPath(std::string(variant.name) + ".bag");
    WriteAll(path, records, variant.options);
    std::string output;
    ASSERT_TRUE(RunPython(kPythonDump, {path}, &output)) << output.substr(0, 2000);
    ExpectSameLines(SplitLines(output), expected);
  }
}

// Reindexes a copy of a bag whose writer never closed it, and another copy cut in the middle of its last
// chunk, with python rosbag (as `rosbag reindex` does). Prints: messages recovered, chunks, messages
// recovered from the cut copy, messages of the last chunk.
constexpr char kPythonReindex[] =
    "import shutil, sys, rosbag\n"
    "def reindex(path):\n"
    "    bag = rosbag.Bag(path, 'a', allow_unindexed=True)\n"
    "    for _ in bag.reindex():\n"
    "        pass\n"
    "    bag.close()\n"
    "    bag = rosbag.Bag(path)\n"
    "    chunks = [(c.pos, sum(c.connection_counts.values())) for c in bag._chunks]\n"
    "    return bag.get_message_count(), chunks\n"
    "killed, cut = sys.argv[1], sys.argv[2]\n"
    "shutil.copyfile(killed, cut)\n"
    "n, chunks = reindex(killed)\n"
    "with open(cut, 'r+b') as f:\n"
    "    f.truncate(chunks[-1][0] + 100)\n"
    "m, _ = reindex(cut)\n"
    "print(n, len(chunks), m, chunks[-1][1])\n";

TEST(BagWriterRecovery, ReindexRecoversEveryChunkAKilledWriterWrote) {
  if (!HavePythonRosbag()) GTEST_SKIP() << "/usr/bin/python3 cannot import rosbag";
  const std::vector<Record> records = ManyRecords();
  for (const Variant& variant : {kVariants[0], kVariants[1]}) {
    SCOPED_TRACE(variant.name);
    const std::string path = TempPath(std::string(variant.name) + "_killed.bag");
    // a child writes until its fifth chunk is out and a little more, then dies without closing the bag
    int report[2];
    ASSERT_EQ(::pipe(report), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      BagWriter writer(path, variant.options);
      uint64_t in_chunks = 0;
      size_t after = 0;
      for (const Record& r : records) {
        writer.Write(r.topic, *r.type, r.time_ns, r.bytes.data(), r.bytes.size(), r.publisher);
        if (in_chunks == 0 && writer.stats().chunks == 5) in_chunks = writer.stats().messages;
        if (in_chunks > 0 && ++after > 3) break;
      }
      const uint64_t sent[2] = {in_chunks, writer.stats().chunks};
      static_cast<void>(::write(report[1], sent, sizeof(sent)));
      ::_exit(0);
    }
    ::close(report[1]);
    uint64_t written[2] = {0, 0};
    ASSERT_EQ(::read(report[0], written, sizeof(written)), static_cast<ssize_t>(sizeof(written)));
    ::close(report[0]);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    const uint64_t in_chunks = written[0];
    ASSERT_GT(in_chunks, 0u);
    ASSERT_EQ(written[1], 5u) << "the messages after the fifth chunk filled a sixth";

    // the file is unindexed, as a killed recorder's is: read by walking its chunks, it gives the messages of
    // the five whole ones, and says so
    const std::vector<Record> first(records.begin(),
                                    records.begin() + static_cast<std::ptrdiff_t>(in_chunks));
    {
      const BagReader walked(path);
      EXPECT_NE(walked.note().find("unindexed"), std::string::npos) << walked.note();
      EXPECT_NE(walked.note().find("its 5 whole chunks"), std::string::npos) << walked.note();
      ExpectSameLines(MessageLines(walked), MessageLines(first));
    }
    // iapsim's reindex writes an indexed copy with those messages, each connection's publisher kept
    {
      const std::string copy = TempPath(std::string(variant.name) + "_reindexed.bag");
      EXPECT_EQ(ReindexBag(path, copy, variant.options), in_chunks);
      const BagReader reindexed(copy);
      EXPECT_EQ(reindexed.note(), "");
      ExpectSameLines(MessageLines(reindexed), MessageLines(first));
      std::set<std::string> publishers, expected_publishers;
      reindexed.ForEach(
          {}, [&](const BagMessage& m) { return publishers.insert(m.topic + " " + m.publisher), true; });
      for (const Record& r : first) expected_publishers.insert(r.topic + " " + r.publisher);
      EXPECT_EQ(publishers, expected_publishers);
    }
    // cut inside the last chunk's index: that chunk is skipped, the four before it read
    const std::string cut = TempPath(std::string(variant.name) + "_cut_index.bag");
    std::vector<char> bytes = ReadFile(path);
    bytes.resize(bytes.size() - 20);
    std::ofstream(cut, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    std::string output;
    ASSERT_TRUE(RunPython(kPythonReindex, {path, TempPath(std::string(variant.name) + "_cut.bag")}, &output))
        << output;
    uint64_t recovered = 0, chunks = 0, recovered_cut = 0, last_chunk = 0;
    std::istringstream(output) >> recovered >> chunks >> recovered_cut >> last_chunk;
    EXPECT_EQ(recovered, in_chunks) << output;
    EXPECT_EQ(chunks, 5u) << output;
    EXPECT_GT(last_chunk, 0u) << output;
    EXPECT_EQ(recovered_cut, in_chunks - last_chunk) << output;
    {
      const BagReader walked(cut);
      EXPECT_NE(walked.note().find("its 4 whole chunks"), std::string::npos) << walked.note();
      EXPECT_NE(walked.note().find("bytes (the chunk being written"), std::string::npos) << walked.note();
      ExpectSameLines(
          MessageLines(walked),
          MessageLines(std::vector<Record>(
              records.begin(), records.begin() + static_cast<std::ptrdiff_t>(in_chunks - last_chunk))));
    }
    // what was recovered is exactly the messages of those chunks
    const BagReader reindexed(path);
    EXPECT_EQ(reindexed.note(), "");
    ExpectSameLines(MessageLines(reindexed), MessageLines(first));
  }
}

TEST(BagWriter, RejectsTimesABagCannotHoldAndUnknownConnections) {
  BagWriter writer(TempPath("limits.bag"));
  const auto bytes = Encode(MakeClock(7));
  const uint32_t clock = writer.Connection("/clock", TypeInfoOf<rosgraph_msgs::Clock>(), "/sim");
  writer.Write(clock, 4294967295LL * 1000000000 + 999999999, bytes.data(), bytes.size());  // ros::TIME_MAX
  EXPECT_THROW(writer.Write(clock, 4294967296LL * 1000000000, bytes.data(), bytes.size()), BagError);
  EXPECT_THROW(writer.Write(clock + 1, 7, bytes.data(), bytes.size()), BagError);
  EXPECT_THROW(writer.Write(clock, 7, nullptr, 3), BagError);
  EXPECT_EQ(writer.Connection("/clock", TypeInfoOf<rosgraph_msgs::Clock>(), "/sim"), clock);
  EXPECT_NE(writer.Connection("/clock", TypeInfoOf<rosgraph_msgs::Clock>(), "/other"), clock);
}

}  // namespace
}  // namespace iapsim::bridge
