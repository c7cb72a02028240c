#include "tools/plot_script.h"

#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tools/spawn_attributes.h"

extern char** environ;

namespace iapsim::tools {
namespace {

// tools/plot_server.py behind a socket pair (its stdin and stdout), started on the first plot and ended
// (end of input, then reaped) when the program exits; a server that died is started again for the next plot
class PlotServer {
 public:
  ~PlotServer() { Stop(); }

  bool Run(const std::string& script, const std::vector<std::string>& args) {
    if (fd_ < 0 && !Start()) return false;
    nlohmann::json job = nlohmann::json::array({script});
    for (const auto& arg : args) job.push_back(arg);
    const std::string line = job.dump() + "\n";
    std::string reply;
    if (!Send(line) || !ReadLine(&reply)) {
      std::fprintf(stderr, "iapsim: the plot server (%s) stopped while plotting %s\n", IAPSIM_PLOT_SERVER,
                   script.c_str());
      Stop();
      return false;
    }
    if (reply != "ok") {
      std::fprintf(stderr, "iapsim: %s failed (%s); the metrics are complete\n", script.c_str(),
                   reply.c_str());
      return false;
    }
    return true;
  }

 private:
  bool Start() {
    int fds[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) {
      std::fprintf(stderr, "iapsim: cannot make the plot server's socket: %s\n", std::strerror(errno));
      return false;
    }
    const std::string python = std::ifstream("/usr/bin/python3").good() ? "/usr/bin/python3" : "python3";
    std::string server = IAPSIM_PLOT_SERVER;
    char* argv[] = {const_cast<char*>(python.c_str()), server.data(), nullptr};
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDIN_FILENO);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    const UnblockedSignalsSpawn attributes;
    const int spawned = posix_spawnp(&pid_, python.c_str(), &actions, attributes.get(), argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (spawned != 0) {
      std::fprintf(stderr, "iapsim: cannot start %s for %s: %s\n", python.c_str(), IAPSIM_PLOT_SERVER,
                   std::strerror(spawned));
      close(fds[0]);
      pid_ = -1;
      return false;
    }
    fd_ = fds[0];
    return true;
  }

  void Stop() {
    if (fd_ >= 0) close(fd_);  // end of input: the server returns
    fd_ = -1;
    if (pid_ > 0) waitpid(pid_, nullptr, 0);
    pid_ = -1;
    buffer_.clear();
  }

  bool Send(const std::string& line) {
    size_t sent = 0;
    while (sent < line.size()) {
      const ssize_t n = send(fd_, line.data() + sent, line.size() - sent, MSG_NOSIGNAL);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      sent += static_cast<size_t>(n);
    }
    return true;
  }

  bool ReadLine(std::string* line) {
    size_t end;
    while ((end = buffer_.find('\n')) == std::string::npos) {
      char chunk[4096];
      const ssize_t n = read(fd_, chunk, sizeof chunk);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      buffer_.append(chunk, static_cast<size_t>(n));
    }
    *line = buffer_.substr(0, end);
    buffer_.erase(0, end + 1);
    return true;
  }

  int fd_ = -1;
  pid_t pid_ = -1;
  std::string buffer_;
};

}  // namespace

bool RunPlotScript(const std::string& script, const std::vector<std::string>& args) {
  static PlotServer server;
  return server.Run(script, args);
}

}  // namespace iapsim::tools
