#pragma once
// Offline data sets of the docking task in D4RL's layout (Fu et al. 2020, the layout d4rl and Minari's
// converters read), as HDF5 (Debian's libhdf5), so that h5py, d4rl-style loaders and this project's TD3-BC
// read the same file. One row per transition, in episode order:
//
//   observations       float32 [N, 48]   next_observations  float32 [N, 48]
//   actions            float32 [N, 12]   rewards            float32 [N]
//   terminals          bool    [N]       timeouts           bool    [N]
//   success            bool    [N]       (the step that made its episode a success)
//
// and attributes on the root: task, scenario, policy, seed, episodes, control_rate_hz, action_noise,
// observation_layout, action_layout. Booleans are HDF5 enums {FALSE, TRUE} over int8, which h5py reads as
// numpy bool.
//
// A data set is written to PATH.partial and renamed to PATH when closed, so an interrupted collection never
// leaves a file that looks complete.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rl/evaluation.h"

namespace iapsim::rl {

using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct DatasetAttributes {
  std::string task;
  std::string scenario;
  std::string policy;
  uint64_t seed = 0;
  int64_t episodes = 0;
  double control_rate_hz = 0.0;
  double action_noise = 0.0;  // σ added to the policy's actions (EpisodeOptions::action_noise)
};

class DatasetWriter {
 public:
  /// Creates PATH.partial; throws std::runtime_error naming the path when it cannot.
  explicit DatasetWriter(const std::string& path);
  /// Closes and keeps nothing where Close() was not called (the .partial file is removed).
  ~DatasetWriter();
  DatasetWriter(const DatasetWriter&) = delete;
  DatasetWriter& operator=(const DatasetWriter&) = delete;

  /// Appends an episode's transitions.
  void Append(const Transitions& transitions);
  /// Writes the attributes, closes the file and renames it to PATH.
  void Close(const DatasetAttributes& attributes);
  int64_t size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct Dataset {
  RowMatrixF observations, actions, next_observations;
  Eigen::VectorXf rewards;
  std::vector<uint8_t> terminals, timeouts, successes;
  DatasetAttributes attributes;
  int64_t size() const { return rewards.size(); }
};

/// Reads a data set; throws std::runtime_error naming the file and the field for a file that is not HDF5,
/// a missing field or one of the wrong shape.
Dataset ReadDataset(const std::string& path);

}  // namespace iapsim::rl
