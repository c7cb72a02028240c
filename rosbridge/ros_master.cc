#include "rosbridge/ros_master.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <thread>
#include <vector>

namespace iapsim::rosbridge {

int FreeLoopbackPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  const bool ok = bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
                  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0;
  const int error = errno;
  close(fd);
  if (!ok) throw std::runtime_error(std::string("no free port on 127.0.0.1: ") + std::strerror(error));
  return ntohs(address.sin_port);
}

PrivateRosMaster::PrivateRosMaster(int port, const std::string& log_dir) {
  if (port == 0) port = FreeLoopbackPort();
  uri_ = "http://127.0.0.1:" + std::to_string(port) + "/";
  std::filesystem::create_directories(log_dir);
  log_file_ = log_dir + "/roscore.log";
  // everything the child needs is prepared before fork (it only calls async-signal-safe functions after)
  const std::string port_text = std::to_string(port);
  // this process's environment, with the master's own ROS variables
  std::vector<std::string> environment = {"ROS_MASTER_URI=" + uri_, "ROS_IP=127.0.0.1", "ROS_HOME=" + log_dir,
                                          "ROS_LOG_DIR=" + log_dir};
  for (char** e = environ; *e; ++e) {
    const std::string entry = *e;
    if (entry.rfind("ROS_MASTER_URI=", 0) != 0 && entry.rfind("ROS_IP=", 0) != 0 &&
        entry.rfind("ROS_HOSTNAME=", 0) != 0 && entry.rfind("ROS_HOME=", 0) != 0 &&
        entry.rfind("ROS_LOG_DIR=", 0) != 0) {
      environment.push_back(entry);
    }
  }
  std::vector<char*> envp;
  for (std::string& entry : environment) envp.push_back(entry.data());
  envp.push_back(nullptr);
  char* argv[] = {const_cast<char*>("roscore"), const_cast<char*>("-p"), const_cast<char*>(port_text.c_str()),
                  nullptr};
  const int log_fd = open(log_file_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log_fd < 0) throw std::runtime_error(log_file_ + ": " + std::strerror(errno));
  const pid_t parent = getpid();
  pid_ = fork();
  if (pid_ < 0) {
    close(log_fd);
    throw std::runtime_error(std::string("fork for roscore: ") + std::strerror(errno));
  }
  if (pid_ == 0) {
    prctl(PR_SET_PDEATHSIG, SIGTERM);  // this process gone -> the master goes too
    if (getppid() != parent) _exit(1);
    dup2(log_fd, STDOUT_FILENO);
    dup2(log_fd, STDERR_FILENO);
    execvpe("roscore", argv, envp.data());
    _exit(127);
  }
  close(log_fd);
}

PrivateRosMaster::~PrivateRosMaster() {
  if (pid_ <= 0) return;
  kill(pid_, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (waitpid(pid_, nullptr, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

void PrivateRosMaster::CheckAlive() {
  if (pid_ <= 0) return;
  int status = 0;
  if (waitpid(pid_, &status, WNOHANG) != pid_) return;
  pid_ = -1;
  const std::string how = WIFEXITED(status) ? "exited with status " + std::to_string(WEXITSTATUS(status))
                                            : "was killed by signal " + std::to_string(WTERMSIG(status));
  throw std::runtime_error(
      "the run's ROS master (roscore, " + uri_ + ") " + how +
      (WIFEXITED(status) && WEXITSTATUS(status) == 127 ? " (roscore not found: install ros-core)" : "") +
      "; its log: " + log_file_);
}

}  // namespace iapsim::rosbridge
