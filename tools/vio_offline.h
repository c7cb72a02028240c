#pragma once
// `iapsim vio RUN_DIR|BAG --mode vio`: the visual-inertial estimator of vio/ over a recorded data set, one
// estimator per sub-aircraft with a stereo camera, all on the same recorded images and IMU, so that modes
// can be compared on the same data (seed §VI-G). Cameras, IMU mounts and noise come from the scenario the
// bag was recorded with (the run's scenario.resolved.yaml). Each sub-aircraft's estimate starts from its
// first ground-truth state (the paper ties each estimate frame to the first ground-truth frame). Writes TUM
// trajectories of estimate and truth per sub-aircraft and vio.json (ATE as it is and after a rigid
// alignment, per-stage timing), and prints a table. Runs in iapsim_vio_offline: Ceres, OpenCV and the
// renderer's libraries stay out of the `iapsim` program.

#include <string>
#include <vector>

namespace iapsim::tools {

struct VioOfflineArgs {
  std::string input;     ///< a run directory (run.bag, scenario.resolved.yaml) or a bag
  std::string scenario;  ///< with a bag: its scenario (default: scenario.resolved.yaml beside the bag)
  /// vio, vio_uwb, virpo; all (the three, and a table like Table VIII); anchors (VIO, then VIO+UWB with 1,
  /// 2, ... of the scenario's anchors, and a table like Table VII); all and anchors in one pass over the bag
  std::string mode = "vio";
  std::vector<std::string> sub_aircraft;  ///< bodies to estimate ("iap/sub1"); default: every stereo camera's
  std::string out_dir;                    ///< default: <input's folder>/vio_<mode>
  std::string config;                     ///< the estimator's settings (vio/config.h); empty: defaults
  std::vector<std::string> overrides;     ///< "virpo.sigma_attitude_rad=0.04" on top of them
};

/// 0 on success, 2 for a bad configuration or data set (the message names the file, topic or key), 1 when
/// the estimation itself fails.
int VioOffline(const VioOfflineArgs& args);

}  // namespace iapsim::tools
