#include "bridge/message_format.h"

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/UwbRanges.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CompressedImage.h>
#include <std_msgs/Empty.h>
#include <std_msgs/Float32.h>
#include <std_msgs/Float64.h>
#include <std_msgs/String.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

#include "bridge/message.h"
#include "bridge/testing/sample_messages.h"

namespace iapsim::bridge {
namespace {

template <class M>
std::string Yaml(const M& message, size_t max_bytes_shown = 16) {
  const auto bytes = Encode(message);
  return FormatYaml(SchemaOf<M>(), bytes.data(), bytes.size(), max_bytes_shown);
}

template <class M>
FlatMessage Flat(const M& message) {
  const auto bytes = Encode(message);
  return Flatten(SchemaOf<M>(), bytes.data(), bytes.size());
}

template <class M>
std::optional<StampedPose> Pose(const M& message, int64_t record_time_ns,
                                const std::string& pose_field = "") {
  const auto bytes = Encode(message);
  return ExtractPose(SchemaOf<M>(), bytes.data(), bytes.size(), record_time_ns, pose_field);
}

// The message of the std::invalid_argument that `f` throws, or "" when it throws none.
template <class F>
std::string InvalidArgumentOf(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

TEST(FormatYaml, PrintsNestedMessagesIndentedByTwo) {
  geometry_msgs::PoseStamped pose;
  pose.header.seq = 3;
  pose.header.stamp = ros::Time(1, 5000000);
  pose.header.frame_id = "W";
  pose.pose.position.x = 1.0;
  pose.pose.position.y = 0.1;
  pose.pose.position.z = -2.5e-7;
  pose.pose.orientation.w = 1.0;
  EXPECT_EQ(Yaml(pose),
            "header:\n"
            "  seq: 3\n"
            "  stamp: 1.005000000\n"
            "  frame_id: W\n"
            "pose:\n"
            "  position:\n"
            "    x: 1.0\n"
            "    y: 0.1\n"
            "    z: -2.5e-07\n"
            "  orientation:\n"
            "    x: 0.0\n"
            "    y: 0.0\n"
            "    z: 0.0\n"
            "    w: 1.0\n");
}

TEST(FormatYaml, PrintsArraysOfMessagesAsDashItems) {
  const std::string text = Yaml(testing::MakeSampleState());
  EXPECT_NE(text.find("step: 1005\nbodies:\n"
                      "  - name: platform\n"
                      "    pose_W:\n"
                      "      position:\n"
                      "        x: 0.0\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("  - name: \"1.5\"\n"), std::string::npos) << text;
  EXPECT_NE(text.find("external_wrench_P:\n  force:\n    x: 0.0\n    y: 0.0\n    z: 19.62\n"),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find(" \n"), std::string::npos) << "trailing space in\n" << text;
}

TEST(FormatYaml, ParsesBackWithTheSameValues) {
  const auto state = testing::MakeSampleState();
  const YAML::Node root = YAML::Load(Yaml(state));
  EXPECT_EQ(root["header"]["seq"].as<uint32_t>(), 7u);
  EXPECT_EQ(root["header"]["stamp"].as<std::string>(), "1.005000000");
  EXPECT_EQ(root["header"]["frame_id"].as<std::string>(), "W");
  EXPECT_EQ(root["step"].as<uint64_t>(), 1005u);
  ASSERT_TRUE(root["bodies"].IsSequence());
  ASSERT_EQ(root["bodies"].size(), 4u);
  EXPECT_EQ(root["bodies"][0]["name"].as<std::string>(), "platform");
  // quoted: a plain 1.5 would be a float to any yaml reader
  EXPECT_EQ(root["bodies"][1]["name"].Tag(), "!");
  EXPECT_EQ(root["bodies"][1]["name"].as<std::string>(), "1.5");
  for (size_t i = 0; i < state.bodies.size(); ++i) {
    SCOPED_TRACE(i);
    const auto& expected = state.bodies[i].pose_W;
    const YAML::Node pose = root["bodies"][i]["pose_W"];
    EXPECT_TRUE(SameBits(pose["position"]["x"].as<double>(), expected.position.x));
    EXPECT_TRUE(SameBits(pose["position"]["y"].as<double>(), expected.position.y));
    EXPECT_TRUE(SameBits(pose["position"]["z"].as<double>(), expected.position.z));
    EXPECT_EQ(pose["orientation"]["w"].as<double>(), 1.0);
    EXPECT_EQ(root["bodies"][i]["twist_B"]["angular"]["z"].as<double>(), -0.25);
  }
  ASSERT_EQ(root["joints"].size(), 3u);
  EXPECT_EQ(root["joints"][2]["type"].as<int>(), 1);
  EXPECT_EQ(root["external_wrench_P"]["force"]["z"].as<double>(), 19.62);
}

TEST(FormatYaml, QuotesStringsThatWouldNotReadBackAsThemselves) {
  const std::vector<std::string> tricky = {
      "",        "12",          "-3",         "1e5",       ".inf", "yes",        "No",         "null",
      "~",       "a: b",        "x #y",       " padded ",  "#tag", "[1]",        "a,b",        "{}",
      "q\"uote", "back\\slash", "two\nlines", "tab\there", "*ref", "plain text", "caf\xc3\xa9"};
  iapsim_msgs::UwbRanges ranges;
  ranges.tag = "2024-01-01";
  ranges.peers = tricky;
  ranges.ranges_m = {1.5, 2.25};
  const std::string text = Yaml(ranges);
  EXPECT_NE(text.find("tag: \"2024-01-01\"\n"), std::string::npos) << text;
  EXPECT_NE(text.find("ranges_m: [1.5, 2.25]\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\"a: b\""), std::string::npos) << text;
  EXPECT_NE(text.find(", plain text, "), std::string::npos) << "plain strings stay unquoted:\n" << text;

  const YAML::Node root = YAML::Load(text);
  EXPECT_EQ(root["tag"].as<std::string>(), "2024-01-01");
  ASSERT_TRUE(root["peers"].IsSequence()) << text;
  ASSERT_EQ(root["peers"].size(), tricky.size()) << text;
  for (size_t i = 0; i < tricky.size(); ++i) EXPECT_EQ(root["peers"][i].as<std::string>(), tricky[i]) << text;
  ASSERT_EQ(root["ranges_m"].size(), 2u);
  EXPECT_EQ(root["ranges_m"][1].as<double>(), 2.25);
}

TEST(FormatYaml, ShowsSmallByteArraysAndSummarizesLargeOnes) {
  sensor_msgs::CompressedImage image;
  image.header.frame_id = "cam";
  image.format = "png";
  image.data = {1, 2, 255};
  YAML::Node root = YAML::Load(Yaml(image));
  ASSERT_TRUE(root["data"].IsSequence());
  EXPECT_EQ(root["data"][2].as<int>(), 255);

  image.data.assign(5000, 7);
  const std::string text = Yaml(image, 16);
  EXPECT_NE(text.find("data: \"<5000 bytes>\"\n"), std::string::npos) << text;
  root = YAML::Load(text);
  EXPECT_EQ(root["data"].as<std::string>(), "<5000 bytes>");
  EXPECT_EQ(root["format"].as<std::string>(), "png");

  image.data.assign(16, 0);
  EXPECT_TRUE(YAML::Load(Yaml(image, 16))["data"].IsSequence()) << "size == max_bytes_shown is still listed";
}

TEST(FormatYaml, PrintsEmptyContainersAndSpecialFloats) {
  iapsim_msgs::IapState empty;
  const std::string text = Yaml(empty);
  EXPECT_NE(text.find("bodies: []\njoints: []\n"), std::string::npos) << text;
  EXPECT_TRUE(YAML::Load(text)["bodies"].IsSequence());
  EXPECT_EQ(Yaml(std_msgs::Empty()), "{}\n");
  EXPECT_TRUE(YAML::Load(Yaml(std_msgs::Empty())).IsMap());

  std_msgs::Float64 value;
  value.data = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(Yaml(value), "data: -.inf\n");
  EXPECT_EQ(YAML::Load(Yaml(value))["data"].as<double>(), value.data);
  value.data = std::nan("");
  EXPECT_TRUE(std::isnan(YAML::Load(Yaml(value))["data"].as<double>()));

  // float32 prints its own shortest form, not the widened double 0.10000000149011612
  std_msgs::Float32 single;
  single.data = 0.1f;
  EXPECT_EQ(Yaml(single), "data: 0.1\n");
}

TEST(FormatYaml, RejectsMalformedBytes) {
  auto bytes = Encode(testing::MakeSampleState());
  bytes.pop_back();
  EXPECT_THROW(FormatYaml(SchemaOf<iapsim_msgs::IapState>(), bytes.data(), bytes.size()),
               std::invalid_argument);
}

TEST(FormatFlatten, ListsLeavesInSerializationOrder) {
  geometry_msgs::PoseStamped pose;
  pose.header.stamp = ros::Time(2, 1);
  pose.header.frame_id = "a,b";
  pose.pose.position.x = 0.1;
  pose.pose.orientation.w = 1.0;
  const FlatMessage flat = Flat(pose);
  const std::vector<std::string> columns = {"header.seq",         "header.stamp",       "header.frame_id",
                                            "pose.position.x",    "pose.position.y",    "pose.position.z",
                                            "pose.orientation.x", "pose.orientation.y", "pose.orientation.z",
                                            "pose.orientation.w"};
  EXPECT_EQ(flat.columns, columns);
  const std::vector<std::string> values = {"0",   "2.000000001", "a,b", "0.1", "0.0",
                                           "0.0", "0.0",         "0.0", "0.0", "1.0"};
  EXPECT_EQ(flat.values, values);
}

TEST(FormatFlatten, IndexesArraysAndCountsBytes) {
  const FlatMessage state = Flat(testing::MakeSampleState());
  ASSERT_EQ(state.columns.size(), state.values.size());
  const auto at = [&](const std::string& column) {
    for (size_t i = 0; i < state.columns.size(); ++i) {
      if (state.columns[i] == column) return state.values[i];
    }
    return std::string("<missing>");
  };
  EXPECT_EQ(at("bodies[1].name"), "1.5");
  EXPECT_EQ(at("bodies[3].pose_W.position.x"), "1.44");
  EXPECT_EQ(at("joints[2].type"), "1");
  EXPECT_EQ(at("step"), "1005");

  sensor_msgs::CompressedImage image;
  image.data.assign(5000, 7);
  const FlatMessage flat = Flat(image);
  ASSERT_EQ(flat.columns.back(), "data");
  EXPECT_EQ(flat.values.back(), "5000");

  iapsim_msgs::UwbRanges ranges;
  ranges.peers = {"a", "b"};
  ranges.ranges_m = {1.0, std::numeric_limits<double>::infinity()};
  const FlatMessage uwb = Flat(ranges);
  const std::vector<std::string> tail = {"peers[0]", "peers[1]", "ranges_m[0]", "ranges_m[1]"};
  EXPECT_EQ(std::vector<std::string>(uwb.columns.end() - 4, uwb.columns.end()), tail);
  EXPECT_EQ(uwb.values.back(), "inf");
}

iapsim_msgs::UwbRanges MakeRanges(std::vector<std::string> peers) {
  iapsim_msgs::UwbRanges ranges;
  ranges.header.stamp = ros::Time(3, 0);
  ranges.tag = "t\"1";
  ranges.ranges_m.assign(peers.size(), 0.5);
  ranges.peers = std::move(peers);
  return ranges;
}

TEST(CsvWriter, WritesHeaderThenQuotedRows) {
  std::ostringstream out;
  CsvWriter writer(out);
  writer.Write(1000000001, Flat(MakeRanges({"a,1", "line\nbreak"})));
  writer.Write(-1500000000, Flat(MakeRanges({"plain", ""})));
  EXPECT_EQ(out.str(),
            "time_s,header.seq,header.stamp,header.frame_id,tag,peers[0],peers[1],ranges_m[0],ranges_m[1]\n"
            "1.000000001,0,3.000000000,,\"t\"\"1\",\"a,1\",\"line\nbreak\",0.5,0.5\n"
            "-1.500000000,0,3.000000000,,\"t\"\"1\",plain,,0.5,0.5\n");
}

// What CsvWriter writes, SplitCsvLine reads back field for field: commas, doubled quotes and line breaks
// inside quoted fields, empty fields. A record spans lines while a quote is open (RFC 4180), as a reader
// joins them.
TEST(CsvWriter, RoundTripsThroughSplitCsvLine) {
  const std::vector<std::vector<std::string>> peers = {
      {"a,1", "line\nbreak"}, {"say \"hi\", twice", ""}, {"\"", ",\r\n,"}, {"plain", "trailing,"}};
  std::ostringstream out;
  CsvWriter writer(out);
  std::vector<FlatMessage> written;
  for (size_t k = 0; k < peers.size(); ++k) {
    written.push_back(Flat(MakeRanges(peers[k])));
    writer.Write(static_cast<int64_t>(k + 1), written.back());
  }
  std::istringstream in(out.str());
  std::vector<std::vector<std::string>> records;
  std::string record;
  for (std::string line; std::getline(in, line);) {
    record += line;
    bool unterminated = false;
    std::vector<std::string> fields = SplitCsvLine(record, &unterminated);
    if (unterminated) {
      record += '\n';  // the line break was inside the quoted field
      continue;
    }
    records.push_back(std::move(fields));
    record.clear();
  }
  EXPECT_TRUE(record.empty()) << "an open quote at the end: " << record;
  ASSERT_EQ(records.size(), 1 + peers.size());
  EXPECT_EQ(records[0].front(), "time_s");
  EXPECT_EQ(std::vector<std::string>(records[0].begin() + 1, records[0].end()), written[0].columns);
  for (size_t k = 0; k < peers.size(); ++k) {
    const std::vector<std::string>& fields = records[k + 1];
    ASSERT_EQ(fields.size(), 1 + written[k].values.size()) << k;
    // '\r' is dropped on reading (a CRLF file's line ends): the only change a round trip makes
    std::vector<std::string> expected = written[k].values;
    for (std::string& value : expected)
      value.erase(std::remove(value.begin(), value.end(), '\r'), value.end());
    EXPECT_EQ(std::vector<std::string>(fields.begin() + 1, fields.end()), expected) << k;
  }
}

TEST(CsvWriter, RejectsRowsWhoseColumnsDiffer) {
  std::ostringstream out;
  CsvWriter writer(out);
  writer.Write(1, Flat(MakeRanges({"a"})));
  writer.Write(2, Flat(MakeRanges({"b"})));
  const std::string before = out.str();

  const std::string more = InvalidArgumentOf([&] { writer.Write(3, Flat(MakeRanges({"a", "b"}))); });
  EXPECT_NE(more.find("row 3"), std::string::npos) << more;
  // the second row's peers[1] takes the header's ranges_m[0] slot
  EXPECT_NE(more.find("'peers[1]'"), std::string::npos) << more;
  EXPECT_NE(more.find("'ranges_m[0]'"), std::string::npos) << more;
  EXPECT_NE(more.find("8 columns, header has 6"), std::string::npos) << more;

  const std::string fewer = InvalidArgumentOf([&] { writer.Write(3, Flat(MakeRanges({}))); });
  EXPECT_NE(fewer.find("row 3"), std::string::npos) << fewer;
  EXPECT_NE(fewer.find("4 columns, header has 6"), std::string::npos) << fewer;
  EXPECT_EQ(out.str(), before) << "a rejected row writes nothing";

  // a matching row after a rejected one still goes through
  writer.Write(4, Flat(MakeRanges({"c"})));
  EXPECT_NE(out.str().find("\n0.000000004,"), std::string::npos) << out.str();
}

TEST(CsvWriter, HeaderOfAMessageWithoutFieldsIsJustTime) {
  std::ostringstream out;
  CsvWriter writer(out);
  writer.Write(5, Flat(std_msgs::Empty()));
  EXPECT_EQ(out.str(), "time_s\n0.000000005\n");
}

TEST(PoseExtract, PoseStampedUsesItsHeaderStamp) {
  geometry_msgs::PoseStamped msg;
  msg.header.stamp = ros::Time(10, 20);
  msg.pose.position.x = 1.5;
  msg.pose.position.y = -2.0;
  msg.pose.position.z = 0.25;
  msg.pose.orientation.x = 0.5;
  msg.pose.orientation.y = -0.5;
  msg.pose.orientation.z = 0.5;
  msg.pose.orientation.w = -0.5;
  for (const std::string field : {"", "pose"}) {
    SCOPED_TRACE(field);
    const auto pose = Pose(msg, 999, field);
    ASSERT_TRUE(pose.has_value());
    EXPECT_EQ(pose->time_ns, 10000000020);
    EXPECT_EQ(pose->position[0], 1.5);
    EXPECT_EQ(pose->position[1], -2.0);
    EXPECT_EQ(pose->position[2], 0.25);
    EXPECT_EQ(pose->orientation_xyzw[0], 0.5);
    EXPECT_EQ(pose->orientation_xyzw[1], -0.5);
    EXPECT_EQ(pose->orientation_xyzw[2], 0.5);
    EXPECT_EQ(pose->orientation_xyzw[3], -0.5);
  }
}

TEST(PoseExtract, OdometryFindsPosePose) {
  nav_msgs::Odometry odom;
  odom.header.stamp = ros::Time(4, 0);
  odom.child_frame_id = "B";
  odom.pose.pose.position.z = -3.0;
  odom.pose.pose.orientation.w = 0.0;
  odom.pose.pose.orientation.x = 1.0;
  odom.pose.covariance[0] = 42.0;
  for (const std::string field : {"", "pose.pose"}) {
    SCOPED_TRACE(field);
    const auto pose = Pose(odom, 1, field);
    ASSERT_TRUE(pose.has_value());
    EXPECT_EQ(pose->time_ns, 4000000000);
    EXPECT_EQ(pose->position[2], -3.0);
    EXPECT_EQ(pose->orientation_xyzw[0], 1.0);
    EXPECT_EQ(pose->orientation_xyzw[3], 0.0);
  }
  const std::string error = InvalidArgumentOf([&] { Pose(odom, 1, "pose"); });
  EXPECT_NE(error.find("'pose'"), std::string::npos) << error;
  EXPECT_NE(error.find("geometry_msgs/PoseWithCovariance"), std::string::npos) << error;
}

TEST(PoseExtract, IapStateDefaultsToTheFirstBodyAndSelectsOthersByPath) {
  const auto state = testing::MakeSampleState();
  const auto first = Pose(state, 1);
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->time_ns, 1005000000);
  EXPECT_EQ(first->position[0], 0.0);
  EXPECT_EQ(first->position[2], -1.0 / 3.0);

  const auto third = Pose(state, 1, "bodies[2].pose_W");
  ASSERT_TRUE(third.has_value());
  EXPECT_EQ(third->position[0], state.bodies[2].pose_W.position.x);
  EXPECT_EQ(third->position[1], state.bodies[2].pose_W.position.y);
  EXPECT_EQ(third->orientation_xyzw[3], 1.0);

  // no bodies: wrenches and twists are not poses
  EXPECT_FALSE(Pose(iapsim_msgs::IapState(), 1).has_value());
}

TEST(PoseExtract, RejectsAPoseFieldThatIsMissingOrNotAPose) {
  const auto state = testing::MakeSampleState();
  const std::string missing = InvalidArgumentOf([&] { Pose(state, 1, "bodies[9].pose_W"); });
  EXPECT_NE(missing.find("'bodies[9].pose_W'"), std::string::npos) << missing;
  EXPECT_NE(missing.find("iapsim_msgs/IapState"), std::string::npos) << missing;

  const std::string header = InvalidArgumentOf([&] { Pose(state, 1, "header"); });
  EXPECT_NE(header.find("std_msgs/Header"), std::string::npos) << header;
  const std::string leaf = InvalidArgumentOf([&] { Pose(state, 1, "step"); });
  EXPECT_NE(leaf.find("uint64"), std::string::npos) << leaf;
  const std::string array = InvalidArgumentOf([&] { Pose(state, 1, "bodies"); });
  EXPECT_NE(array.find("array"), std::string::npos) << array;
  const std::string none = InvalidArgumentOf([&] { Pose(std_msgs::String(), 1, "pose"); });
  EXPECT_NE(none.find("std_msgs/String"), std::string::npos) << none;
}

TEST(PoseExtract, WithoutAHeaderUsesTheRecordTime) {
  geometry_msgs::Pose bare;
  bare.position.y = 7.0;
  const auto pose = Pose(bare, 123456789012, "");
  ASSERT_TRUE(pose.has_value());
  EXPECT_EQ(pose->time_ns, 123456789012);
  EXPECT_EQ(pose->position[1], 7.0);

  geometry_msgs::TransformStamped transform;
  transform.header.stamp = ros::Time(0, 5);
  transform.transform.translation.x = 2.0;
  transform.transform.rotation.z = 1.0;
  transform.transform.rotation.w = 0.0;
  const auto from_transform = Pose(transform, 1);
  ASSERT_TRUE(from_transform.has_value());
  EXPECT_EQ(from_transform->time_ns, 5);
  EXPECT_EQ(from_transform->position[0], 2.0);
  EXPECT_EQ(from_transform->orientation_xyzw[2], 1.0);
  EXPECT_EQ(from_transform->orientation_xyzw[3], 0.0);
}

TEST(PoseExtract, MessageWithoutPoseGivesNothing) {
  std_msgs::String text;
  text.data = "position";
  EXPECT_FALSE(Pose(text, 1).has_value());
  EXPECT_FALSE(Pose(sensor_msgs::CompressedImage(), 1).has_value());
}

// Splits a TUM line on single spaces, failing on empty fields (doubled or trailing spaces).
std::vector<std::string> SplitTum(const std::string& line) {
  std::vector<std::string> fields;
  size_t start = 0;
  while (true) {
    const auto space = line.find(' ', start);
    fields.push_back(line.substr(start, space - start));
    EXPECT_FALSE(fields.back().empty()) << "empty field in '" << line << "'";
    if (space == std::string::npos) break;
    start = space + 1;
  }
  return fields;
}

TEST(TumFormat, PrintsNanosecondTimeAndExactDoubles) {
  StampedPose pose;
  pose.time_ns = 1700000000123456789;
  pose.position[0] = 0.1;
  pose.position[1] = -1.0 / 3.0;
  pose.position[2] = 2.5e-300;
  pose.orientation_xyzw[0] = 1e22;
  pose.orientation_xyzw[1] = -0.0;
  pose.orientation_xyzw[2] = std::numeric_limits<double>::denorm_min();
  pose.orientation_xyzw[3] = 1.0;
  const std::string line = FormatTum(pose);
  EXPECT_EQ(line.rfind("1700000000.123456789 0.1 ", 0), 0u) << line;
  EXPECT_EQ(line.substr(line.size() - 4), " 1.0") << line;
  const auto fields = SplitTum(line);
  ASSERT_EQ(fields.size(), 8u) << line;
  const double expected[7] = {pose.position[0],         pose.position[1],         pose.position[2],
                              pose.orientation_xyzw[0], pose.orientation_xyzw[1], pose.orientation_xyzw[2],
                              pose.orientation_xyzw[3]};
  for (size_t i = 0; i < 7; ++i) {
    EXPECT_TRUE(SameBits(std::strtod(fields[i + 1].c_str(), nullptr), expected[i])) << fields[i + 1];
  }

  pose.time_ns = 5;
  EXPECT_EQ(FormatTum(pose).rfind("0.000000005 ", 0), 0u);
}

TEST(TumFormat, RandomDoublesRoundTripBitExact) {
  std::mt19937_64 rng(12345);
  for (int n = 0; n < 2000; ++n) {
    StampedPose pose;
    pose.time_ns = static_cast<int64_t>(rng() >> 2);
    double* values[7] = {&pose.position[0],         &pose.position[1],         &pose.position[2],
                         &pose.orientation_xyzw[0], &pose.orientation_xyzw[1], &pose.orientation_xyzw[2],
                         &pose.orientation_xyzw[3]};
    for (double* v : values) {
      // random bit patterns cover every exponent; non-finite ones are redrawn
      do {
        const uint64_t bits = rng();
        std::memcpy(v, &bits, sizeof(double));
      } while (!std::isfinite(*v));
    }
    const std::string line = FormatTum(pose);
    const auto fields = SplitTum(line);
    ASSERT_EQ(fields.size(), 8u) << line;
    const std::string seconds = std::to_string(pose.time_ns / 1000000000);
    char nanos[16];
    std::snprintf(nanos, sizeof(nanos), "%09lld", static_cast<long long>(pose.time_ns % 1000000000));
    ASSERT_EQ(fields[0], seconds + "." + nanos);
    for (size_t i = 0; i < 7; ++i) {
      ASSERT_TRUE(SameBits(std::strtod(fields[i + 1].c_str(), nullptr), *values[i])) << line;
    }
  }
}

}  // namespace
}  // namespace iapsim::bridge
