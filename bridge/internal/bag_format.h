#pragma once
// ROS bag format 2.0 (http://wiki.ros.org/Bags/Format/2.0): the constants the project's writer and reader
// share. The layout is described in bag_writer.cc.

#include <cstdint>
#include <limits>
#include <string>

#include "bridge/bag.h"

namespace iapsim::bridge::bag_format {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "bag records are little-endian, copied by memcpy");

constexpr char kVersionLine[] = "#ROSBAG V2.0\n";
constexpr uint8_t kOpMessageData = 0x02;
constexpr uint8_t kOpBagHeader = 0x03;
constexpr uint8_t kOpIndexData = 0x04;
constexpr uint8_t kOpChunk = 0x05;
constexpr uint8_t kOpChunkInfo = 0x06;
constexpr uint8_t kOpConnection = 0x07;
constexpr uint32_t kIndexVersion = 1;
constexpr uint32_t kChunkInfoVersion = 1;
constexpr int64_t kMaxTimeNs = int64_t{std::numeric_limits<uint32_t>::max()} * 1000000000 + 999999999;

inline BagError ErrorFor(const std::string& path, const std::string& what) {
  return BagError("bag '" + path + "': " + what);
}

}  // namespace iapsim::bridge::bag_format
