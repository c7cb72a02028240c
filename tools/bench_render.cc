// iapsim bench render: images per second at 640x480 on the CPU (OSMesa, llvmpipe) in a stated scene with the
// three-star IAP flying through it: one camera, and the seed's three stereo pairs (six images a frame,
// §VI-G); render only (draw + read back) and render + PNG encode (on a worker while the next image draws),
// through render::CameraSystem as the render process uses it; then the render process itself in a lockstep
// graph with physics, publishing every image of one camera, of the three pairs, and of the pairs recorded.
// The IAP moves every frame, so every frame redraws the sun's shadow map too, as a flight does.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <thread>

#include "bridge/config.h"
#include "bridge/launcher.h"
#include "model/vehicle.h"
#include "render/camera_rig.h"
#include "render/camera_system.h"
#include "render/scene_config.h"
#include "render/vehicle_visual.h"
#include "tools/media.h"

namespace iapsim::tools {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kSecondsPerFigure = 2.0;

// The seed's rig per sub-aircraft: 640x480, 90° horizontal field of view, 12 cm baseline, 19.8 cm ahead.
render::CameraConfig SubAircraftCamera(const std::string& body, double baseline_m) {
  bridge::YamlMap map(YAML::Load("cameras: [{name: cam, body: " + body +
                                 ", position_m: [0.198, 0, 0], width: 640, height: 480, hfov_deg: 90, "
                                 "rate_hz: 20, baseline_m: " +
                                 std::to_string(baseline_m) + "}]"),
                      "bench");
  return render::ReadCameras(map, "cameras").at(0);
}

struct Flight {
  const model::Vehicle* vehicle;
  // a 6 m circle at 2 m height, 1/20 s a frame: the view changes every frame
  Eigen::Isometry3d Platform(int frame) const {
    const double angle = 0.05 * frame * 0.5;
    return Eigen::Isometry3d(Eigen::Translation3d(6.0 * std::cos(angle), 6.0 * std::sin(angle), -2.0) *
                             Eigen::AngleAxisd(angle + M_PI / 2.0, Eigen::Vector3d::UnitZ()));
  }
  void Pose(int frame, render::CameraSystem* system) const {
    system->SetBodyPose(render::PlatformBody("iap"), Platform(frame));
    for (const model::SubAircraft& sub : vehicle->sub_aircraft) {
      system->SetBodyPose(render::SubAircraftBody("iap", sub),
                          Platform(frame) * Eigen::Translation3d(sub.joint_P_m) *
                              Eigen::AngleAxisd(sub.initial_yaw_rad, Eigen::Vector3d::UnitZ()));
    }
  }
};

struct Figure {
  double frames_per_s = 0.0;
  double images_per_s = 0.0;
  double frame_ms_p50 = 0.0;  // latency of a whole frame (every camera), state to last image
  double frame_ms_p95 = 0.0;
  double png_kib = 0.0;  // mean PNG size
};

Figure Measure(const Flight& flight, render::CameraSystem* system) {
  std::vector<int> cameras(system->cameras().size());
  std::iota(cameras.begin(), cameras.end(), 0);
  std::vector<render::EyeFrame> frames;
  std::vector<double> frame_ms;
  double png_bytes = 0.0;
  int images = 0;
  const Clock::time_point start = Clock::now();
  int frame = 0;
  while (std::chrono::duration<double>(Clock::now() - start).count() < kSecondsPerFigure) {
    const Clock::time_point frame_start = Clock::now();
    flight.Pose(frame, system);
    system->Render(cameras, &frames);
    for (const render::EyeFrame& eye : frames) png_bytes += static_cast<double>(eye.png.size());
    images += static_cast<int>(frames.size());
    frame_ms.push_back(1e3 * std::chrono::duration<double>(Clock::now() - frame_start).count());
    ++frame;
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  std::sort(frame_ms.begin(), frame_ms.end());
  Figure figure;
  figure.frames_per_s = frame / seconds;
  figure.images_per_s = images / seconds;
  figure.frame_ms_p50 = frame_ms[frame_ms.size() / 2];
  figure.frame_ms_p95 = frame_ms[std::min(frame_ms.size() - 1, frame_ms.size() * 95 / 100)];
  figure.png_kib = png_bytes / images / 1024.0;
  return figure;
}

// The whole path of a flight: iapsim_render in a lockstep graph with physics, drawing, encoding and
// publishing every frame before physics may step on (and, with `record`, the recorder writing every image).
// `stereo`: a stereo pair on every sub-aircraft, else one camera on the first.
Figure MeasureProcess(const std::string& scene_path, const std::string& vehicle_path,
                      const model::Vehicle& model, bool stereo, bool record) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("iapsim-bench-render-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string vehicle = std::filesystem::absolute(vehicle_path).string();
  std::string cameras;
  for (const model::SubAircraft& sub : model.sub_aircraft) {
    cameras += "        - {name: cam, body: " + render::SubAircraftBody("iap", sub) +
               ", position_m: [0.198, 0, 0], width: 640, height: 480, hfov_deg: 90, baseline_m: " +
               (stereo ? "0.12" : "0") + ", rate_hz: 20}\n";
    if (!stereo) break;
  }
  std::ofstream(dir / "bench.yaml") << "name: bench_render\nmode: lockstep\nduration_s: "
                                    << kSecondsPerFigure * 2
                                    << "\nrecording: {enabled: " << (record ? "true" : "false") << "}\n"
                                    << "processes:\n"
                                       "  physics:\n    exec: iapsim_physics\n    role: clock\n    params:\n"
                                       "      vehicles:\n        - {name: iap, file: "
                                    << vehicle << ", position_m: [0, 0, -2], rotors: hover}\n"
                                    << "  render:\n    exec: iapsim_render\n    role: participant\n"
                                       "    rate_hz: 20\n    params:\n      scene: "
                                    << std::filesystem::absolute(scene_path).string()
                                    << "\n      vehicles: [{name: iap, file: " << vehicle
                                    << "}]\n      cameras:\n"
                                    << cameras;
  bridge::LaunchOptions options;
  options.scenario_path = (dir / "bench.yaml").string();
  options.out_dir = (dir / "run").string();
  options.bin_dir = bridge::ExecutableDir();
  const bridge::LaunchResult result = bridge::Launch(options);
  Figure figure;
  if (result.exit_code == 0) {
    const nlohmann::json report = nlohmann::json::parse(
        std::ifstream(result.run_dir + "/metrics.json"))["processes"]["render"]["process"];
    figure.frames_per_s = report["frames_per_s"].get<double>();
    figure.images_per_s = report["images_per_s"].get<double>();
    figure.frame_ms_p50 = report["latency_ms"]["p50"].get<double>();
    figure.frame_ms_p95 = report["latency_ms"]["p95"].get<double>();
    figure.png_kib = report["png_kib_mean"].get<double>();
  } else {
    std::fprintf(stderr, "bench render: the render process run failed: %s\n", result.message.c_str());
  }
  std::filesystem::remove_all(dir);
  return figure;
}

nlohmann::json ToJson(const Figure& f) {
  return {{"frames_per_s", f.frames_per_s},
          {"images_per_s", f.images_per_s},
          {"frame_ms_p50", f.frame_ms_p50},
          {"frame_ms_p95", f.frame_ms_p95},
          {"png_kib", f.png_kib}};
}

void PrintFigure(const std::string& label, const Figure& f) {
  std::printf("  %-46s %10.1f %10.1f %12.1f %12.1f %9.0f\n", label.c_str(), f.frames_per_s, f.images_per_s,
              f.frame_ms_p50, f.frame_ms_p95, f.png_kib);
}

}  // namespace

int MeasureRendering(const std::string& scene_path, const std::string& vehicle_path, nlohmann::json* report) {
  render::Scene scene = render::LoadScene(scene_path);
  const model::Vehicle vehicle = model::LoadVehicle(vehicle_path);
  render::AddVehicle(&scene, vehicle, "iap");
  std::size_t triangles = 0;
  for (const render::SceneObject& object : scene.objects) {
    for (const render::MeshPart& part : scene.meshes[object.mesh].parts) triangles += part.indices.size() / 3;
  }
  const Flight flight{&vehicle};
  std::vector<render::CameraConfig> one{SubAircraftCamera("iap/sub1", 0.0)};
  std::vector<render::CameraConfig> stereo;
  for (const model::SubAircraft& sub : vehicle.sub_aircraft)
    stereo.push_back(SubAircraftCamera("iap/" + sub.name, 0.12));
  const char* threads = std::getenv("LP_NUM_THREADS");
  const std::string thread_text =
      threads ? threads : std::to_string(std::thread::hardware_concurrency()) + " (default)";

  nlohmann::json& out = (*report)["render"];
  bool header = false;
  const std::pair<const char*, const std::vector<render::CameraConfig>*> sets[] = {
      {"one_camera", &one}, {"three_stereo_pairs", &stereo}};
  for (const auto& [key, cameras] : sets) {
    for (const bool encode : {false, true}) {
      render::CameraSystemOptions options;
      options.encode_png = encode;
      render::CameraSystem system(scene, *cameras, options);
      if (!header) {
        std::printf("render at 640x480, %s\n", system.renderer().Description().c_str());
        std::printf("  scene %s (%s): %zu objects, %zu triangles with the IAP, shadows %s, fog %.3g /m\n",
                    scene.name.c_str(), scene_path.c_str(), scene.objects.size(), triangles,
                    scene.sun.shadows ? "on" : "off", scene.fog.density_per_m);
        std::printf("  vehicle %s flying a 6 m circle, llvmpipe threads %s, %.0f s per figure\n\n",
                    vehicle.name.c_str(), thread_text.c_str(), kSecondsPerFigure);
        std::printf("  %-46s %10s %10s %12s %12s %9s\n", "cameras", "frames/s", "images/s", "frame p50 ms",
                    "frame p95 ms", "PNG KiB");
        out["renderer"] = system.renderer().Description();
        header = true;
      }
      const Figure f = Measure(flight, &system);
      PrintFigure(std::string(key == std::string("one_camera") ? "1 camera" : "3 stereo pairs (6 images)") +
                      (encode ? ", render + PNG" : ", render only"),
                  f);
      out[key][encode ? "render_png" : "render_only"] = ToJson(f);
    }
  }
  const Figure one_published = MeasureProcess(scene_path, vehicle_path, vehicle, false, false);
  PrintFigure("1 camera, iapsim_render publishing", one_published);
  out["one_camera"]["process_published"] = ToJson(one_published);
  for (const bool record : {false, true}) {
    const Figure f = MeasureProcess(scene_path, vehicle_path, vehicle, true, record);
    PrintFigure(
        record ? "3 stereo pairs, iapsim_render + bag recorder" : "3 stereo pairs, iapsim_render publishing",
        f);
    out["three_stereo_pairs"][record ? "process_recorded" : "process_published"] = ToJson(f);
  }
  out["scene"] = scene_path;
  out["triangles"] = triangles;
  out["vehicle"] = vehicle.name;
  out["llvmpipe_threads"] = thread_text;
  out["width"] = 640;
  out["height"] = 480;
  const double six_hz = out["three_stereo_pairs"]["process_published"]["frames_per_s"].get<double>();
  std::printf(
      "\n  six images a frame rendered, encoded and published: %.1f Hz (target >= 10 Hz on the CPU): %s\n",
      six_hz, six_hz >= 10.0 ? "met" : "NOT met");
  return 0;
}

}  // namespace iapsim::tools
