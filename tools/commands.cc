#include "tools/commands.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "bridge/bag.h"
#include "bridge/bus.h"
#include "bridge/launcher.h"
#include "bridge/message_format.h"
#include "bridge/message_registry.h"
#include "bridge/process.h"
#include "bridge/run_secret.h"
#include "bridge/scenario.h"
#include "model/urdf.h"
#include "model/vehicle.h"
#include "tools/run_evaluation.h"
#include "tools/video.h"

namespace iapsim::tools {
namespace {

using namespace iapsim::bridge;

std::atomic<bool> interrupted{false};
extern "C" void OnInterrupt(int) { interrupted = true; }

std::vector<std::string> Overrides(const RunArgs& args) {
  std::vector<std::string> overrides;
  if (!args.mode.empty()) overrides.push_back("mode=" + args.mode);
  if (args.duration_s) overrides.push_back("duration_s=" + std::to_string(*args.duration_s));
  if (args.seed) overrides.push_back("seed=" + std::to_string(*args.seed));
  overrides.insert(overrides.end(), args.overrides.begin(), args.overrides.end());
  return overrides;
}

std::string YamlFlowList(const std::vector<std::string>& items) {
  YAML::Node list(YAML::NodeType::Sequence);
  for (const auto& item : items) list.push_back(item);
  YAML::Emitter out;
  out << YAML::Flow << list;
  return out.c_str();
}

int Launch(const RunArgs& args, std::vector<std::string> overrides) {
  // the evaluation section is checked before the run, so a typo does not cost a flight
  RunEvaluation evaluation;
  bool recorded = true;
  try {
    const Scenario scenario = LoadScenario(args.scenario, overrides);
    evaluation = ReadRunEvaluation(scenario);
    recorded = scenario.recording.enabled;
  } catch (const ConfigError& e) {
    std::cerr << "iapsim: invalid configuration: " << e.what() << std::endl;
    return 2;
  }
  if (!recorded && !args.video.empty()) {
    std::cerr << "iapsim: --video " << args.video
              << ": the video is made from the bag, and recording.enabled is false" << std::endl;
    return 2;
  }
  LaunchOptions options;
  options.scenario_path = args.scenario;
  options.overrides = std::move(overrides);
  options.out_dir = args.out_dir;
  options.bin_dir = ExecutableDir();
  options.progress = true;
  options.check_only = args.check;
  const LaunchResult result = bridge::Launch(options);
  if (result.exit_code == 2) {
    std::cerr << "iapsim: invalid configuration: " << result.message << std::endl;
    return 2;
  }
  if (args.check && result.exit_code == 0) {
    std::printf("%s: valid (the scenario and the params of every process)\n", args.scenario.c_str());
    return 0;
  }
  // 3: the run completed with losses; its outputs are complete and summarised, and the exit code says so
  if (result.exit_code != 0 && result.exit_code != 3) {
    std::cerr << "iapsim: run failed: " << result.message << std::endl;
    if (!result.run_dir.empty()) std::cerr << "iapsim: partial outputs in " << result.run_dir << std::endl;
    return result.exit_code;
  }
  // a short summary of what the run produced
  std::ifstream metrics_file(result.run_dir + "/metrics.json");
  const auto metrics = nlohmann::json::parse(metrics_file, nullptr, false);
  std::printf("run complete: %s\n", result.run_dir.c_str());
  if (metrics.is_object() && metrics.contains("sim_time_s")) {
    std::printf("  sim time %.3f s in %.2f s wall (x%.2f real time), mode %s\n",
                metrics["sim_time_s"].get<double>(), metrics["wall_time_s"].get<double>(),
                metrics["real_time_factor"].get<double>(), metrics["mode"].get<std::string>().c_str());
  }
  std::printf("  %s/scenario.resolved.yaml   configuration as used\n", result.run_dir.c_str());
  std::printf("  %s/metrics.json             figures of the run\n", result.run_dir.c_str());
  if (metrics.is_object() && metrics["processes"].contains("recorder")) {
    const auto& recorder = metrics["processes"]["recorder"]["process"];
    const std::string compression = recorder["compression"].get<std::string>();
    char ratio[128] = "";
    if (compression != "none") {
      std::snprintf(ratio, sizeof(ratio), ", %s %.2fx smaller", compression.c_str(),
                    recorder["compression_ratio"].get<double>());
    }
    unsigned long long thinned = 0;
    const nlohmann::json thinned_by_topic = recorder.value("thinned", nlohmann::json::object());
    for (const auto& [topic, n] : thinned_by_topic.items()) {
      thinned += n.get<unsigned long long>();
    }
    if (thinned > 0) {
      std::snprintf(ratio + std::strlen(ratio), sizeof(ratio) - std::strlen(ratio),
                    ", %llu thinned by max_rate_hz", thinned);
    }
    std::printf("  %s/run.bag                  %llu messages on %zu topics, %.1f MiB%s (iapsim info)\n",
                result.run_dir.c_str(), recorder["messages"].get<unsigned long long>(),
                recorder["recorded"].size(), recorder["bag_bytes"].get<double>() / (1 << 20), ratio);
  }
  std::printf("  %s/log.txt, logs/           launcher and per-process logs\n", result.run_dir.c_str());
  // the evaluation reads the bag: an unrecorded run (a timing run, say) has only the launcher's figures
  if (recorded) {
    EvaluateRun(result.run_dir, evaluation);
  } else if (!evaluation.empty()) {
    std::printf(
        "  (the scenario's evaluation is skipped: it reads the bag, and recording.enabled is false)\n");
  }
  if (!args.video.empty()) {
    try {
      PrintCameraVideo(WriteCameraVideo(result.run_dir + "/run.bag", args.video,
                                        DefaultVideoPath(result.run_dir + "/run.bag", args.video)));
    } catch (const std::exception& e) {
      std::cerr << "iapsim: --video: " << e.what() << std::endl;
      return 1;
    }
  }
  if (result.exit_code == 3) std::cerr << "iapsim: the run completed, but " << result.message << std::endl;
  return result.exit_code;
}

// A bus node for command-line inspection of a running graph: it connects to every process, publishes nothing.
std::unique_ptr<Bus> InspectorBus(const std::string& run_dir) {
  const std::string resolved = run_dir + "/scenario.resolved.yaml";
  if (access(resolved.c_str(), R_OK) != 0) {
    throw std::runtime_error("no run in '" + run_dir + "' (" + resolved + " not found); pass --run DIR");
  }
  const Scenario scenario = LoadScenario(resolved);
  // RUN/secret: readable by the user who started the run
  return std::make_unique<Bus>(
      ObserverBusOptions(scenario, "iapsim-cli-" + std::to_string(getpid()), ReadRunSecret(run_dir)));
}

// Why no graph runs in `run_dir` any more (its metrics.json is written: it ended; its launcher is gone: it
// was killed), or empty while it may still run.
std::string RunGone(const std::string& run_dir) {
  if (access((run_dir + "/metrics.json").c_str(), F_OK) == 0) return "the run in " + run_dir + " has ended";
  std::ifstream in(run_dir + "/launcher.pid");
  pid_t pid = 0;
  if (in >> pid && pid > 0 && kill(pid, 0) != 0 && errno == ESRCH) {
    return "nothing runs in " + run_dir + " (its launcher, pid " + std::to_string(pid) + ", is gone)";
  }
  return "";
}

double Seconds(int64_t ns) { return static_cast<double>(ns) * 1e-9; }

}  // namespace

int Run(const RunArgs& args) { return Launch(args, Overrides(args)); }

namespace {
int ReplayUsage(const std::string& what) {
  std::cerr << "iapsim replay: " << what << std::endl;
  return 2;
}
}  // namespace

int Replay(const ReplayArgs& args) {
  auto overrides = Overrides(args.run);
  overrides.push_back("processes.replayer.exec=iapsim_replayer");
  overrides.push_back("processes.replayer.role=participant");
  const std::string extension = std::filesystem::path(args.log).extension().string();
  const std::string format = !args.format.empty()                         ? args.format
                             : extension == ".tum" || extension == ".txt" ? "tum"
                             : extension == ".csv"                        ? "csv"
                                                                          : "";
  // the replayer checks the rest (a topic for a file, topics and renames within the bag)
  if (format.empty()) {
    if (!args.topic.empty())
      return ReplayUsage("--topic is for a pose file (--format tum or csv); a bag keeps its topics");
    overrides.push_back("processes.replayer.params.bag=" + args.log);
    overrides.push_back("processes.replayer.params.topics=" + YamlFlowList(args.topics));
    overrides.push_back("processes.replayer.params.map=" + YamlFlowList(args.map));
    overrides.push_back(std::string("processes.replayer.params.as_pose=") +
                        (args.as_pose ? "true" : "false"));
    if (!args.pose_field.empty())
      overrides.push_back("processes.replayer.params.pose_field=" + args.pose_field);
  } else {
    if (!args.topics.empty() || !args.map.empty() || args.as_pose || !args.pose_field.empty()) {
      return ReplayUsage("--topics, --map, --as-pose and --pose-field are for a bag; a " + format +
                         " pose file plays on --topic");
    }
    if (args.topic.empty())
      return ReplayUsage("a " + format + " pose file needs --topic (where its poses go)");
    overrides.push_back("processes.replayer.params.file=" + std::filesystem::absolute(args.log).string());
    overrides.push_back("processes.replayer.params.format=" + format);
    overrides.push_back("processes.replayer.params.topic=" + args.topic);
  }
  return Launch(args.run, overrides);
}

int Evaluate(const std::string& run_dir) {
  const Scenario scenario = LoadScenario(run_dir + "/scenario.resolved.yaml");
  const RunEvaluation evaluation = ReadRunEvaluation(scenario);
  if (evaluation.empty()) {
    std::cerr << "iapsim: " << scenario.file
              << ": no evaluation section (tracking, contact, videos): nothing to evaluate" << std::endl;
    return 2;
  }
  if (!scenario.recording.enabled) {
    std::cerr << "iapsim: " << run_dir << ": the run was not recorded (recording.enabled is false), and the "
              << "evaluation reads its bag" << std::endl;
    return 2;
  }
  EvaluateRun(run_dir, evaluation);
  return 0;
}

int Video(const VideoArgs& args) {
  const CameraVideo video = WriteCameraVideo(
      args.bag, args.camera, args.output.empty() ? DefaultVideoPath(args.bag, args.camera) : args.output);
  PrintCameraVideo(video);
  return 0;
}

int Info(const std::string& bag_path) {
  BagReader bag(bag_path);
  const auto topics = bag.Topics();
  uint64_t total = 0;
  for (const auto& t : topics) total += t.count;
  std::printf("bag:       %s\n", bag_path.c_str());
  std::printf("duration:  %.3f s (%.9f to %.9f)\n", Seconds(bag.end_time_ns() - bag.start_time_ns()),
              Seconds(bag.start_time_ns()), Seconds(bag.end_time_ns()));
  std::printf("messages:  %llu on %zu topics\n", static_cast<unsigned long long>(total), topics.size());
  if (!bag.note().empty()) {
    std::printf("note:      %s; `iapsim bag reindex %s` writes its index\n", bag.note().c_str(),
                bag_path.c_str());
  }
  std::printf("\n");
  size_t topic_width = 5, type_width = 4;
  for (const auto& t : topics) {
    topic_width = std::max(topic_width, t.topic.size());
    type_width = std::max(type_width, t.datatype.size());
  }
  std::printf("%-*s  %-*s  %10s  %10s\n", static_cast<int>(topic_width), "topic",
              static_cast<int>(type_width), "type", "count", "rate_hz");
  for (const auto& t : topics) {
    const double span_s = Seconds(t.last_time_ns - t.first_time_ns);
    const double rate = t.count > 1 && span_s > 0 ? static_cast<double>(t.count - 1) / span_s : 0.0;
    std::printf("%-*s  %-*s  %10llu  %10.2f\n", static_cast<int>(topic_width), t.topic.c_str(),
                static_cast<int>(type_width), t.datatype.c_str(), static_cast<unsigned long long>(t.count),
                rate);
  }
  return 0;
}

int Reindex(const ReindexArgs& args) {
  const BagReader bag(args.bag);
  if (bag.note().empty() && args.output.empty()) {
    std::printf("%s is indexed; nothing to do\n", args.bag.c_str());
    return 0;
  }
  if (!bag.note().empty()) std::printf("%s: %s\n", args.bag.c_str(), bag.note().c_str());
  std::error_code error;
  if (!args.output.empty() && std::filesystem::equivalent(args.bag, args.output, error)) {
    throw std::runtime_error("--output " + args.output +
                             " is the bag itself (leave --output out to reindex in place)");
  }
  const std::string written = args.output.empty() ? args.bag + ".reindex.tmp" : args.output;
  BagWriterOptions options;
  options.compression = args.lz4 ? BagCompression::kLz4 : BagCompression::kNone;
  const uint64_t messages = ReindexBag(args.bag, written, options);
  if (args.output.empty()) {
    std::filesystem::path backup(args.bag);
    if (backup.extension() == ".bag") {
      backup.replace_extension(".orig.bag");
    } else {
      backup += ".orig";
    }
    std::filesystem::rename(args.bag, backup);
    std::filesystem::rename(written, args.bag);
    std::printf("%s: %llu messages, indexed (the original is %s)\n", args.bag.c_str(),
                static_cast<unsigned long long>(messages), backup.string().c_str());
  } else {
    std::printf("%s: %llu messages, indexed\n", written.c_str(), static_cast<unsigned long long>(messages));
  }
  return 0;
}

int Export(const ExportArgs& args) {
  BagReader bag(args.bag);
  if (!bag.note().empty())
    std::fprintf(stderr, "iapsim export: %s: %s\n", args.bag.c_str(), bag.note().c_str());
  const BagTopicInfo* topic = nullptr;
  const auto topics = bag.Topics();
  for (const auto& t : topics) {
    if (t.topic == args.topic) topic = &t;
  }
  if (!topic) throw std::runtime_error(args.bag + ": no topic '" + args.topic + "' (see iapsim info)");
  const auto schema = SchemaSet::Parse(topic->datatype, topic->definition);

  std::ofstream file;
  if (!args.output.empty()) {
    file.open(args.output);
    if (!file) throw std::runtime_error("cannot write '" + args.output + "'");
  }
  std::ostream& out = args.output.empty() ? std::cout : file;
  CsvWriter csv(out);
  uint64_t written = 0;
  bag.ForEach({args.topic}, [&](const BagMessage& m) {
    if (args.format == "csv") {
      csv.Write(m.record_time_ns, Flatten(*schema, m.bytes.data(), m.bytes.size()));
    } else {
      const auto pose =
          ExtractPose(*schema, m.bytes.data(), m.bytes.size(), m.record_time_ns, args.pose_field);
      if (!pose)
        throw std::runtime_error("topic '" + args.topic + "' (" + topic->datatype + ") holds no pose");
      out << FormatTum(*pose) << "\n";
    }
    ++written;
    return true;
  });
  if (!args.output.empty()) {
    std::fprintf(stderr, "wrote %llu rows of %s to %s\n", static_cast<unsigned long long>(written),
                 args.topic.c_str(), args.output.c_str());
  }
  return 0;
}

int Topics(const LiveArgs& args) {
  auto bus = InspectorBus(args.run_dir);
  if (const std::string gone = RunGone(args.run_dir); !gone.empty()) {
    std::fprintf(stderr, "iapsim topics: %s\n", gone.c_str());
    return 1;
  }
  struct Seen {
    std::string datatype;
    std::string publisher;
    uint64_t count = 0;
  };
  std::map<std::string, Seen> seen;
  bus->SubscribeRaw("", [&](const uint8_t*, size_t, const MessageInfo& info) {
    Seen& s = seen[info.topic];
    s.datatype = info.datatype;
    s.publisher = info.publisher;
    ++s.count;
  });
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(args.listen_s);
  while (std::chrono::steady_clock::now() < end) bus->Spin(std::chrono::milliseconds(20));
  if (seen.empty()) {
    std::printf("no messages within %.1f s: is the run in %s still going?\n", args.listen_s,
                args.run_dir.c_str());
    return 1;
  }
  std::printf("%-40s %-32s %-12s %10s\n", "topic", "type", "publisher", "rate_hz");
  for (const auto& [topic, s] : seen) {
    std::printf("%-40s %-32s %-12s %10.1f\n", topic.c_str(), s.datatype.c_str(), s.publisher.c_str(),
                static_cast<double>(s.count) / args.listen_s);
  }
  return 0;
}

int Echo(const LiveArgs& args) {
  auto bus = InspectorBus(args.run_dir);
  if (const std::string gone = RunGone(args.run_dir); !gone.empty()) {
    std::fprintf(stderr, "iapsim echo: %s\n", gone.c_str());
    return 1;
  }
  long printed = 0;
  bus->SubscribeRaw(args.topic, [&](const uint8_t* data, size_t size, const MessageInfo& info) {
    if (info.topic != args.topic || (args.count >= 0 && printed >= args.count)) return;
    const RegisteredType* type = FindType(info.datatype);
    if (!type) {
      std::printf("--- %s from %s: %zu bytes of unknown type %s\n", info.topic.c_str(),
                  info.publisher.c_str(), size, info.datatype.c_str());
    } else {
      std::printf("---\n%s", FormatYaml(*type->schema, data, size).c_str());
    }
    std::fflush(stdout);
    ++printed;
  });
  struct sigaction action {};
  action.sa_handler = OnInterrupt;
  sigaction(SIGINT, &action, nullptr);
  // the run may end (or be killed) while we listen: looked at twice a second
  auto next_look = std::chrono::steady_clock::now();
  while (!interrupted && (args.count < 0 || printed < args.count)) {
    bus->Spin(std::chrono::milliseconds(50));
    if (std::chrono::steady_clock::now() < next_look) continue;
    next_look += std::chrono::milliseconds(500);
    if (const std::string gone = RunGone(args.run_dir); !gone.empty()) {
      std::fprintf(stderr, "iapsim echo: %s%s\n", gone.c_str(), printed == 0 ? " before a message came" : "");
      return printed == 0 ? 1 : 0;
    }
  }
  return 0;
}

int Urdf(const std::string& vehicle_path, const std::string& output, bool ros) {
  model::Vehicle vehicle;
  try {
    vehicle = model::LoadVehicle(vehicle_path);
  } catch (const ConfigError& e) {
    std::cerr << "iapsim: invalid vehicle: " << e.what() << std::endl;
    return 2;
  }
  const std::string urdf = ros ? model::GenerateRosUrdf(vehicle) : model::GenerateUrdf(vehicle);
  if (output.empty()) {
    std::cout << urdf;
    return 0;
  }
  std::ofstream out(output);
  if (!(out << urdf)) throw std::runtime_error("cannot write '" + output + "'");
  std::fprintf(stderr, "wrote %s (%zu sub-aircraft, %.3f kg)\n", output.c_str(), vehicle.sub_aircraft.size(),
               vehicle.TotalMass_kg());
  return 0;
}

int Bench(const BenchArgs& args) {
  nlohmann::json report;
  int status = 0;
  const bool all = args.what == "all";
  if (args.what == "bus" || all) status |= BenchBus(&report);
  if (all) std::printf("\n");
  if (args.what == "physics" || all) status |= BenchPhysics(args.vehicle, args.scenario, &report);
  if (all) std::printf("\n");
  if (args.what == "render" || all) status |= BenchRender(args.scene, args.vehicle, &report);
  if (all) std::printf("\n");
  if (args.what == "record" || all) status |= BenchRecord(args.scenario, args.repeats, &report);
  if (all) std::printf("\n");
  if (args.what == "launch" || all) status |= BenchLaunch(args.scenario, args.repeats, &report);
  if (all) std::printf("\n");
  if (args.what == "fidelity" || all) status |= BenchFidelity(args.vehicle, &report);
  if (all) std::printf("\n");
  if (args.what == "rl" || all) status |= BenchRl(args.task, &report);
  if (all) std::printf("\n");
  if (args.what == "sweep" || all) status |= BenchSweep(args.scenario, &report);
  if (all) std::printf("\n");
  if (args.what == "ros" || all) status |= BenchRos(&report);
  if (!args.json.empty()) {
    std::ofstream(args.json) << report.dump(2) << "\n";
    std::printf("figures written to %s\n", args.json.c_str());
  }
  return status;
}

}  // namespace iapsim::tools
