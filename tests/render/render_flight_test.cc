// Issue 6 end to end: the render process in a three-star flight with a stereo pair on every sub-aircraft
// (seed §VI-G) and a chase camera. Every image carries the stamp of a physics state it drew (Fig. 10), with
// its CameraInfo; in lockstep every due frame is drawn and two runs give the same PNG bytes; in realtime the
// renderer skips frames it cannot draw in time but still stamps each image with the state it shows.
#include <gtest/gtest.h>
#include <iapsim_msgs/IapState.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "bridge/bag.h"
#include "bridge/eigen_msgs.h"
#include "bridge/launcher.h"
#include "bridge/message.h"
#include "render/image.h"

namespace iapsim::bridge {
namespace {

constexpr char kScenario[] = "/configs/scenarios/three_star_stereo.yaml";
const std::vector<std::string> kEyes = {
    "/iap/sub1/stereo/left", "/iap/sub1/stereo/right", "/iap/sub2/stereo/left", "/iap/sub2/stereo/right",
    "/iap/sub3/stereo/left", "/iap/sub3/stereo/right", "/iap/platform/chase"};

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

struct RecordedImages {
  std::set<int64_t> state_stamps_ns;
  std::map<std::string, std::vector<int64_t>> image_stamps_ns;  // per eye namespace
  std::map<std::string, std::vector<int64_t>> info_stamps_ns;
  std::map<std::string, std::vector<std::vector<uint8_t>>> png;
  nlohmann::json render_report;
  double render_sim_time_s = 0.0;  // the last tick the renderer saw
};

RecordedImages Fly(const std::string& name, const std::vector<std::string>& overrides) {
  LaunchOptions options;
  options.scenario_path = std::string(IAPSIM_SOURCE_DIR) + kScenario;
  options.overrides = overrides;
  options.out_dir = (std::filesystem::path(::testing::TempDir()) /
                     ("iapsim-render-" + name + "-" + std::to_string(getpid())))
                        .string();
  options.bin_dir = ExecutableDir();
  const LaunchResult result = Launch(options);
  EXPECT_EQ(result.exit_code, 0) << result.message;

  RecordedImages out;
  std::string error;
  BagReader(result.run_dir + "/run.bag").ForEach({}, [&](const BagMessage& m) {
    if (m.topic == "/iap/state") {
      iapsim_msgs::IapState state;
      EXPECT_TRUE(Decode(m.bytes, &state, &error)) << error;
      out.state_stamps_ns.insert(ToNanoseconds(state.header.stamp));
    } else if (EndsWith(m.topic, "/image_raw/compressed")) {
      sensor_msgs::CompressedImage image;
      EXPECT_TRUE(Decode(m.bytes, &image, &error)) << error;
      const std::string eye = m.topic.substr(0, m.topic.size() - std::string("/image_raw/compressed").size());
      EXPECT_EQ(image.header.frame_id, eye.substr(1) + "_optical");
      out.image_stamps_ns[eye].push_back(ToNanoseconds(image.header.stamp));
      out.png[eye].push_back(image.data);
    } else if (EndsWith(m.topic, "/camera_info")) {
      sensor_msgs::CameraInfo info;
      EXPECT_TRUE(Decode(m.bytes, &info, &error)) << error;
      out.info_stamps_ns[m.topic.substr(0, m.topic.size() - std::string("/camera_info").size())].push_back(
          ToNanoseconds(info.header.stamp));
    }
    return true;
  });
  const nlohmann::json render =
      nlohmann::json::parse(std::ifstream(result.run_dir + "/metrics.json"))["processes"]["render"];
  out.render_report = render["process"];
  out.render_sim_time_s = render["sim_time_s"];
  if (!::testing::Test::HasFailure()) std::filesystem::remove_all(options.out_dir);  // kept to look into
  return out;
}

// Every image shows a state physics published, in order, with its CameraInfo of the same stamp.
void ExpectStampedByPhysics(const RecordedImages& run) {
  for (const std::string& eye : kEyes) {
    ASSERT_TRUE(run.image_stamps_ns.count(eye)) << eye << " recorded no image";
    const std::vector<int64_t>& stamps = run.image_stamps_ns.at(eye);
    for (size_t i = 0; i < stamps.size(); ++i) {
      EXPECT_TRUE(run.state_stamps_ns.count(stamps[i]))
          << eye << " image " << i << " at " << stamps[i] << " ns: no physics state has that stamp";
      if (i > 0) {
        EXPECT_GT(stamps[i], stamps[i - 1]) << eye;
      }
    }
    EXPECT_EQ(run.info_stamps_ns.at(eye), stamps) << eye << ": one CameraInfo per image, same stamp";
  }
}

TEST(RenderFlight, LockstepImagesCarryPhysicsStampsAndRepeatByteForByte) {
  const RecordedImages first = Fly("lockstep", {"duration_s=1"});
  ExpectStampedByPhysics(first);
  for (const std::string& eye : kEyes) {
    // 20 Hz at steps 0, 50, ..., 1000: every due frame drawn, at exactly its step's stamp
    const std::vector<int64_t>& stamps = first.image_stamps_ns.at(eye);
    ASSERT_EQ(stamps.size(), 21u) << eye;
    for (size_t i = 0; i < stamps.size(); ++i)
      EXPECT_EQ(stamps[i], static_cast<int64_t>(i) * 50000000) << eye;
    const render::Image image = render::DecodeImage(first.png.at(eye).back(), eye);
    EXPECT_EQ(image.width, 640);
    EXPECT_EQ(image.height, 480);
  }
  // the eyes of a pair see the yard from 12 cm apart, and the view changes as the IAP flies
  EXPECT_NE(first.png.at("/iap/sub1/stereo/left").back(), first.png.at("/iap/sub1/stereo/right").back());
  EXPECT_NE(first.png.at("/iap/platform/chase").front(), first.png.at("/iap/platform/chase").back());
  EXPECT_EQ(first.render_report["frames"], 21);
  EXPECT_EQ(first.render_report["images"], 21 * 7);
  EXPECT_EQ(first.render_report["frames_skipped_busy"], 0);

  const RecordedImages second = Fly("lockstep-again", {"duration_s=1"});
  for (const std::string& eye : kEyes) EXPECT_TRUE(first.png.at(eye) == second.png.at(eye)) << eye;
}

TEST(RenderFlight, RealtimeImagesShowTheNewestStateTheyHad) {
  const RecordedImages run = Fly("realtime", {"duration_s=2", "mode=realtime"});
  ExpectStampedByPhysics(run);
  // 41 frames were due (20 Hz for 2 s, steps 0..2000). Realtime does not wait for the renderer, so it may
  // see fewer ticks (the run stops without it); each due tick it saw was drawn, skipped because a frame was
  // still drawing, or came before the first state.
  const uint64_t frames = run.render_report["frames"], skipped = run.render_report["frames_skipped_busy"],
                 without_state = run.render_report["frames_without_state"];
  const auto due_seen = static_cast<uint64_t>(std::floor(run.render_sim_time_s * 20.0 + 1e-6)) + 1;
  EXPECT_EQ(frames + skipped + without_state, due_seen) << "the last tick seen at " << run.render_sim_time_s;
  EXPECT_LE(due_seen, 41u);
  EXPECT_GE(frames, 1u);
  EXPECT_GT(run.render_report["latency_ms"]["p50"].get<double>(), 0.0);
}

}  // namespace
}  // namespace iapsim::bridge
