#include "rosbridge/ros_bridge.h"

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMain(argc, argv, "iapsim ros bridge: forwards topics between a run and ROS1",
                                     iapsim::rosbridge::MakeRosBridge);
}
