#include "bridge/run_secret.h"

#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace iapsim::bridge {

std::string CreateRunSecret(const std::string& run_dir) {
  unsigned char bytes[32];
  // the kernel's CSPRNG (never the clock); blocks only before the pool is first initialised at boot
  if (getrandom(bytes, sizeof(bytes), 0) != static_cast<ssize_t>(sizeof(bytes))) {
    throw std::runtime_error(std::string("getrandom: ") + std::strerror(errno));
  }
  std::string secret;
  for (const unsigned char b : bytes) {
    secret += "0123456789abcdef"[b >> 4];
    secret += "0123456789abcdef"[b & 15];
  }
  const std::string path = run_dir + "/secret";
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0 || fchmod(fd, 0600) != 0 ||
      write(fd, secret.data(), secret.size()) != static_cast<ssize_t>(secret.size())) {
    const std::string error = std::strerror(errno);
    if (fd >= 0) close(fd);
    throw std::runtime_error("cannot write the run's secret " + path + ": " + error);
  }
  close(fd);
  return secret;
}

std::string ReadRunSecret(const std::string& run_dir) {
  if (const char* secret = std::getenv("IAPSIM_RUN_SECRET")) return secret;
  if (run_dir.empty()) return "";
  std::ifstream in(run_dir + "/secret");
  std::string secret;
  std::getline(in, secret);
  return secret;
}

bool SameSecret(const std::string& a, const std::string& b) {
  unsigned char differ = a.size() == b.size() ? 0 : 1;
  const size_t n = std::min(a.size(), b.size());
  for (size_t i = 0; i < n; ++i) differ |= static_cast<unsigned char>(a[i] ^ b[i]);
  return differ == 0;
}

}  // namespace iapsim::bridge
