// iapsim_media: the commands of `iapsim` that need the renderer and OpenCV (tools/media.h says why they run
// here), started by `iapsim` itself:
//   iapsim_media video BAG CAMERA VIDEO_PATH RESULT_JSON
//   iapsim_media bench-render SCENE VEHICLE RESULT_JSON
// Tables go to stdout; RESULT_JSON gets the result, or {"error": why}.
#include <cstdio>
#include <exception>
#include <fstream>
#include <string>

#include "tools/media.h"

int main(int argc, char** argv) {
  using namespace iapsim::tools;
  const std::string command = argc > 1 ? argv[1] : "";
  if (!((command == "video" && argc == 6) || (command == "bench-render" && argc == 5))) {
    std::fprintf(stderr,
                 "usage: iapsim_media video BAG CAMERA VIDEO_PATH RESULT_JSON\n"
                 "       iapsim_media bench-render SCENE VEHICLE RESULT_JSON\n"
                 "(started by `iapsim video`, `iapsim run --video` and `iapsim bench render`)\n");
    return 2;
  }
  const std::string result_path = argv[argc - 1];
  nlohmann::json result;
  int status = 0;
  try {
    if (command == "video") {
      result = ToJson(EncodeCameraVideo(argv[2], argv[3], argv[4]));
    } else {
      result["status"] = MeasureRendering(argv[2], argv[3], &result);
    }
  } catch (const std::exception& e) {
    result = {{"error", e.what()}};
    status = 1;
  }
  std::ofstream out(result_path);
  if (!(out << result.dump() << "\n")) {
    std::fprintf(stderr, "iapsim_media: cannot write %s\n", result_path.c_str());
    return 1;
  }
  return status;
}
