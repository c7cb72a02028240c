#pragma once
// The parts of the `iapsim` program that need the renderer (OSMesa, with LLVM) and OpenCV's codecs: they run
// in their own executable, `iapsim_media` (media_main.cc), which `iapsim` starts for them
// (RunMedia). Loading those libraries cost every `iapsim` command 0.3 s before it did anything.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tools/video.h"

namespace iapsim::tools {

// In the library iapsim_tools_media (video_encoding.cc, bench_render.cc), linked by iapsim_media only:

/// What WriteCameraVideo does, in this process.
CameraVideo EncodeCameraVideo(const std::string& bag_path, const std::string& camera,
                              const std::string& video_path);

/// What BenchRender does (commands.h), in this process.
int MeasureRendering(const std::string& scene_path, const std::string& vehicle_path, nlohmann::json* report);

// In iapsim_tools (media.cc):

/// Runs `iapsim_media ARGS... RESULT_JSON` next to this executable, its output on ours, and returns the
/// JSON it wrote. Throws std::runtime_error with the reason it reported, or why it could not run.
nlohmann::json RunMedia(const std::vector<std::string>& args);

}  // namespace iapsim::tools
