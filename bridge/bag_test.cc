#include "bridge/bag.h"

#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <iapsim_msgs/IapState.h>
#include <rosgraph_msgs/Clock.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <tuple>
#include <vector>

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

void WriteAll(const std::string& path, const std::vector<Record>& records) {
  BagWriter writer(path);
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

TEST(BagPython, DebianRosbagReadsTheBag) {
  if (std::system("/usr/bin/python3 -c 'import rosbag' >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "/usr/bin/python3 cannot import rosbag";
  }
  const std::string path = TempPath("python.bag");
  WriteAll(path, MixedRecords());
  // messages are rebuilt from the stored definitions, so this also checks type, md5 and payload
  const std::string script =
      "import sys, rosbag\n"
      "bag = rosbag.Bag(sys.argv[1])\n"
      "info = bag.get_type_and_topic_info().topics\n"
      "steps = [m.step for _, m, _ in bag.read_messages(topics=[\"/iap/state\"])]\n"
      "poses = [m.pose.position.x for _, m, _ in bag.read_messages(topics=[\"/uav1/pose\"])]\n"
      "n = sum(1 for _ in bag.read_messages())\n"
      "print(n, bag.get_message_count(), info[\"/iap/state\"].msg_type, steps, poses)\n";
  std::string output;
  ASSERT_TRUE(RunCommand("/usr/bin/python3 -c '" + script + "' '" + path + "' 2>&1", &output)) << output;
  EXPECT_EQ(output, "7 7 iapsim_msgs/IapState [1, 2, 3] [0.5, -0.25]\n");
}

}  // namespace
}  // namespace iapsim::bridge
