#pragma once
// The sensor_msgs of a rendered eye, as image_transport and image_geometry expect them: PNG in
// CompressedImage, rgb8 and 32FC1 (metres along z_C, REP 118) in Image, and CameraInfo with the pinhole of
// camera.h (no distortion) and, for a stereo pair's right eye, P's Tx = −fx·baseline.

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Header.h>

#include <cstdint>
#include <vector>

#include "render/camera_rig.h"
#include "render/image.h"

namespace iapsim::render {

/// The header of an eye's messages: the physics stamp of the state drawn, the eye's optical frame.
std_msgs::Header EyeHeader(const CameraConfig& config, int eye, int64_t stamp_ns);

sensor_msgs::CameraInfo CameraInfoMessage(const CameraConfig& config, int eye,
                                          const std_msgs::Header& header);
/// Takes the PNG bytes (a frame's encoded image moves into the message, no copy).
sensor_msgs::CompressedImage PngMessage(std::vector<std::uint8_t> png, const std_msgs::Header& header);
sensor_msgs::Image RgbMessage(const Image& image, const std_msgs::Header& header);
sensor_msgs::Image DepthMessage(const DepthImage& depth, const std_msgs::Header& header);

}  // namespace iapsim::render
