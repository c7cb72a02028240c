#pragma once
// Files of timed poses, as `iapsim export` writes them and as trajectory tools (evo, TUM RGB-D) exchange
// them: TUM lines "t x y z qx qy qz qw", or CSV with a header (t_s, x_m, y_m, z_m, qx, qy, qz, qw, or
// time_s and the first pose or transform of an exported topic). Read for a recorded trajectory (control)
// and for replaying a command log (the replayer).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "bridge/message_format.h"

namespace iapsim::bridge {

struct TimedPose {
  double t_s = 0.0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // normalised
};

/// Reads a pose file of `format` "tum" or "csv". Times strictly increase; quaternions have norm 1 within
/// 1e-3 (recorders print a few digits) and come back normalised. Throws ConfigError naming the file, the
/// line and the column on anything else, and for a file without a pose.
std::vector<TimedPose> ReadPoseFile(const std::string& path, const std::string& format);

/// Writes `poses` as a TUM file after a "# `comment`" line. Throws std::runtime_error naming the file when it
/// cannot.
void WriteTumFile(const std::string& path, const std::vector<StampedPose>& poses, const std::string& comment);

}  // namespace iapsim::bridge
