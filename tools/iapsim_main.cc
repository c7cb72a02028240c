// iapsim: the one command-line program. Each subcommand lives in tools/commands.cc or tools/bench_*.cc.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "bridge/cli_usage.h"
#include "bridge/launcher.h"
#include "tools/commands.h"
#include "tools/sweep.h"

namespace {

// `iapsim rl ...` and `iapsim vio ...` become the iapsim_rl and iapsim_vio_offline programs beside this one
// (tools/rl_commands.h and tools/vio_offline.h say why), with the same arguments, output and exit code.
int ExecCompanion(const char* name, int argc, char** argv) {
  const std::string program = iapsim::bridge::ExecutableDir() + "/" + name;
  std::vector<char*> args = {const_cast<char*>(program.c_str())};
  for (int i = 2; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  // OpenBLAS (tools/install-deps.sh) starts a thread per core for every product, on top of the programs' own
  // threads (libtorch's and the environments', one estimator per sub-aircraft): one BLAS thread trains TD3-BC
  // 2.5x faster here
  ::setenv("OPENBLAS_NUM_THREADS", "1", /*overwrite=*/0);
  ::execv(program.c_str(), args.data());
  std::cerr << "iapsim: cannot start " << program << ": " << std::strerror(errno) << std::endl;
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace iapsim::tools;
  if (argc > 1 && std::string(argv[1]) == "rl") return ExecCompanion("iapsim_rl", argc, argv);
  if (argc > 1 && std::string(argv[1]) == "vio") return ExecCompanion("iapsim_vio_offline", argc, argv);
  CLI::App app("iapsim: a multi-process simulator for Integrated Aerial Platforms");
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("iapsim ") + IAPSIM_VERSION);
  app.option_defaults()->always_capture_default();  // every --help shows each option's default

  RunArgs run;
  auto* run_cmd = app.add_subcommand(
      "run", "run a scenario: start its process graph, supervise it, write a run directory");
  run_cmd->footer(
      "Examples:\n  iapsim run configs/regression/three_star_spiral.yaml\n  iapsim run "
      "configs/scenarios/bus_demo.yaml --mode realtime --duration 10 --out runs/demo\n  iapsim run "
      "configs/scenarios/three_star_stereo.yaml --set clock.step_s=0.002 --check");
  run_cmd->add_option("scenario", run.scenario, "scenario YAML")->required()->check(CLI::ExistingFile);
  run_cmd->add_option("--out", run.out_dir, "run directory (default runs/<name>-<UTC time>)");
  run_cmd->add_option("--mode", run.mode, "lockstep, fast or realtime")
      ->check(CLI::IsMember({"lockstep", "fast", "realtime"}));
  run_cmd->add_option("--duration", run.duration_s, "sim seconds");
  run_cmd->add_option("--seed", run.seed, "seed of every random stream");
  run_cmd->add_option("--set", run.overrides, "override a scenario key: KEY=VALUE (repeatable)");
  run_cmd->add_option("--video", run.video,
                      "after the run, an MP4 of this camera's recorded images (e.g. iap/platform/chase)");
  run_cmd->add_flag(
      "--check", run.check,
      "validate the scenario and every process's params (exit 0, or 2 with the file, line and key), "
      "run nothing");

  ReplayArgs replay;
  auto* replay_cmd = app.add_subcommand(
      "replay", "play a command log (topics of a bag, or a TUM / CSV pose file) into a run of a scenario");
  replay_cmd->footer(
      "Examples:\n  iapsim replay runs/latest/run.bag --scenario configs/scenarios/bus_demo.yaml --topics "
      "/iap/cmd");
  replay_cmd->add_option("log", replay.log, "bag, or TUM (.tum, .txt) / CSV (.csv) pose file")
      ->required()
      ->check(CLI::ExistingFile);
  replay_cmd->add_option("--format", replay.format, "pose file format (default: from the extension)")
      ->check(CLI::IsMember({"tum", "csv"}));
  replay_cmd->add_option("--topic", replay.topic, "pose file: the topic its poses play on, as PoseStamped");
  replay_cmd->add_flag("--as-pose", replay.as_pose,
                       "bag: play each message's first pose as a geometry_msgs/PoseStamped (e.g. another "
                       "vehicle's nav_msgs/Odometry)");
  replay_cmd->add_option("--pose-field", replay.pose_field,
                         "bag, with --as-pose: the pose's field path (e.g. bodies[0].pose_W)");
  replay_cmd->add_option("--scenario", replay.run.scenario, "scenario YAML")
      ->required()
      ->check(CLI::ExistingFile);
  replay_cmd->add_option("--topics", replay.topics, "topics to play (default: all)");
  replay_cmd->add_option("--map", replay.map, "rename a topic: FROM:=TO (repeatable)");
  replay_cmd->add_option("--out", replay.run.out_dir, "run directory");
  replay_cmd->add_option("--mode", replay.run.mode, "lockstep, fast or realtime")
      ->check(CLI::IsMember({"lockstep", "fast", "realtime"}));
  replay_cmd->add_option("--duration", replay.run.duration_s, "sim seconds");
  replay_cmd->add_option("--seed", replay.run.seed, "seed of every random stream");
  replay_cmd->add_option("--set", replay.run.overrides, "override a scenario key: KEY=VALUE (repeatable)");

  std::string evaluate_run;
  auto* evaluate_cmd = app.add_subcommand("evaluate", "recompute a run's tracking metrics and plots");
  evaluate_cmd->footer("Examples:\n  iapsim evaluate runs/latest");
  evaluate_cmd->add_option("run_dir", evaluate_run, "run directory")
      ->required()
      ->check(CLI::ExistingDirectory);

  RegressArgs regress;
  auto* regress_cmd = app.add_subcommand(
      "regress",
      "run the regression flights of a suite, compare with its thresholds, exit 1 on a regression");
  regress_cmd->footer(
      "Examples:\n  iapsim regress\n  iapsim regress --only three_star_spiral --fidelity realistic\n  iapsim "
      "regress --monte-carlo 10 --jobs 2 --out runs/mc");
  regress_cmd
      ->add_option("suite_dir", regress.suite_dir, "folder with suite.yaml (default configs/regression)")
      ->check(CLI::ExistingDirectory);
  regress_cmd->add_option("--out", regress.out_dir, "where the runs go (default runs/regress-<UTC time>)");
  regress_cmd->add_option("--only", regress.only, "run only these flights (repeatable)");
  regress_cmd->add_option("--set", regress.overrides,
                          "override a scenario key of every flight: KEY=VALUE (repeatable)");
  regress_cmd
      ->add_option("--monte-carlo", regress.monte_carlo,
                   "fly each flight N times (seeds 1..N) with the suite's monte_carlo keys; check "
                   "percentiles (default: "
                   "each flight once)")
      ->check(CLI::Range(1, 100000));
  regress_cmd
      ->add_option("--fidelity", regress.fidelity,
                   "the profile flown: ideal, realistic (or the one a flight's realistic.fidelity names) or "
                   "both (default both; Monte Carlo: realistic)")
      ->check(CLI::IsMember({"ideal", "realistic", "both"}));
  regress_cmd->add_flag("--keep-bags", regress.keep_bags,
                        "Monte Carlo: keep each draw's run.bag (by default deleted once evaluated)");
  regress_cmd
      ->add_option("--jobs,-j", regress.execution.jobs,
                   "flights (Monte Carlo: draws) at a time (default: the cores; with --slurm: as the cluster "
                   "allows)")
      ->check(CLI::Range(1, 1024));
  regress_cmd->add_flag(
      "--slurm", regress.execution.slurm,
      "Monte Carlo: fly the draws of each flight as one Slurm job array (as iapsim sweep --slurm)");

  std::string info_bag;
  auto* info_cmd = app.add_subcommand("info", "list a bag's topics, types, counts and rates");
  info_cmd->footer("Examples:\n  iapsim info runs/latest/run.bag");
  info_cmd->add_option("bag", info_bag, "bag file")->required()->check(CLI::ExistingFile);

  ReindexArgs reindex;
  auto* bag_cmd = app.add_subcommand("bag", "repair a bag");
  bag_cmd->require_subcommand(1);
  auto* reindex_cmd = bag_cmd->add_subcommand(
      "reindex",
      "write the index of a bag its writer did not close (a killed recorder's), from its whole chunks");
  reindex_cmd->footer("Examples:\n  iapsim bag reindex runs/latest/run.bag");
  reindex_cmd->add_option("bag", reindex.bag, "bag file")->required()->check(CLI::ExistingFile);
  reindex_cmd->add_option(
      "-o,--output", reindex.output,
      "write an indexed copy here (default: in place, the original kept as BAG.orig.bag)");
  reindex_cmd->add_flag("--lz4", reindex.lz4, "compress the chunks of what is written with lz4");

  VideoArgs video;
  auto* video_cmd = app.add_subcommand("video", "an MP4 and a contact sheet of a camera's images in a bag");
  video_cmd->footer("Examples:\n  iapsim video runs/latest/run.bag iap/platform/chase -o chase.mp4");
  video_cmd->add_option("bag", video.bag, "bag file")->required()->check(CLI::ExistingFile);
  video_cmd->add_option("camera", video.camera, "the eye, e.g. iap/sub1/stereo/left, or its image topic")
      ->required();
  video_cmd->add_option("-o,--output", video.output,
                        "MP4 file (default: next to the bag, named after the eye)");

  ExportArgs exp;
  auto* export_cmd = app.add_subcommand("export", "write one topic of a bag as CSV or as a TUM trajectory");
  export_cmd->footer(
      "Examples:\n  iapsim export runs/latest/run.bag --topic /iap/odometry --format tum -o odometry.tum");
  export_cmd->add_option("bag", exp.bag, "bag file")->required()->check(CLI::ExistingFile);
  export_cmd->add_option("--topic", exp.topic, "topic to export")->required();
  export_cmd->add_option("--format", exp.format, "csv or tum")->check(CLI::IsMember({"csv", "tum"}));
  export_cmd->add_option("--pose-field", exp.pose_field,
                         "tum: field holding the pose, e.g. bodies[0].pose_W (default: the first pose)");
  export_cmd->add_option("-o,--output", exp.output, "output file (default: standard output)");

  LiveArgs topics;
  auto* topics_cmd = app.add_subcommand("topics", "list the topics of a running graph");
  topics_cmd->footer("Examples:\n  iapsim topics\n  iapsim topics --run runs/demo --listen 2");
  topics_cmd->add_option("--run", topics.run_dir, "run directory of the running graph (default runs/latest)");
  topics_cmd->add_option("--listen", topics.listen_s, "seconds to listen");

  SweepArgs sweep;
  auto* sweep_cmd = app.add_subcommand(
      "sweep",
      "run a scenario over a grid or random draws of its keys and over seeds, N runs at a time, and "
      "tabulate their metrics (exit 1 if a run failed)");
  sweep_cmd->footer(
      "Examples:\n  iapsim sweep configs/sweeps/spiral_wind.yaml --jobs 2 --out sweeps/wind\n  iapsim sweep "
      "configs/sweeps/spiral_wind.yaml --out sweeps/wind --resume\n  iapsim sweep "
      "configs/sweeps/spiral_wind.yaml --slurm --partition batch --time 00:30:00");
  sweep_cmd->add_option("sweep", sweep.file, "sweep YAML (tools/sweep.h, README)")
      ->required()
      ->check(CLI::ExistingFile);
  sweep_cmd->add_option("--out", sweep.out_dir,
                        "where the runs and tables go (default sweeps/<name>-<UTC time>)");
  sweep_cmd->add_option("--jobs,-j", sweep.jobs, "runs at a time (default: the sweep's jobs, else the cores)")
      ->check(CLI::Range(1, 1024));
  sweep_cmd->add_flag("--resume", sweep.resume, "go on with the sweep in --out: skip its finished runs");
  sweep_cmd->add_flag("--list", sweep.list, "print the runs (ids and settings) and exit");
  sweep_cmd->add_option("--set", sweep.overrides,
                        "override a scenario key in every run: KEY=VALUE (repeatable)");
  sweep_cmd->add_flag("--slurm", sweep.slurm,
                      "submit the runs as one Slurm job array (sbatch) and wait for it, instead of the local "
                      "pool; --out must be on a file system the nodes share");
  sweep_cmd->add_option("--partition", sweep.partition, "with --slurm: the partition (default: the sweep's)");
  sweep_cmd->add_option("--time", sweep.time,
                        "with --slurm: a run's time limit, as sbatch takes it (01:00:00)");
  sweep_cmd->add_option("--cpus-per-run", sweep.cpus_per_run, "with --slurm: CPUs of each run (default 1)")
      ->check(CLI::Range(1, 1024));
  std::string sweep_task_dir, sweep_task_id;
  // what each task of a --slurm array runs (tools/sweep.h); not for users, so not listed
  auto* sweep_task_cmd =
      app.add_subcommand("sweep-task", "one run of a sweep, as a Slurm task runs it")->group("");
  sweep_task_cmd->add_option("dir", sweep_task_dir, "the sweep's folder")->required();
  sweep_task_cmd->add_option("id", sweep_task_id, "the run's id")->required();

  LiveArgs echo;
  auto* echo_cmd = app.add_subcommand("echo", "print the messages of a topic of a running graph as YAML");
  echo_cmd->footer("Examples:\n  iapsim echo /iap/odometry -n 1\n  iapsim echo /iap/state --run runs/demo");
  echo_cmd->add_option("topic", echo.topic, "topic")->required();
  echo_cmd->add_option("--run", echo.run_dir, "run directory of the running graph (default runs/latest)");
  echo_cmd->add_option("-n,--count", echo.count, "stop after this many messages (default: until Ctrl-C)");

  std::string urdf_vehicle, urdf_output;
  bool urdf_ros = false;
  auto* urdf_cmd =
      app.add_subcommand("urdf", "write the URDF of a vehicle description (configs/vehicles/*.yaml)");
  urdf_cmd->footer(
      "Examples:\n  iapsim urdf configs/vehicles/three_star.yaml -o three_star.urdf\n"
      "  iapsim urdf configs/vehicles/three_star.yaml --ros -o three_star_ros.urdf && check_urdf "
      "three_star_ros.urdf");
  urdf_cmd->add_option("vehicle", urdf_vehicle, "vehicle YAML")->required()->check(CLI::ExistingFile);
  urdf_cmd->add_option("-o,--output", urdf_output, "output file (default: standard output)");
  urdf_cmd->add_flag(
      "--ros", urdf_ros,
      "for ROS tools (check_urdf, robot_state_publisher, rviz): spherical joints as roll, pitch and "
      "yaw joints, visuals for every part; not for simulation");

  BenchArgs bench;
  auto* bench_cmd = app.add_subcommand("bench", "measure performance and print a table (and JSON)");
  bench_cmd->footer("Examples:\n  iapsim bench physics\n  iapsim bench all --json bench.json");
  bench_cmd
      ->add_option("what", bench.what,
                   "bus, physics, render, record, launch, fidelity, rl, sweep, ros or all")
      ->check(CLI::IsMember(
          {"bus", "physics", "render", "record", "launch", "fidelity", "rl", "sweep", "ros", "all"}));
  bench_cmd->add_option("--vehicle", bench.vehicle,
                        "physics, render, fidelity: the vehicle to measure (default the three-star)");
  bench_cmd->add_option("--scene", bench.scene, "render: the scene (default configs/scenes/buildings.yaml)");
  bench_cmd
      ->add_option("--scenario", bench.scenario,
                   "record, launch, sweep: the scenario run; physics: the scenario whose ideal and realistic "
                   "profiles are compared (default configs/regression/three_star_spiral.yaml)")
      ->check(CLI::ExistingFile);
  bench_cmd->add_option("--repeat", bench.repeats, "record, launch: runs of each variant (default 3)")
      ->check(CLI::Range(1, 100));
  bench_cmd->add_option("--task", bench.task, "rl: the docking task (default configs/rl/docking.yaml)")
      ->check(CLI::ExistingFile);
  bench_cmd->add_option("--json", bench.json, "also write the figures to this JSON file");

  // listed for --help; `iapsim rl ...` and `iapsim vio ...` never get here (ExecCompanion)
  app.add_subcommand(
      "rl", "the air-docking learning task (seed section VI-H): eval, collect; see iapsim rl --help");
  app.add_subcommand(
      "vio", "visual-inertial odometry over a recorded run (seed section VI-G); see iapsim vio --help");

  iapsim::bridge::HideEmptyDefaults(app);
  // after the subcommands, which would otherwise take it as theirs
  app.footer("Examples:\n  iapsim run configs/regression/three_star_spiral.yaml\n  iapsim COMMAND --help");
  if (argc > 1 && argv[1][0] != '-' && iapsim::bridge::AnswerUnknownSubcommand(app, "iapsim", argv[1]))
    return 2;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return iapsim::bridge::AnswerParseError(app, e);
  }
  try {
    if (*run_cmd) return Run(run);
    if (*replay_cmd) return Replay(replay);
    if (*evaluate_cmd) return Evaluate(evaluate_run);
    if (*regress_cmd) return Regress(regress);
    if (*sweep_cmd) return Sweep(sweep);
    if (*sweep_task_cmd) return SweepTask(sweep_task_dir, sweep_task_id);
    if (*info_cmd) return Info(info_bag);
    if (*reindex_cmd) return Reindex(reindex);
    if (*export_cmd) return Export(exp);
    if (*video_cmd) return Video(video);
    if (*topics_cmd) return Topics(topics);
    if (*echo_cmd) return Echo(echo);
    if (*urdf_cmd) return Urdf(urdf_vehicle, urdf_output, urdf_ros);
    if (*bench_cmd) return Bench(bench);
  } catch (const std::exception& e) {
    std::cerr << "iapsim: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
