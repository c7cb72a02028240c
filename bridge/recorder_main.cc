#include "bridge/recorder.h"

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMain(argc, argv, "iapsim recorder: writes the bus to run.bag",
                                     iapsim::bridge::MakeRecorder);
}
