#include "bridge/message.h"

#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <iapsim_msgs/IapCommand.h>
#include <iapsim_msgs/IapState.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CompressedImage.h>

#include <random>

#include "bridge/message_registry.h"
#include "bridge/testing/sample_messages.h"

namespace iapsim::bridge {
namespace {

TEST(Codec, RoundTripsProjectState) {
  const auto state = testing::MakeSampleState();
  const auto bytes = Encode(state);
  iapsim_msgs::IapState decoded;
  std::string error;
  ASSERT_TRUE(Decode(bytes, &decoded, &error)) << error;
  EXPECT_EQ(decoded, state);
}

// Every registered type: a default message round-trips, and one with filled arrays does too.
TEST(Codec, EveryRegisteredTypeValidatesItsOwnEncoding) {
  for (const RegisteredType* type : AllTypes()) {
    SCOPED_TRACE(type->info.datatype);
    EXPECT_EQ(type->info.md5.size(), 32u);
    EXPECT_EQ(type->schema->root().datatype, type->info.datatype);
  }
  nav_msgs::Odometry odom;
  odom.child_frame_id = "P";
  odom.pose.covariance[35] = 0.1;
  nav_msgs::Odometry odom_decoded;
  ASSERT_TRUE(Decode(Encode(odom), &odom_decoded, nullptr));
  EXPECT_EQ(odom_decoded, odom);

  sensor_msgs::CompressedImage image;
  image.format = "png";
  image.data.assign(5000, 7);
  sensor_msgs::CompressedImage image_decoded;
  ASSERT_TRUE(Decode(Encode(image), &image_decoded, nullptr));
  EXPECT_EQ(image_decoded, image);

  iapsim_msgs::IapCommand command;
  command.sub_aircraft.resize(3);
  command.sub_aircraft[1].mode = iapsim_msgs::SubAircraftCommand::MODE_BODY_RATE;
  command.sub_aircraft[1].thrust_N = 17.3;
  iapsim_msgs::IapCommand command_decoded;
  ASSERT_TRUE(Decode(Encode(command), &command_decoded, nullptr));
  EXPECT_EQ(command_decoded, command);
}

TEST(Codec, RejectsEveryTruncation) {
  const auto bytes = Encode(testing::MakeSampleState());
  iapsim_msgs::IapState decoded;
  for (size_t size = 0; size < bytes.size(); ++size) {
    std::string error;
    EXPECT_FALSE(Decode(bytes.data(), size, &decoded, &error)) << "size " << size;
    EXPECT_FALSE(error.empty());
  }
}

TEST(Codec, RejectsTrailingBytes) {
  auto bytes = Encode(testing::MakeSampleState());
  bytes.push_back(0);
  iapsim_msgs::IapState decoded;
  std::string error;
  EXPECT_FALSE(Decode(bytes, &decoded, &error));
  EXPECT_NE(error.find("trailing"), std::string::npos) << error;
}

TEST(Codec, RejectsHugeArrayLengthWithoutAllocating) {
  auto bytes = Encode(testing::MakeSampleState());
  // header: seq(4) stamp(8) frame_id(4+1) step(8), then the bodies array length
  const size_t bodies_length_offset = 4 + 8 + 4 + 1 + 8;
  const uint32_t huge = 0xFFFFFFF0u;
  std::memcpy(bytes.data() + bodies_length_offset, &huge, 4);
  iapsim_msgs::IapState decoded;
  std::string error;
  EXPECT_FALSE(Decode(bytes, &decoded, &error));
  EXPECT_NE(error.find("bodies"), std::string::npos) << error;
}

// Fuzz-style: random byte strings and random corruptions of valid messages never crash the decoder.
TEST(Codec, RandomAndCorruptedInputIsRejectedOrDecodedWithoutCrash) {
  std::mt19937_64 rng(20261121);
  const auto valid = Encode(testing::MakeSampleState());
  int accepted = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    std::vector<uint8_t> bytes;
    if (trial % 2 == 0) {
      bytes.resize(rng() % 600);
      for (auto& b : bytes) b = static_cast<uint8_t>(rng());
    } else {
      bytes = valid;
      const int flips = 1 + static_cast<int>(rng() % 8);
      for (int f = 0; f < flips; ++f) bytes[rng() % bytes.size()] = static_cast<uint8_t>(rng());
      bytes.resize(bytes.size() - rng() % 3);
    }
    iapsim_msgs::IapState decoded;
    std::string error;
    if (Decode(bytes, &decoded, &error)) {
      // whatever was accepted must re-encode to exactly the input
      EXPECT_EQ(Encode(decoded), bytes);
      ++accepted;
    } else {
      EXPECT_FALSE(error.empty());
    }
  }
  EXPECT_LT(accepted, 20000);
}

class CollectingVisitor : public FieldVisitor {
 public:
  void Leaf(const std::string& path, const std::string&, const LeafValue& value) override {
    leaves[path] = value;
  }
  void Bytes(const std::string& path, const std::string&, const uint8_t*, size_t size) override {
    byte_arrays[path] = size;
  }
  std::map<std::string, LeafValue> leaves;
  std::map<std::string, size_t> byte_arrays;
};

TEST(Schema, WalksNestedFieldsByPath) {
  const auto bytes = Encode(testing::MakeSampleState());
  CollectingVisitor visitor;
  SchemaOf<iapsim_msgs::IapState>().Walk(bytes.data(), bytes.size(), visitor);
  EXPECT_EQ(std::get<std::string>(visitor.leaves.at("bodies[0].name")), "platform");
  EXPECT_DOUBLE_EQ(std::get<double>(visitor.leaves.at("bodies[2].pose_W.position.x")), 0.96);
  EXPECT_DOUBLE_EQ(std::get<double>(visitor.leaves.at("external_wrench_P.force.z")), 19.62);
  EXPECT_EQ(std::get<uint64_t>(visitor.leaves.at("step")), 1005u);
  EXPECT_EQ(std::get<TimeNs>(visitor.leaves.at("header.stamp")).ns, 1005000000);
  EXPECT_EQ(std::get<uint64_t>(visitor.leaves.at("joints[2].type")), 1u);
  EXPECT_EQ(SchemaOf<iapsim_msgs::IapState>().HeaderStampOffset(), 4);
  EXPECT_EQ(SchemaOf<iapsim_msgs::JointState>().HeaderStampOffset(), -1);
}

TEST(Schema, ReportsByteArraysWhole) {
  sensor_msgs::CompressedImage image;
  image.data.assign(1234, 1);
  const auto bytes = Encode(image);
  CollectingVisitor visitor;
  SchemaOf<sensor_msgs::CompressedImage>().Walk(bytes.data(), bytes.size(), visitor);
  EXPECT_EQ(visitor.byte_arrays.at("data"), 1234u);
}

TEST(Schema, RejectsADefinitionWithAnUndefinedType) {
  EXPECT_THROW(SchemaSet::Parse("a/B", "Missing field\n"), std::invalid_argument);
  EXPECT_THROW(SchemaSet::Parse("a/B", "float64\n"), std::invalid_argument);
}

TEST(Registry, KnowsProjectAndStandardTypes) {
  ASSERT_NE(FindType("iapsim_msgs/IapState"), nullptr);
  ASSERT_NE(FindType("geometry_msgs/PoseStamped"), nullptr);
  EXPECT_EQ(FindType("geometry_msgs/PoseStamped")->info.md5, TypeInfoOf<geometry_msgs::PoseStamped>().md5);
  EXPECT_EQ(FindType("no_such/Type"), nullptr);
}

}  // namespace
}  // namespace iapsim::bridge
