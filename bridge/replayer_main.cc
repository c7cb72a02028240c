#include "bridge/replayer.h"

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMain(argc, argv, "iapsim replayer: plays recorded topics of a bag into a run",
                                     iapsim::bridge::MakeReplayer);
}
