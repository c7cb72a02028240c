#include "tools/batch.h"

#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>

namespace iapsim::tools {

std::vector<std::string> ReadSetOverrides(bridge::YamlMap& map) {
  std::vector<std::string> overrides;
  if (!map.Has("set")) return overrides;
  const YAML::Node set = map.Raw("set");
  if (!set.IsMap()) map.Fail("set", "expected a map of scenario keys (dotted, as --set) to values");
  for (const auto& entry : set) {
    YAML::Emitter value;
    value << YAML::Flow << entry.second;
    overrides.push_back(entry.first.Scalar() + "=" + value.c_str());
  }
  return overrides;
}

double InterpolatedPercentile(const std::vector<double>& sorted, double p) {
  const double h = (sorted.size() - 1) * p / 100.0;
  const size_t below = static_cast<size_t>(std::floor(h));
  const size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (h - below) * (sorted[above] - sorted[below]);
}

nlohmann::json MetricStatistics(const std::vector<nlohmann::json>& runs) {
  std::map<std::string, std::vector<double>> values;  // by JSON pointer
  for (const nlohmann::json& metrics : runs) {
    const nlohmann::json flat = metrics.flatten();  // items() of a temporary would outlive it
    for (const auto& [pointer, value] : flat.items()) {
      if (value.is_number()) values[pointer].push_back(value.get<double>());
    }
  }
  nlohmann::json flat = nlohmann::json::object();
  for (auto& [pointer, samples] : values) {
    std::sort(samples.begin(), samples.end());
    double sum = 0.0;
    for (double v : samples) sum += v;
    flat[pointer + "/p5"] = InterpolatedPercentile(samples, 5.0);
    flat[pointer + "/p50"] = InterpolatedPercentile(samples, 50.0);
    flat[pointer + "/p95"] = InterpolatedPercentile(samples, 95.0);
    flat[pointer + "/mean"] = sum / samples.size();
    flat[pointer + "/min"] = samples.front();
    flat[pointer + "/max"] = samples.back();
    flat[pointer + "/draws"] = samples.size();
  }
  return flat.unflatten();
}

CommandResult RunCapturing(const std::vector<std::string>& argv) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return {-1, std::string("pipe: ") + std::strerror(errno)};
  const pid_t pid = fork();
  if (pid < 0) {
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    return {-1, std::string("fork: ") + std::strerror(errno)};
  }
  if (pid == 0) {
    dup2(pipe_fds[1], STDOUT_FILENO);
    dup2(pipe_fds[1], STDERR_FILENO);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execvp(args[0], args.data());
    const std::string message = argv[0] + ": " + std::strerror(errno) + "\n";
    (void)!write(STDERR_FILENO, message.data(), message.size());
    _exit(127);
  }
  close(pipe_fds[1]);
  CommandResult result;
  char buffer[4096];
  for (;;) {
    const ssize_t n = read(pipe_fds[0], buffer, sizeof buffer);
    if (n > 0) {
      result.output.append(buffer, static_cast<size_t>(n));
    } else if (n == 0 || errno != EINTR) {
      break;
    }
  }
  close(pipe_fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return result;
}

}  // namespace iapsim::tools
