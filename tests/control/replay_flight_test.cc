// Command-log replay (issue 4): a bag of recorded geometry_msgs/PoseStamped pose commands, stamped on a real
// flight's clock, drives the simulated three-square IAP through `iapsim replay`, which writes the same
// tracking metrics as the regression flights.
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "bridge/bag.h"
#include "bridge/eigen_msgs.h"
#include "bridge/launcher.h"
#include "bridge/message.h"
#include "control/trajectory.h"

namespace iapsim::control {
namespace {

constexpr double kFlightStart_s = 1700000000.0;  // a real flight's wall clock
constexpr double kCommandRate_hz = 50.0;

// What a pilot might have flown: a 1 m move with a turn, 12 s.
void WritePilotBag(const std::string& path) {
  const YAML::Node yaml = YAML::Load(R"(
type: waypoints
stop_at_waypoints: true
waypoints:
  - {t_s: 0, position_m: [0.0, 0.0, -2.0]}
  - {t_s: 6, position_m: [1.0, 0.5, -2.5], rpy_deg: [5, 0, 20]}
  - {t_s: 12, position_m: [1.0, 0.5, -2.5], rpy_deg: [0, 0, 0]}
)");
  bridge::YamlMap map(yaml, "pilot");
  const auto trajectory = ReadTrajectory(map, "");
  bridge::BagWriter bag(path);
  for (int k = 0; k <= static_cast<int>(12.0 * kCommandRate_hz); ++k) {
    const double t_s = k / kCommandRate_hz;
    const PoseReference reference = trajectory->Sample(t_s);
    geometry_msgs::PoseStamped command;
    command.header.stamp = ros::Time(kFlightStart_s + t_s);
    command.header.frame_id = "W";
    command.pose.position = bridge::ToPointMsg(reference.p_WP_m);
    command.pose.orientation = bridge::ToQuaternionMsg(reference.q_WP);
    const std::vector<uint8_t> bytes = bridge::Encode(command);
    bag.Write("/pilot/pose_cmd", bridge::TypeInfoOf<geometry_msgs::PoseStamped>(),
              static_cast<int64_t>(command.header.stamp.toNSec()), bytes.data(), bytes.size(), "/pilot");
  }
  bag.Close();
}

TEST(ReplayFlight, RecordedPoseCommandsFlyTheThreeSquare) {
  const std::filesystem::path out =
      std::filesystem::path(::testing::TempDir()) / ("iapsim-replay-flight-" + std::to_string(getpid()));
  std::filesystem::create_directories(out);
  const std::string bag = (out / "pilot.bag").string();
  WritePilotBag(bag);
  const std::string command = bridge::ExecutableDir() + "/iapsim replay " + bag + " --scenario " +
                              IAPSIM_SOURCE_DIR + "/configs/scenarios/three_square_replay.yaml" +
                              " --topics /pilot/pose_cmd --map /pilot/pose_cmd:=/iap/pose_cmd --duration 16 --out " +
                              (out / "run").string() + " > " + (out / "replay.log").string() + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << std::ifstream(out / "replay.log").rdbuf();

  std::ifstream in(out / "run" / "metrics.json");
  const auto metrics = nlohmann::json::parse(in);
  const auto& tracking = metrics["tracking"];
  const auto& control = metrics["processes"]["control"]["process"];
  std::printf("replayed pilot commands: position max %.4f %.4f %.4f m, yaw max %.3f deg\n",
              tracking["position_max_m"]["x"].get<double>(), tracking["position_max_m"]["y"].get<double>(),
              tracking["position_max_m"]["z"].get<double>(), tracking["attitude_max_deg"]["yaw"].get<double>());
  EXPECT_EQ(control["rejected_references"], 0);
  EXPECT_EQ(control["rejected_updates"], 0);
  EXPECT_EQ(tracking["samples"], 3201);  // 200 Hz for 16 s
  // the replayed commands were flown: the IAP ends at the last command (held after the log ends) ...
  std::ifstream csv(out / "run" / "tracking.csv");
  std::string line, last;
  while (std::getline(csv, line)) last = line;
  double t, x_ref, y_ref, z_ref, x, y, z;
  ASSERT_EQ(std::sscanf(last.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf", &t, &x_ref, &y_ref, &z_ref, &x, &y, &z), 7);
  EXPECT_NEAR(x_ref, 1.0, 1e-6);
  EXPECT_NEAR(y_ref, 0.5, 1e-6);
  EXPECT_NEAR(z_ref, -2.5, 1e-6);
  EXPECT_LT(std::hypot(x - 1.0, y - 0.5, z + 2.5), 0.05);
  // ... and tracked them closely all the way (the paper's real-vs-sim bounds are 0.4 m and 12° yaw)
  for (const char* axis : {"x", "y", "z"}) EXPECT_LT(tracking["position_max_m"][axis].get<double>(), 0.1) << axis;
  EXPECT_LT(tracking["attitude_max_deg"]["yaw"].get<double>(), 3.0);
  std::filesystem::remove_all(out);
}

}  // namespace
}  // namespace iapsim::control
