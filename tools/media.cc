#include "tools/media.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "bridge/launcher.h"
#include "tools/commands.h"

extern char** environ;

namespace iapsim::tools {

nlohmann::json RunMedia(const std::vector<std::string>& args) {
  char result_path[] = "/tmp/iapsim_media_XXXXXX";
  const int fd = ::mkstemp(result_path);
  if (fd < 0)
    throw std::runtime_error(std::string("cannot make a file for iapsim_media: ") + std::strerror(errno));
  ::close(fd);
  const std::string program = bridge::ExecutableDir() + "/iapsim_media";
  std::vector<std::string> words = {program};
  words.insert(words.end(), args.begin(), args.end());
  words.push_back(result_path);
  std::vector<char*> argv;
  for (auto& word : words) argv.push_back(word.data());
  argv.push_back(nullptr);
  std::fflush(stdout);  // what this process printed comes before what the child prints
  pid_t pid = 0;
  const int spawned = ::posix_spawn(&pid, program.c_str(), nullptr, nullptr, argv.data(), environ);
  int status = 0;
  if (spawned == 0) {
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
  }
  nlohmann::json result;
  {
    std::ifstream in(result_path);
    result = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  }
  ::unlink(result_path);
  if (spawned != 0) throw std::runtime_error("cannot start " + program + ": " + std::strerror(spawned));
  if (result.is_object() && result.contains("error"))
    throw std::runtime_error(result["error"].get<std::string>());
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !result.is_object()) {
    throw std::runtime_error(program + " " + args.front() + " failed (" +
                             (WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status))
                                                  : "exit status " + std::to_string(WEXITSTATUS(status))) +
                             ") without saying why");
  }
  return result;
}

int BenchRender(const std::string& scene_path, const std::string& vehicle_path, nlohmann::json* report) {
  const nlohmann::json result = RunMedia({"bench-render", scene_path, vehicle_path});
  (*report)["render"] = result.at("render");
  return result.at("status").get<int>();
}

}  // namespace iapsim::tools
