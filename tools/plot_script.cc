#include "tools/plot_script.h"

#include <spawn.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstring>
#include <fstream>

extern char** environ;

namespace iapsim::tools {

bool RunPlotScript(const std::string& script, const std::vector<std::string>& args) {
  const std::string python = std::ifstream("/usr/bin/python3").good() ? "/usr/bin/python3" : "python3";
  std::vector<std::string> words = {python, script};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& word : words) argv.push_back(word.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, python.c_str(), nullptr, nullptr, argv.data(), environ);
  if (spawned != 0) {
    std::fprintf(stderr, "iapsim: cannot start %s for %s: %s\n", python.c_str(), script.c_str(),
                 std::strerror(spawned));
    return false;
  }
  int status = 0;
  if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::fprintf(stderr, "iapsim: %s failed (see above); the metrics are complete\n", script.c_str());
    return false;
  }
  return true;
}

}  // namespace iapsim::tools
