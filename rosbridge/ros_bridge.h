#pragma once
// iapsim_ros_bridge: forwards chosen topics between a run's bus and ROS1 (roscpp). The bus already carries
// ROS1-serialised bytes (DESIGN, wire format), so nothing is decoded: a topic goes to ROS through
// topic_tools' ShapeShifter advertised with the type's name, md5 and definition, and comes back the same way.
//
// params:
//   master: environment | private   environment: the master at ROS_MASTER_URI (ROS_IP / ROS_HOSTNAME as any
//                                   node); private: a roscore of the run's own on 127.0.0.1 (master_port, 0:
//                                   a free one), logs in RUN/ros, its URI in RUN/ros/master_uri, stopped with
//                                   the run; it has /use_sim_time set when `clock` is on
//   master_timeout_s                how long to wait for the master to answer (roscore takes seconds)
//   node_name                       this node's ROS name (default iapsim_bridge)
//   clock: true                     publish rosgraph_msgs/Clock on /clock at each of this process's steps
//   queue_size                      of every ROS publisher and subscriber (default 100)
//   to_ros:   [{topic, type, as, rate_hz}]          bus topic -> ROS topic `as` (default: the same name);
//                                                   rate_hz: the first message of each 1/rate window of its
//                                                   stamp (0: every message)
//   from_ros: [{topic, type, as, answers, answer_timeout_s}]  ROS topic -> bus topic `as`
//     answers: a to_ros topic (its ROS name) that the ROS node answers, message for message, with a message
//     stamped as the one it answers. The bridge measures each round trip (from the bus publisher's send of
//     the question to the bus publish of the answer) and reports it; in lockstep it also waits, at each of
//     its steps, for the answer to what it forwarded (up to answer_timeout_s), which makes the ROS node a
//     lockstep participant: the run is then as reproducible as the node.
//   tf: {vehicles: [{name, file}], rate_hz: 50, robot_description: true, mounts_from: [PROCESS...]}
//     /tf from each vehicle's /<name>/state (the first state of each 1/rate window of sim time; 0: every
//     state), /tf_static (latched) for the fixed frames, in the scheme of rosbridge/vehicle_tf.h, and the
//     vehicle's `iapsim urdf --ros` URDF as /<name>/robot_description (and /robot_description for one
//     vehicle)
//     mounts_from: sensors and render processes of the scenario whose IMU and camera frames go on /tf_static
//     (rosbridge/mount_frames.h)
//
// Timing. realtime and fast: a message from ROS goes onto the bus as soon as it arrives (the process looks
// every poll_period_us); lockstep: messages from ROS are published at this process's next step, so they are
// applied on the step grid (give the consumer `after: [this process]` to read them in the same step). A ROS
// node that answers late in lockstep (without `answers`) has its message applied at whatever step it
// arrived by: the run goes on without it and is not reproducible.

#include <memory>

#include "bridge/process.h"

namespace iapsim::rosbridge {

std::unique_ptr<bridge::Process> MakeRosBridge(const bridge::ProcessContext& context,
                                               bridge::YamlMap& params);

}  // namespace iapsim::rosbridge
