#include "render/camera_messages.h"

#include <cstring>
#include <utility>

#include "bridge/eigen_msgs.h"

namespace iapsim::render {

std_msgs::Header EyeHeader(const CameraConfig& config, int eye, int64_t stamp_ns) {
  std_msgs::Header header;
  header.stamp = bridge::ToRosTime(stamp_ns);
  header.frame_id = config.OpticalFrameId(eye);
  return header;
}

sensor_msgs::CameraInfo CameraInfoMessage(const CameraConfig& config, int eye,
                                          const std_msgs::Header& header) {
  const CameraIntrinsics& k = config.camera.intrinsics;
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<uint32_t>(k.width);
  info.height = static_cast<uint32_t>(k.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);  // rendered through an ideal pinhole
  info.K = {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};  // the eyes are rectified already
  // the right eye sits +baseline along x_C of the left one: Tx = −fx·baseline (ROS's convention)
  const double tx = eye == 1 ? -k.fx * config.baseline_m : 0.0;
  info.P = {k.fx, 0.0, k.cx, tx, 0.0, k.fy, k.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

sensor_msgs::CompressedImage PngMessage(std::vector<std::uint8_t> png, const std_msgs::Header& header) {
  sensor_msgs::CompressedImage message;
  message.header = header;
  message.format = "rgb8; png compressed rgb8";  // compressed_image_transport's form
  message.data = std::move(png);
  return message;
}

namespace {

// An uncompressed image's fields but its pixels. Every platform iapsim builds on is little-endian.
sensor_msgs::Image ImageMessage(int width, int height, const char* encoding, std::size_t bytes_per_pixel,
                                const std_msgs::Header& header) {
  sensor_msgs::Image message;
  message.header = header;
  message.width = static_cast<uint32_t>(width);
  message.height = static_cast<uint32_t>(height);
  message.encoding = encoding;
  message.is_bigendian = 0;
  message.step = static_cast<uint32_t>(message.width * bytes_per_pixel);
  return message;
}

}  // namespace

sensor_msgs::Image RgbMessage(const Image& image, const std_msgs::Header& header) {
  sensor_msgs::Image message = ImageMessage(image.width, image.height, "rgb8", 3, header);
  message.data = image.rgb;
  return message;
}

sensor_msgs::Image DepthMessage(const DepthImage& depth, const std_msgs::Header& header) {
  sensor_msgs::Image message = ImageMessage(depth.width, depth.height, "32FC1", sizeof(float), header);
  message.data.resize(depth.depth_m.size() * sizeof(float));
  std::memcpy(message.data.data(), depth.depth_m.data(), message.data.size());
  return message;
}

}  // namespace iapsim::render
