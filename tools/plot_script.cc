#include "tools/plot_script.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

extern char** environ;

namespace iapsim::tools {
namespace {

constexpr const char* kSharedSocketVariable = "IAPSIM_PLOT_SOCKET";

bool SendAll(int fd, const std::string& line) {
  size_t sent = 0;
  while (sent < line.size()) {
    const ssize_t n = send(fd, line.data() + sent, line.size() - sent, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    sent += static_cast<size_t>(n);
  }
  return true;
}

// One line from `fd`, what came after it kept in `buffer`.
bool ReadLine(int fd, std::string* buffer, std::string* line) {
  size_t end;
  while ((end = buffer->find('\n')) == std::string::npos) {
    char chunk[4096];
    const ssize_t n = read(fd, chunk, sizeof chunk);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    buffer->append(chunk, static_cast<size_t>(n));
  }
  *line = buffer->substr(0, end);
  buffer->erase(0, end + 1);
  return true;
}

std::string JobLine(const std::string& script, const std::vector<std::string>& args) {
  nlohmann::json job = nlohmann::json::array({script});
  for (const auto& arg : args) job.push_back(arg);
  return job.dump() + "\n";
}

bool Succeeded(const std::string& script, const std::string& reply) {
  if (reply == "ok") return true;
  std::fprintf(stderr, "iapsim: %s failed (%s); the metrics are complete\n", script.c_str(), reply.c_str());
  return false;
}

// The address of a unix socket `name`: a path, or "@" and a name in the abstract namespace (nothing on disk
// to remove, even after a SIGKILL). False when it does not fit.
bool SocketAddress(const std::string& name, sockaddr_un* address, socklen_t* length) {
  *address = sockaddr_un{};
  address->sun_family = AF_UNIX;
  if (name.empty() || name.size() >= sizeof address->sun_path) return false;
  std::memcpy(address->sun_path, name.data(), name.size());
  if (name[0] == '@') address->sun_path[0] = '\0';  // abstract: the length, not a NUL, ends its name
  *length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + name.size() + (name[0] == '@' ? 0 : 1));
  return true;
}

// Runs the job on the server a SharedPlotServer of the program that started this one listens on; false
// (`reply` empty) when it cannot be reached.
bool RunShared(const char* socket_name, const std::string& line, std::string* reply) {
  sockaddr_un address;
  socklen_t length;
  if (!SocketAddress(socket_name, &address, &length)) return false;
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  std::string buffer;
  const bool answered = connect(fd, reinterpret_cast<const sockaddr*>(&address), length) == 0 &&
                        SendAll(fd, line) && ReadLine(fd, &buffer, reply);
  close(fd);
  return answered;
}

// Starts tools/plot_server.py with `argv_tail` after the script's path, its stdin and stdout the given
// descriptors (and `listener` as itself where it is not -1); -1 when it cannot start.
pid_t StartServer(int stdin_fd, int stdout_fd, int listener, const std::vector<std::string>& argv_tail) {
  const std::string python = std::ifstream("/usr/bin/python3").good() ? "/usr/bin/python3" : "python3";
  std::vector<std::string> words = {python, IAPSIM_PLOT_SERVER};
  words.insert(words.end(), argv_tail.begin(), argv_tail.end());
  std::vector<char*> argv;
  for (std::string& word : words) argv.push_back(word.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, stdin_fd, STDIN_FILENO);
  posix_spawn_file_actions_adddup2(&actions, stdout_fd, STDOUT_FILENO);
  if (listener >= 0) posix_spawn_file_actions_adddup2(&actions, listener, listener);  // clears CLOEXEC
  pid_t pid = -1;
  const int spawned = posix_spawnp(&pid, python.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    std::fprintf(stderr, "iapsim: cannot start %s for %s: %s\n", python.c_str(), IAPSIM_PLOT_SERVER,
                 std::strerror(spawned));
    return -1;
  }
  return pid;
}

// tools/plot_server.py behind a socket pair (its stdin and stdout), started on the first plot and ended
// (end of input, then reaped) when the program exits; a server that died is started again for the next plot
class PlotServer {
 public:
  ~PlotServer() { Stop(); }

  bool Run(const std::string& script, const std::string& line) {
    if (fd_ < 0 && !Start()) return false;
    std::string reply;
    if (!SendAll(fd_, line) || !ReadLine(fd_, &buffer_, &reply)) {
      std::fprintf(stderr, "iapsim: the plot server (%s) stopped while plotting %s\n", IAPSIM_PLOT_SERVER,
                   script.c_str());
      Stop();
      return false;
    }
    return Succeeded(script, reply);
  }

 private:
  bool Start() {
    int fds[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) {
      std::fprintf(stderr, "iapsim: cannot make the plot server's socket: %s\n", std::strerror(errno));
      return false;
    }
    pid_ = StartServer(fds[1], fds[1], -1, {});
    close(fds[1]);
    if (pid_ < 0) {
      close(fds[0]);
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

  int fd_ = -1;
  pid_t pid_ = -1;
  std::string buffer_;
};

}  // namespace

bool RunPlotScript(const std::string& script, const std::vector<std::string>& args) {
  const std::string line = JobLine(script, args);
  if (const char* shared = std::getenv(kSharedSocketVariable)) {
    std::string reply;
    if (RunShared(shared, line, &reply)) return Succeeded(script, reply);
  }
  static PlotServer server;  // no shared one, or it is gone
  return server.Run(script, line);
}

SharedPlotServer::SharedPlotServer() {
  if (std::getenv(kSharedSocketVariable) != nullptr) return;  // one serves already: an enclosing one's
  // abstract (nothing to clean up), of this user only: the server serves no other uid (SO_PEERCRED)
  std::random_device random;
  const std::string name = "@iapsim-plots-" + std::to_string(getpid()) + "-" + std::to_string(random());
  sockaddr_un address;
  socklen_t length;
  if (!SocketAddress(name, &address, &length)) return;
  int input[2] = {-1, -1};
  const int listener = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  // listening before the server starts: a run that plots before Python is up waits in the backlog
  if (listener >= 0 && bind(listener, reinterpret_cast<const sockaddr*>(&address), length) == 0 &&
      listen(listener, 64) == 0 && pipe2(input, O_CLOEXEC) == 0) {
    pid_ = StartServer(input[0], STDERR_FILENO, listener, {"--listen-fd", std::to_string(listener)});
  }
  if (listener >= 0) close(listener);
  if (input[0] >= 0) close(input[0]);
  if (pid_ > 0) {
    input_ = input[1];
    setenv(kSharedSocketVariable, name.c_str(), 1);
  } else if (input[1] >= 0) {
    close(input[1]);
  }
}

SharedPlotServer::~SharedPlotServer() {
  if (pid_ > 0) {
    unsetenv(kSharedSocketVariable);
    close(input_);  // end of its stdin: it returns once the plot in hand is done
    waitpid(pid_, nullptr, 0);
  }
}

}  // namespace iapsim::tools
