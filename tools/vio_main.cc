// iapsim_vio_offline: `iapsim vio` (tools/vio_offline.h), which `iapsim vio ...` execs.
//   iapsim vio RUN_DIR|BAG [--mode vio|vio_uwb|virpo|all|anchors] [--scenario S] [--sub BODY]... [--config F]
//   [--set K=V]...
//              [--out DIR]

#include <malloc.h>

#include <CLI/CLI.hpp>

#include "bridge/cli_usage.h"
#include "tools/vio_offline.h"

int main(int argc, char** argv) {
  // Every frame allocates image-sized buffers (pyramids, corner maps) and frees them: glibc serves blocks
  // this large with mmap and returns them at free, so each frame faulted its pages in again (a fifth of the
  // run in the kernel, measured with perf). Kept on the heap, they are reused.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  iapsim::tools::VioOfflineArgs args;
  CLI::App app(
      "iapsim vio: visual-inertial odometry of every stereo sub-aircraft over a recorded run (seed VI-G)",
      "iapsim vio");
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  app.add_option("input", args.input, "a run directory (run.bag, scenario.resolved.yaml) or a bag")
      ->required()
      ->check(CLI::ExistingPath);
  app.add_option(
         "--mode", args.mode,
         "estimator: vio (the paper's VINS baseline), vio_uwb (plus ranges to the scenario's "
         "anchors) or virpo "
         "(plus the attitude estimate and the other sub-aircraft through the platform, eq. 22); all: the "
         "three and a table like the paper's Table VIII; anchors: VIO, then VIO+UWB with 1, 2, ... of the "
         "scenario's anchors and a table like Table VII")
      ->capture_default_str()
      ->check(CLI::IsMember({"vio", "vio_uwb", "virpo", "all", "anchors"}));
  app.add_option("--scenario", args.scenario, "with a bag: the scenario it was recorded from")
      ->check(CLI::ExistingFile);
  app.add_option("--sub", args.sub_aircraft, "a body to estimate, e.g. iap/sub1 (repeatable; default: all)");
  app.add_option("--config", args.config,
                 "the estimator's settings: tracker, estimator, uwb and virpo keys (vio/config.h)")
      ->check(CLI::ExistingFile);
  app.add_option("--set", args.overrides, "override a setting: KEY=VALUE, e.g. virpo.sigma_link_m=0.02");
  app.add_option("--out", args.out_dir,
                 "where the TUM files and vio.json go (default: beside the bag, vio_<mode>)");
  iapsim::bridge::HideEmptyDefaults(app);
  app.footer(
      "Examples:\n"
      "  iapsim run configs/scenarios/three_star_vio.yaml --out runs/vio\n"
      "  iapsim vio runs/vio --mode all\n"
      "  iapsim vio runs/vio --mode virpo --sub iap/sub1 --set virpo.sigma_link_m=0.02");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return iapsim::bridge::AnswerParseError(app, e);
  }
  return iapsim::tools::VioOffline(args);
}
