#pragma once
// posix_spawn attributes that start the child with no signal blocked: a helper (the plot server,
// iapsim_media) started from a thread that blocks SIGINT and SIGTERM would otherwise inherit that mask and
// ignore Ctrl-C and kill.

#include <spawn.h>

#include <csignal>

namespace iapsim::tools {

class UnblockedSignalsSpawn {
 public:
  UnblockedSignalsSpawn() {
    posix_spawnattr_init(&attributes_);
    sigset_t none;
    sigemptyset(&none);
    posix_spawnattr_setsigmask(&attributes_, &none);
    posix_spawnattr_setflags(&attributes_, POSIX_SPAWN_SETSIGMASK);
  }
  UnblockedSignalsSpawn(const UnblockedSignalsSpawn&) = delete;
  UnblockedSignalsSpawn& operator=(const UnblockedSignalsSpawn&) = delete;
  ~UnblockedSignalsSpawn() { posix_spawnattr_destroy(&attributes_); }
  const posix_spawnattr_t* get() const { return &attributes_; }

 private:
  posix_spawnattr_t attributes_;
};

}  // namespace iapsim::tools
