#pragma once
// A private ROS master for one run: `roscore` on a loopback port, its logs in the run directory, stopped with
// the run (and with this process, should it die first: the child gets SIGTERM from the kernel then).

#include <sys/types.h>

#include <string>

namespace iapsim::rosbridge {

class PrivateRosMaster {
 public:
  /// Starts `roscore -p PORT` (port 0: a free one) with ROS_IP=127.0.0.1, so its Python nodes listen on
  /// loopback only, and ROS_HOME and ROS_LOG_DIR in `log_dir` (its output in log_dir/roscore.log). Throws
  /// std::runtime_error when it cannot be started. That it answers is for the caller to wait for (roscpp).
  PrivateRosMaster(int port, const std::string& log_dir);
  ~PrivateRosMaster();  // SIGTERM (roscore stops rosmaster and rosout), SIGKILL if it takes over 5 s
  PrivateRosMaster(const PrivateRosMaster&) = delete;
  PrivateRosMaster& operator=(const PrivateRosMaster&) = delete;

  /// http://127.0.0.1:PORT/
  const std::string& uri() const { return uri_; }
  /// Throws std::runtime_error, naming the exit status and the log, when roscore has exited.
  void CheckAlive();

 private:
  std::string uri_;
  std::string log_file_;
  pid_t pid_ = -1;
};

/// A TCP port on 127.0.0.1 that nothing listens on now (it may be taken before it is used).
int FreeLoopbackPort();

}  // namespace iapsim::rosbridge
