#include "bridge/message_registry.h"

#include <geometry_msgs/AccelStamped.h>
#include <geometry_msgs/PointStamped.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/WrenchStamped.h>
#include <iapsim_msgs/ContactArray.h>
#include <iapsim_msgs/Hello.h>
#include <iapsim_msgs/IapCommand.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/LatchCommand.h>
#include <iapsim_msgs/LatchEvent.h>
#include <iapsim_msgs/Setpoint.h>
#include <iapsim_msgs/StepAck.h>
#include <iapsim_msgs/Tick.h>
#include <iapsim_msgs/UwbRanges.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/BatteryState.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Float64.h>
#include <std_msgs/String.h>

#include <algorithm>
#include <map>

namespace iapsim::bridge {
namespace {

template <class M>
void Register(std::map<std::string, RegisteredType>* types) {
  const TypeInfo& info = TypeInfoOf<M>();
  (*types)[info.datatype] = RegisteredType{info, SchemaSet::Parse(info.datatype, info.definition)};
}

std::map<std::string, RegisteredType> BuildRegistry() {
  std::map<std::string, RegisteredType> types;
  Register<iapsim_msgs::ContactArray>(&types);
  Register<iapsim_msgs::Hello>(&types);
  Register<iapsim_msgs::IapCommand>(&types);
  Register<iapsim_msgs::IapState>(&types);
  Register<iapsim_msgs::LatchCommand>(&types);
  Register<iapsim_msgs::LatchEvent>(&types);
  Register<iapsim_msgs::Setpoint>(&types);
  Register<iapsim_msgs::StepAck>(&types);
  Register<iapsim_msgs::Tick>(&types);
  Register<iapsim_msgs::UwbRanges>(&types);
  Register<geometry_msgs::AccelStamped>(&types);
  Register<geometry_msgs::PointStamped>(&types);
  Register<geometry_msgs::PoseStamped>(&types);
  Register<geometry_msgs::TransformStamped>(&types);
  Register<geometry_msgs::TwistStamped>(&types);
  Register<geometry_msgs::WrenchStamped>(&types);
  Register<nav_msgs::Odometry>(&types);
  Register<nav_msgs::Path>(&types);
  Register<rosgraph_msgs::Clock>(&types);
  Register<sensor_msgs::BatteryState>(&types);
  Register<sensor_msgs::CameraInfo>(&types);
  Register<sensor_msgs::CompressedImage>(&types);
  Register<sensor_msgs::Image>(&types);
  Register<sensor_msgs::Imu>(&types);
  Register<sensor_msgs::Range>(&types);
  Register<std_msgs::Float64>(&types);
  Register<std_msgs::String>(&types);
  return types;
}

const std::map<std::string, RegisteredType>& Registry() {
  // immutable after construction
  static const std::map<std::string, RegisteredType> registry = BuildRegistry();
  return registry;
}

}  // namespace

const RegisteredType* FindType(const std::string& datatype) {
  const auto& registry = Registry();
  const auto it = registry.find(datatype);
  return it == registry.end() ? nullptr : &it->second;
}

std::vector<const RegisteredType*> AllTypes() {
  std::vector<const RegisteredType*> all;
  for (const auto& [name, type] : Registry()) all.push_back(&type);
  return all;
}

}  // namespace iapsim::bridge
