#pragma once
// Eigen <-> geometry_msgs for the processes that put library results on the bus (header only).

#include <geometry_msgs/Point.h>
#include <geometry_msgs/Quaternion.h>
#include <geometry_msgs/Vector3.h>
#include <ros/time.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

namespace iapsim::bridge {

inline geometry_msgs::Vector3 ToVector3Msg(const Eigen::Vector3d& v) {
  geometry_msgs::Vector3 m;
  m.x = v.x();
  m.y = v.y();
  m.z = v.z();
  return m;
}

inline geometry_msgs::Point ToPointMsg(const Eigen::Vector3d& v) {
  geometry_msgs::Point m;
  m.x = v.x();
  m.y = v.y();
  m.z = v.z();
  return m;
}

inline geometry_msgs::Quaternion ToQuaternionMsg(const Eigen::Quaterniond& q) {
  geometry_msgs::Quaternion m;
  m.w = q.w();
  m.x = q.x();
  m.y = q.y();
  m.z = q.z();
  return m;
}

inline Eigen::Vector3d FromMsg(const geometry_msgs::Vector3& m) { return Eigen::Vector3d(m.x, m.y, m.z); }
inline Eigen::Vector3d FromMsg(const geometry_msgs::Point& m) { return Eigen::Vector3d(m.x, m.y, m.z); }
/// Not normalised: a caller that needs a rotation checks the norm (a bad norm is bad input, not noise).
inline Eigen::Quaterniond FromMsg(const geometry_msgs::Quaternion& m) {
  return Eigen::Quaterniond(m.w, m.x, m.y, m.z);
}

inline ros::Time ToRosTime(int64_t ns) {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(ns));
  return t;
}

inline int64_t ToNanoseconds(const ros::Time& t) { return static_cast<int64_t>(t.toNSec()); }

}  // namespace iapsim::bridge
