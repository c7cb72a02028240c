// ros_square_node: a plain roscpp node, not linked to iapsim, that flies a vehicle on a square. It is what
// a user's own ROS controller looks like to iapsim: it reads nav_msgs/Odometry and publishes
// geometry_msgs/PoseStamped setpoints, and would fly a real IAP with the topics remapped.
//
// It answers every odometry message with one setpoint stamped as that odometry (so a bridge can pair them:
// round trips in realtime, lockstep participation). The square starts where the first odometry is, keeps
// that attitude and height, and has its corners at +x, +x+y, +y (the odometry's frame) and back; the node
// moves on to the next corner once the vehicle has stayed within ~tolerance_m of the current one for
// ~hold_s (odometry time), and holds the start once back there.
//
//   ros_square_node [odom:=/iap/odom] [setpoint:=/iap/setpoint] [_side_m:=1.0] [_tolerance_m:=0.15]
//                   [_hold_s:=1.0] [_idle_exit_s:=0]
//
// It runs until stopped, or with idle_exit_s > 0 until odometry has not come for that long (wall time, from
// its start when none came);
// the exit status is 0 when the square was flown.

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <array>
#include <cmath>
#include <optional>

namespace {

class SquareNode {
 public:
  explicit SquareNode(ros::NodeHandle& node) {
    ros::NodeHandle settings("~");
    settings.param("side_m", side_m_, 1.0);
    settings.param("tolerance_m", tolerance_m_, 0.15);
    settings.param("hold_s", hold_s_, 1.0);
    publisher_ = node.advertise<geometry_msgs::PoseStamped>("setpoint", 100);
    subscriber_ =
        node.subscribe("odom", 100, &SquareNode::OnOdometry, this, ros::TransportHints().tcpNoDelay());
  }

  bool done() const { return done_; }
  const std::optional<ros::WallTime>& last_odometry() const { return last_odometry_; }

 private:
  void OnOdometry(const nav_msgs::Odometry& odometry) {
    last_odometry_ = ros::WallTime::now();
    const geometry_msgs::Point& p = odometry.pose.pose.position;
    if (!start_) {
      start_ = odometry.pose.pose;
      ROS_INFO("start at (%.2f, %.2f, %.2f), square of %.2f m", p.x, p.y, p.z, side_m_);
    }
    const std::array<double, 2> offset = kCorners[corner_];
    geometry_msgs::PoseStamped setpoint;
    setpoint.header = odometry.header;
    setpoint.pose = *start_;
    setpoint.pose.position.x += offset[0] * side_m_;
    setpoint.pose.position.y += offset[1] * side_m_;
    publisher_.publish(setpoint);

    const double distance_m = std::hypot(p.x - setpoint.pose.position.x, p.y - setpoint.pose.position.y,
                                         p.z - setpoint.pose.position.z);
    if (distance_m > tolerance_m_ || done_) {
      near_since_.reset();
      return;
    }
    if (!near_since_) near_since_ = odometry.header.stamp;
    if ((odometry.header.stamp - *near_since_).toSec() < hold_s_) return;
    ROS_INFO("corner %zu reached at t = %.3f s (%.3f m off)", corner_, odometry.header.stamp.toSec(),
             distance_m);
    near_since_.reset();
    if (corner_ + 1 == kCorners.size()) {
      done_ = true;
      ROS_INFO("square done");
    } else {
      ++corner_;
    }
  }

  // the corners in units of the side, the start last
  static constexpr std::array<std::array<double, 2>, 4> kCorners{
      {{1.0, 0.0}, {1.0, 1.0}, {0.0, 1.0}, {0.0, 0.0}}};

  double side_m_ = 1.0, tolerance_m_ = 0.15, hold_s_ = 1.0;
  ros::Publisher publisher_;
  ros::Subscriber subscriber_;
  std::optional<geometry_msgs::Pose> start_;
  std::optional<ros::Time> near_since_;
  std::optional<ros::WallTime> last_odometry_;
  size_t corner_ = 0;
  bool done_ = false;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "ros_square");
  ros::NodeHandle node;
  double idle_exit_s = 0.0;
  ros::NodeHandle("~").param("idle_exit_s", idle_exit_s, 0.0);
  SquareNode square(node);
  const ros::WallTime started = ros::WallTime::now();
  // answers until stopped (Ctrl-C), the last corner held, or, with idle_exit_s, once odometry has stopped
  // coming for that long; exit status 0 when the square was flown
  ros::CallbackQueue& queue = *ros::getGlobalCallbackQueue();
  while (ros::ok()) {
    queue.callAvailable(ros::WallDuration(0.01));
    // idle since the last odometry, or since the start when none came (a run that ended before)
    const ros::WallTime since = square.last_odometry() ? *square.last_odometry() : started;
    if (idle_exit_s > 0.0 && (ros::WallTime::now() - since).toSec() > idle_exit_s) {
      break;
    }
  }
  return square.done() ? 0 : 1;
}
