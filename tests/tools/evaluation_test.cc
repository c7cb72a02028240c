// The evaluation's metrics computed from synthetic recordings with known errors (issue 24). Tracking
// (tools/flight_evaluation.h) against hand-computed RMSE and max |e|: pairing by stamp, per-axis statistics,
// the yaw error wrapped through ±180°, a setpoint without a state reported and not compared, mixer
// saturation counted per step. Contact (tools/contact_evaluation.h) on a known wall-push wrench trace and a
// known peg insertion (the tip's depth and offset from the hole's axis, the settled pitch command).
#include <geometry_msgs/WrenchStamped.h>
#include <gtest/gtest.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/Setpoint.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "bridge/bag.h"
#include "bridge/config.h"
#include "bridge/eigen_msgs.h"
#include "bridge/message.h"
#include "control/allocation.h"
#include "tools/contact_evaluation.h"
#include "tools/flight_evaluation.h"

namespace iapsim::tools {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A run folder with a recording written message by message and a metrics.json.
class RecordingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::path(::testing::TempDir()) / ("iapsim-evaluation-" + std::to_string(getpid()));
    std::filesystem::create_directories(dir_);
    bag_ = std::make_unique<bridge::BagWriter>((dir_ / "run.bag").string());
    std::ofstream(dir_ / "metrics.json")
        << R"({"processes": {"control": {"process": {"saturated_updates": 7}}}})";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // The platform at (p, rpy) at stamp_ns; `saturated` marks sub-aircraft whose mixer cut; `raw_P` is the
  // true contact wrench.
  void State(int64_t stamp_ns, const Eigen::Vector3d& p_m, const Eigen::Vector3d& rpy_rad,
             std::vector<bool> saturated = {false, false},
             const control::Vector6d& raw_P = control::Vector6d::Zero()) {
    iapsim_msgs::IapState state;
    state.header.stamp = bridge::ToRosTime(stamp_ns);
    state.bodies.resize(1);
    state.bodies[0].pose_W.position = bridge::ToPointMsg(p_m);
    state.bodies[0].pose_W.orientation =
        bridge::ToQuaternionMsg(control::AttitudeFromEuler(rpy_rad.x(), rpy_rad.y(), rpy_rad.z()));
    state.external_wrench_P.force = bridge::ToVector3Msg(raw_P.head<3>());
    state.external_wrench_P.torque = bridge::ToVector3Msg(raw_P.tail<3>());
    for (bool cut : saturated) {
      state.sub_aircraft.emplace_back();
      state.sub_aircraft.back().saturated = cut;
    }
    Write("/iap/state", stamp_ns, state);
  }
  void Setpoint(int64_t stamp_ns, const Eigen::Vector3d& p_m, const Eigen::Vector3d& rpy_rad) {
    iapsim_msgs::Setpoint setpoint;
    setpoint.header.stamp = bridge::ToRosTime(stamp_ns);
    setpoint.pose_W.position = bridge::ToPointMsg(p_m);
    setpoint.pose_W.orientation =
        bridge::ToQuaternionMsg(control::AttitudeFromEuler(rpy_rad.x(), rpy_rad.y(), rpy_rad.z()));
    Write("/iap/setpoint", stamp_ns, setpoint);
  }
  void Wrench(const std::string& topic, int64_t stamp_ns, const control::Vector6d& wrench_P) {
    geometry_msgs::WrenchStamped wrench;
    wrench.header.stamp = bridge::ToRosTime(stamp_ns);
    wrench.wrench.force = bridge::ToVector3Msg(wrench_P.head<3>());
    wrench.wrench.torque = bridge::ToVector3Msg(wrench_P.tail<3>());
    Write(topic, stamp_ns, wrench);
  }
  bridge::BagReader Recording() {
    bag_->Close();
    return bridge::BagReader((dir_ / "run.bag").string());
  }

  std::filesystem::path dir_;

 private:
  template <typename M>
  void Write(const std::string& topic, int64_t stamp_ns, const M& message) {
    const std::vector<uint8_t> bytes = bridge::Encode(message);
    bag_->Write(topic, bridge::TypeInfoOf<M>(), stamp_ns + 1, bytes.data(), bytes.size(), "/test");
  }
  std::unique_ptr<bridge::BagWriter> bag_;
};

class TrackingEvaluationTest : public RecordingTest {
 protected:
  nlohmann::json Evaluate() {
    TrackingEvaluation evaluation;
    evaluation.plots = false;
    return EvaluateTracking(dir_.string(), Recording(), evaluation);
  }
};

TEST_F(TrackingEvaluationTest, MatchesHandComputedErrors) {
  const Eigen::Vector3d origin(1.0, -2.0, -3.0);
  // errors (actual − reference): x 0.1, −0.2, 0, 0.3; y 0; z −0.05 throughout; roll 2°, 0, 0, 0;
  // yaw: reference 179°, actual −179° at the third sample (+2° through the wrap), 0 elsewhere
  const double ex[4] = {0.1, -0.2, 0.0, 0.3};
  for (int k = 0; k < 4; ++k) {
    const int64_t stamp = 5000000 * (k + 1);
    const double yaw_ref = k == 2 ? 179.0 * kDeg : 0.0, yaw = k == 2 ? -179.0 * kDeg : 0.0;
    State(stamp, origin + Eigen::Vector3d(ex[k], 0.0, -0.05),
          Eigen::Vector3d(k == 0 ? 2.0 * kDeg : 0.0, 0, yaw),
          {k == 1, k == 1});  // one step with both mixers cutting: one step counted
    Setpoint(stamp, origin, Eigen::Vector3d(0, 0, yaw_ref));
  }
  Setpoint(25000000, origin, Eigen::Vector3d::Zero());  // its state was not recorded
  const nlohmann::json tracking = Evaluate();

  EXPECT_EQ(tracking["samples"], 4);
  EXPECT_EQ(tracking["unmatched_setpoints"], 1);
  EXPECT_NEAR(tracking["duration_s"].get<double>(), 0.020, 1e-12);  // first to last setpoint
  EXPECT_NEAR(tracking["position_rmse_m"]["x"].get<double>(), std::sqrt((0.01 + 0.04 + 0.0 + 0.09) / 4.0),
              1e-12);
  EXPECT_NEAR(tracking["position_max_m"]["x"].get<double>(), 0.3, 1e-12);
  EXPECT_NEAR(tracking["position_rmse_m"]["y"].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(tracking["position_rmse_m"]["z"].get<double>(), 0.05, 1e-12);
  EXPECT_NEAR(tracking["position_max_m"]["z"].get<double>(), 0.05, 1e-12);
  EXPECT_NEAR(tracking["attitude_rmse_deg"]["roll"].get<double>(), 1.0, 1e-9);  // √(2² / 4)
  EXPECT_NEAR(tracking["attitude_max_deg"]["roll"].get<double>(), 2.0, 1e-9);
  EXPECT_NEAR(tracking["attitude_max_deg"]["yaw"].get<double>(), 2.0, 1e-9);  // not 358°
  EXPECT_NEAR(tracking["attitude_rmse_deg"]["yaw"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(tracking["attitude_max_deg"]["pitch"].get<double>(), 0.0, 1e-9);
  EXPECT_EQ(tracking["mixer_saturated_steps"], 1);
  EXPECT_EQ(tracking["saturated_updates"], 7);  // the controller's own count, from metrics.json
  // the CSV holds the compared samples, and metrics.json the section
  std::ifstream csv(dir_ / "tracking.csv");
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 1 + 4);
  std::ifstream metrics(dir_ / "metrics.json");
  EXPECT_EQ(nlohmann::json::parse(metrics)["tracking"]["samples"], 4);
}

// A lead-in (the realistic profile's settling hover) is flown and recorded but not evaluated: the samples
// before the scenario's time 0 (a 1 m error and a mixer cut) count nowhere, and time starts at 0 there.
TEST_F(RecordingTest, TrackingStartsAtTheScenariosTimeZero) {
  for (int k = 0; k < 6; ++k) {
    const int64_t stamp = 5000000 * k;
    const bool lead_in = stamp < 15000000;
    State(stamp, Eigen::Vector3d(lead_in ? 1.0 : 0.1, 0, 0), Eigen::Vector3d::Zero(), {lead_in, false});
    Setpoint(stamp, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  }
  TrackingEvaluation evaluation;
  evaluation.plots = false;
  evaluation.start_ns = 15000000;
  const nlohmann::json tracking = EvaluateTracking(dir_.string(), Recording(), evaluation);
  EXPECT_EQ(tracking["samples"], 3);
  EXPECT_NEAR(tracking["position_max_m"]["x"].get<double>(), 0.1, 1e-12);
  EXPECT_EQ(tracking["mixer_saturated_steps"], 0);
  EXPECT_NEAR(tracking["duration_s"].get<double>(), 0.010, 1e-12);
  std::ifstream csv(dir_ / "tracking.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  EXPECT_EQ(first.substr(0, 6), "0.000,") << first;
}

TEST_F(TrackingEvaluationTest, NoMatchingStampIsAnError) {
  State(1000000, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  Setpoint(2000000, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  EXPECT_THROW(Evaluate(), std::runtime_error);
}

// A wall push at 10 Hz for 20 s: the wrench command (fx 1.5 N, fy 4 N, tz −4 N·m) from 2 s; the filtered
// wrench has fx at 1.0 N until 2.5 s and 1.5 N after, fy at 2.0 N until 5 s and 3.8 N after, tz at
// −4.2 N·m; for 10 samples of the 10 s steady window fy drops to 0, which leaves the force (1.5 N) under
// the 1.6 N that counts as contact here; the raw wrench first touches at 1.9 s and spikes to 50 N at 2.5 s.
class WallPushRecording : public RecordingTest {
 protected:
  void Record() {
    const control::Vector6d command = (control::Vector6d() << 1.5, 4.0, 0, 0, 0, -4.0).finished();
    for (int k = 0; k <= 200; ++k) {
      const int64_t stamp = 100000000LL * k + 1000000;  // the first setpoint at 1 ms, as in a run
      const double t = 0.1 * k;
      control::Vector6d raw = control::Vector6d::Zero(), filtered = control::Vector6d::Zero();
      if (k >= 19) raw[0] = 1.0;
      if (k == 25) raw[1] = 50.0;
      const bool broken = k >= 150 && k < 160;
      if (k >= 20) filtered << (k < 25 ? 1.0 : 1.5), broken ? 0.0 : t < 5.0 - 1e-9 ? 2.0 : 3.8, 0, 0, 0, -4.2;
      State(stamp, Eigen::Vector3d(1.01, -0.02, -2.0), Eigen::Vector3d::Zero(), {false}, raw);
      Setpoint(stamp, Eigen::Vector3d(1.0, 0.0, -2.0), Eigen::Vector3d::Zero());
      Wrench("/iap/wrench/filtered", stamp, filtered);
      const bool released = k >= 152 && k < 160;  // (21) let go during the break and engaged again
      if (k >= 20 && !released) Wrench("/iap/wrench/target", stamp, command);
    }
  }
  nlohmann::json Evaluate(int64_t start_ns) {
    Record();
    ContactEvaluation evaluation;
    evaluation.plots = false;
    evaluation.contact_force_N = 1.6;
    evaluation.start_ns = start_ns;
    return EvaluateContact(dir_.string(), Recording(), evaluation);
  }
};

TEST_F(WallPushRecording, ContactMetricsOfAKnownWallPush) {
  const nlohmann::json contact = Evaluate(0);

  EXPECT_NEAR(contact["first_contact_s"].get<double>(), 1.9, 1e-9);
  EXPECT_NEAR(contact["max_raw_force_N"].get<double>(), std::hypot(1.0, 50.0), 1e-9);
  EXPECT_NEAR(contact["max_raw_force_at_s"].get<double>(), 2.5, 1e-9);
  EXPECT_NEAR(contact["engaged_at_s"].get<double>(), 2.0, 1e-9);
  EXPECT_EQ(contact["engagements"].get<int>(), 2);
  // the window [10, 20] s holds 101 samples, 10 of them without contact
  const double touching = 91.0 / 101.0;
  EXPECT_NEAR(contact["contact_fraction"].get<double>(), touching, 1e-12);
  EXPECT_NEAR(contact["steady_wrench_P"]["fy"].get<double>(), 3.8 * touching, 1e-9);
  EXPECT_NEAR(contact["wrench_error_relative"]["fx"].get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(contact["wrench_error_relative"]["fy"].get<double>(), (4.0 - 3.8 * touching) / 4.0, 1e-9);
  EXPECT_NEAR(contact["wrench_error_relative"]["tz"].get<double>(), 0.2 / 4.0, 1e-9);
  EXPECT_TRUE(contact["wrench_error_relative"]["fz"].is_null());  // no command on fz: no relative error
  // settling within 10 % of the command, from the engagement to the last sample outside: fx is outside
  // until 2.5 s, fy until 5 s and again while it drops (15.0 to 15.9 s), tz never
  EXPECT_NEAR(contact["settling_time_s"]["fx"].get<double>(), 2.4 - 2.0, 1e-9);
  EXPECT_NEAR(contact["settling_time_s"]["fy"].get<double>(), 15.9 - 2.0, 1e-9);
  EXPECT_NEAR(contact["settling_time_s"]["tz"].get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(contact["steady_pose_error"]["x"].get<double>(), 0.01, 1e-9);
  EXPECT_NEAR(contact["steady_pose_error"]["y"].get<double>(), -0.02, 1e-9);
}

// After a lead-in the times count from the scenario's time 0, and what came before it is not evaluated: the
// touch at 1.9 s and the engagement at 2.0 s lie before a time 0 at 2.201 s, the spike 0.3 s after it.
TEST_F(WallPushRecording, ContactStartsAtTheScenariosTimeZero) {
  const nlohmann::json contact = Evaluate(2201000000);
  EXPECT_NEAR(contact["first_contact_s"].get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(contact["max_raw_force_at_s"].get<double>(), 0.3, 1e-9);
  EXPECT_NEAR(contact["engaged_at_s"].get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(contact["contact_fraction"].get<double>(), 91.0 / 101.0, 1e-12);  // the same last 10 s
}

// A peg-in-hole at 10 Hz for 20 s, level throughout, the hole's entry at (−1.375, 0, −2) m with its axis
// along −x and a 25 mm radius, the tip 1 m ahead of the platform along −x: the platform flies the tip 6 cm
// deep by 6 s, it is pulled back to 4 cm at 10 s; the pitch command ramps to 12° from 10 to 14 s and then
// alternates 11.8° / 12.2° (even / odd samples); the filtered force is 2 N from the first touch at 3 s. The
// tip stays `offset_m` beside the axis (along y).
class PegInHoleRecording : public RecordingTest {
 protected:
  nlohmann::json Evaluate(double offset_m) {
    for (int k = 0; k <= 200; ++k) {
      const int64_t stamp = 100000000LL * k + 1000000;
      const double t = 0.1 * k;
      const double depth_m = k <= 100 ? std::min(0.01 * t, 0.06) : 0.04;
      double pitch_command_deg = std::clamp(3.0 * (t - 10.0), 0.0, 12.0);
      if (k >= 140) pitch_command_deg = k % 2 == 0 ? 11.8 : 12.2;
      control::Vector6d filtered = control::Vector6d::Zero();
      if (k >= 30) filtered[0] = 2.0;
      State(stamp, Eigen::Vector3d(-0.375 - depth_m, offset_m, -2.0), Eigen::Vector3d::Zero(), {false});
      Setpoint(stamp, Eigen::Vector3d(-0.43, 0.0, -2.0), Eigen::Vector3d(0.0, pitch_command_deg * kDeg, 0.0));
      Wrench("/iap/wrench/filtered", stamp, filtered);
    }
    ContactEvaluation evaluation;
    evaluation.task = ContactEvaluation::Task::kPegInHole;
    evaluation.plots = false;
    evaluation.steady_window_s = 5.0;
    evaluation.hole_entry_W_m = Eigen::Vector3d(-1.375, 0.0, -2.0);
    evaluation.hole_axis_W = -Eigen::Vector3d::UnitX();
    evaluation.hole_radius_m = 0.025;
    return EvaluateContact(dir_.string(), Recording(), evaluation);
  }
};

TEST_F(PegInHoleRecording, ContactMetricsOfAKnownInsertion) {
  const nlohmann::json contact = Evaluate(0.01);
  // the window [15, 20] s holds samples 150..200: 26 even (11.8°) and 25 odd (12.2°)
  const double mean = (26 * 11.8 + 25 * 12.2) / 51.0;
  const double mean_square = (26 * 11.8 * 11.8 + 25 * 12.2 * 12.2) / 51.0;
  EXPECT_NEAR(contact["pitch_command_settled_deg"].get<double>(), mean, 1e-9);
  EXPECT_NEAR(contact["pitch_command_std_deg"].get<double>(), std::sqrt(mean_square - mean * mean), 1e-6);
  EXPECT_NEAR(contact["insertion_depth_final_m"].get<double>(), 0.04, 1e-9);
  EXPECT_NEAR(contact["insertion_depth_max_m"].get<double>(), 0.06, 1e-9);
  EXPECT_NEAR(contact["tip_radial_offset_final_m"].get<double>(), 0.01, 1e-9);
  EXPECT_TRUE(contact["first_contact_s"].is_null());  // no raw wrench recorded
  EXPECT_NEAR(contact["contact_fraction"].get<double>(), 1.0, 1e-12);
  EXPECT_TRUE(contact["success"].get<bool>());
}

// A pole that passed beside the funnel and leans on its outside is as deep along the axis and touching, but
// not in the hole.
TEST_F(PegInHoleRecording, ATipBesideTheHoleIsNotInIt) {
  const nlohmann::json contact = Evaluate(0.06);
  EXPECT_NEAR(contact["insertion_depth_final_m"].get<double>(), 0.04, 1e-9);
  EXPECT_NEAR(contact["tip_radial_offset_final_m"].get<double>(), 0.06, 1e-9);
  EXPECT_NEAR(contact["contact_fraction"].get<double>(), 1.0, 1e-12);
  EXPECT_FALSE(contact["success"].get<bool>());
}

// Without the hole's radius a peg-in-hole cannot tell a tip in the hole from one beside it: the scenario is
// refused, naming the file, the line and the key.
TEST(ContactEvaluationConfig, APegInHoleNeedsTheHolesRadius) {
  const YAML::Node root = YAML::Load(
      "contact:\n"
      "  task: peg_in_hole\n"
      "  hole_entry_W_m: [-1.375, 0.0, -2.0]\n");
  bridge::YamlMap evaluation(root, "peg.yaml", "evaluation");
  try {
    ReadContactEvaluation(evaluation);
    FAIL() << "a peg-in-hole without hole_radius_m was accepted";
  } catch (const bridge::ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("peg.yaml:2:"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("hole_radius_m: is required for task peg_in_hole"),
              std::string::npos)
        << error.what();
  }
}

}  // namespace
}  // namespace iapsim::tools
