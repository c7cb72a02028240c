#pragma once
// Videos and contact sheets of rendered images, for a person to watch a flight. The MP4 goes through
// OpenCV's VideoWriter on FFmpeg: H.264 where the FFmpeg build has an encoder for it, else MPEG-4 part 2,
// both in an MP4 container that common players open.

#include <memory>
#include <string>
#include <vector>

#include "render/image.h"

namespace iapsim::render {

class VideoWriter {
 public:
  /// Opens `path` for frames of width x height at `frames_per_s`. Throws std::runtime_error naming the file
  /// when no MP4 encoder opens it.
  VideoWriter(const std::string& path, double frames_per_s, int width, int height);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// Appends a frame; throws std::invalid_argument when its size is not the video's.
  void Add(const Image& frame);
  /// Finishes the file (also done by the destructor).
  void Close();
  /// "H.264" or "MPEG-4".
  const std::string& codec() const { return codec_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string path_;
  std::string codec_;
};

/// The images side by side in rows of `columns`, each scaled by `scale` with its label written in its
/// top-left corner. Every image must have the size of the first.
Image ContactSheet(const std::vector<Image>& images, const std::vector<std::string>& labels, int columns,
                   double scale);

}  // namespace iapsim::render
