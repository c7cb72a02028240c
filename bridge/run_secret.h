#pragma once
// A run's secret: 32 random bytes (64 hex digits) the launcher makes for each run and keeps in RUN/secret
// (mode 0600, so only the user who started the run can read it). Every connection to the run's control
// channel and shared-memory bus must present it: other local processes can neither join, read nor stall
// the run. A process started by hand (or on another host) is given it through IAPSIM_RUN_SECRET.

#include <string>

namespace iapsim::bridge {

/// Makes RUN/secret and returns the secret. Throws std::runtime_error naming the file.
std::string CreateRunSecret(const std::string& run_dir);

/// IAPSIM_RUN_SECRET when set, else the content of RUN/secret; empty when neither exists (a bus or a
/// control channel made outside a run, as unit tests do: its peers must have none either).
std::string ReadRunSecret(const std::string& run_dir);

/// Compares in constant time: how long a refusal takes says nothing about how much of a guess was right.
bool SameSecret(const std::string& a, const std::string& b);

}  // namespace iapsim::bridge
