#pragma once
// The fixed frames of what a scenario's processes mount on bodies, for /tf_static: the sensors process's IMUs
// (V/SUB -> V/SUB/imu, the frame its sensor_msgs/Imu name) and the render process's cameras (BODY ->
// the optical frame each eye's images name, W for a world-fixed camera). Read from those processes' params
// with their own readers, so the frames are where the sensors and the renderer put them. UWB tags sit at
// each sub-aircraft's origin (sensors/uwb.h): their frame is V/SUB itself.

#include <string>
#include <vector>

#include "bridge/scenario.h"
#include "rosbridge/vehicle_tf.h"

namespace iapsim::rosbridge {

struct MountFrames {
  std::vector<FrameTransform> fixed;
  std::vector<std::string> moving;  // frames that follow a body without being fixed to it (chase cameras)
};

/// The mounts of process `process` of the scenario (an iapsim_sensors or iapsim_render process). Throws
/// bridge::ConfigError naming the process when it is neither, or its params do not read.
MountFrames ReadMountFrames(const bridge::Scenario& scenario, const std::string& process);

}  // namespace iapsim::rosbridge
