#include "control/trajectory.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "bridge/message_format.h"
#include "control/allocation.h"

namespace iapsim::control {
namespace {

namespace fs = std::filesystem;
using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr double kDegToRad = M_PI / 180.0;

std::unique_ptr<Trajectory> FromYaml(const std::string& text,
                                     const std::string& scenario_file = "scenario.yaml") {
  bridge::YamlMap map(YAML::Load(text), scenario_file, "trajectory");
  return ReadTrajectory(map, scenario_file);
}

std::string ErrorOf(const std::string& text, const std::string& scenario_file = "scenario.yaml") {
  try {
    FromYaml(text, scenario_file);
  } catch (const bridge::ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no ConfigError for:\n" << text;
  return "";
}

Vector3d RotationVector(const Quaterniond& q) {
  const Eigen::AngleAxisd angle_axis(q);
  return angle_axis.angle() * angle_axis.axis();
}

// Velocities, accelerations, ω̄ and dω̄/dt against central differences of what they differentiate.
void ExpectDerivativesMatchDifferences(const Trajectory& trajectory, const std::vector<double>& times_s) {
  constexpr double h = 1e-5;
  for (const double t : times_s) {
    SCOPED_TRACE("t = " + std::to_string(t) + " s");
    const PoseReference before = trajectory.Sample(t - h), now = trajectory.Sample(t),
                        after = trajectory.Sample(t + h);
    const auto expect_near = [](const Vector3d& exact, const Vector3d& difference, const char* what) {
      EXPECT_LT((exact - difference).norm(), 1e-6 * (1.0 + exact.norm()))
          << what << ": " << exact.transpose() << " vs differences " << difference.transpose();
    };
    expect_near(now.v_WP_W_mps, (after.p_WP_m - before.p_WP_m) / (2 * h), "velocity");
    expect_near(now.a_WP_W_mps2, (after.v_WP_W_mps - before.v_WP_W_mps) / (2 * h), "acceleration");
    expect_near(now.w_WP_P_radps, RotationVector(before.q_WP.conjugate() * after.q_WP) / (2 * h),
                "body rate");
    expect_near(now.dw_WP_P_radps2, (after.w_WP_P_radps - before.w_WP_P_radps) / (2 * h),
                "body rate derivative");
  }
}

// A grid over the flight and past both ends, and points just either side of `boundaries_s`.
std::vector<double> TestTimes(double duration_s, const std::vector<double>& boundaries_s) {
  std::vector<double> times{-1.0, duration_s + 1.0};
  // off the knots of the recorded test trajectory, where dω̄/dt steps
  for (int i = 0; i < 97; ++i) times.push_back(duration_s * (i + 0.37) / 97);
  for (const double b : boundaries_s) {
    times.push_back(b - 1e-3);
    times.push_back(b + 1e-3);
  }
  times.push_back(1e-3);
  times.push_back(duration_s - 1e-3);
  return times;
}

void ExpectAtRest(const PoseReference& reference) {
  EXPECT_EQ(reference.v_WP_W_mps, Vector3d::Zero());
  EXPECT_EQ(reference.a_WP_W_mps2, Vector3d::Zero());
  EXPECT_EQ(reference.w_WP_P_radps, Vector3d::Zero());
  EXPECT_EQ(reference.dw_WP_P_radps2, Vector3d::Zero());
}

TEST(ReferenceFromEuler, AttitudeRateAndItsDerivativeFollowTheAngles) {
  // an arbitrary smooth motion of all three angles
  const auto angles = [](double t) {
    return std::array<Vector3d, 3>{
        Vector3d(0.3 * std::sin(1.1 * t), -0.4 * std::cos(0.7 * t), 2.0 * std::sin(0.5 * t) + t),
        Vector3d(0.33 * std::cos(1.1 * t), 0.28 * std::sin(0.7 * t), std::cos(0.5 * t) + 1.0),
        Vector3d(-0.363 * std::sin(1.1 * t), 0.196 * std::cos(0.7 * t), -0.5 * std::sin(0.5 * t))};
  };
  const auto reference = [&](double t) {
    const auto [rpy, rate, accel] = angles(t);
    return ReferenceFromEuler(Vector3d(1, 2, 3), Vector3d(4, 5, 6), Vector3d(7, 8, 9), rpy, rate, accel);
  };
  constexpr double h = 1e-5;
  for (double t = 0.0; t < 10.0; t += 0.37) {
    const PoseReference now = reference(t), before = reference(t - h), after = reference(t + h);
    const Vector3d rpy = angles(t)[0];
    EXPECT_LT(now.q_WP.angularDistance(Quaterniond(Eigen::AngleAxisd(rpy.z(), Vector3d::UnitZ()) *
                                                   Eigen::AngleAxisd(rpy.y(), Vector3d::UnitY()) *
                                                   Eigen::AngleAxisd(rpy.x(), Vector3d::UnitX()))),
              1e-12);
    EXPECT_EQ(now.p_WP_m, Vector3d(1, 2, 3));
    EXPECT_EQ(now.v_WP_W_mps, Vector3d(4, 5, 6));
    EXPECT_EQ(now.a_WP_W_mps2, Vector3d(7, 8, 9));
    EXPECT_LT((now.w_WP_P_radps - RotationVector(before.q_WP.conjugate() * after.q_WP) / (2 * h)).norm(),
              1e-8);
    EXPECT_LT((now.dw_WP_P_radps2 - (after.w_WP_P_radps - before.w_WP_P_radps) / (2 * h)).norm(), 1e-8);
  }
}

constexpr char kWaypoints[] = R"(
type: waypoints
waypoints:
  - {t_s: 0, position_m: [0, 0, -1]}
  - {t_s: 2, position_m: [2, 1, -2], rpy_deg: [5, -3, 40]}
  - {t_s: 3.5, position_m: [3, -1, -2.5], rpy_deg: [-4, 6, 120]}
  - {t_s: 6, position_m: [1, 0, -1], rpy_deg: [0, 0, 90]}
)";

TEST(WaypointTrajectory, PassesEveryWaypointAtItsTimeAndRestsAtTheEnds) {
  const auto trajectory = FromYaml(kWaypoints);
  EXPECT_EQ(trajectory->duration_s(), 6.0);
  const std::vector<std::pair<double, std::array<Vector3d, 2>>> waypoints{
      {0.0, {Vector3d(0, 0, -1), Vector3d(0, 0, 0)}},
      {2.0, {Vector3d(2, 1, -2), Vector3d(5, -3, 40)}},
      {3.5, {Vector3d(3, -1, -2.5), Vector3d(-4, 6, 120)}},
      {6.0, {Vector3d(1, 0, -1), Vector3d(0, 0, 90)}}};
  for (const auto& [t_s, pose] : waypoints) {
    const PoseReference reference = trajectory->Sample(t_s);
    const Vector3d rpy = pose[1] * kDegToRad;
    EXPECT_LT((reference.p_WP_m - pose[0]).norm(), 1e-12) << t_s;
    EXPECT_LT(reference.q_WP.angularDistance(AttitudeFromEuler(rpy.x(), rpy.y(), rpy.z())), 1e-12) << t_s;
    EXPECT_NEAR(reference.a_WP_W_mps2.norm(), 0.0, 1e-12) << "zero acceleration at waypoints, t = " << t_s;
    EXPECT_FALSE(reference.five_dof);
  }
  for (const double t_s : {-1.0, 0.0, 6.0, 7.0}) ExpectAtRest(trajectory->Sample(t_s));
  EXPECT_EQ(trajectory->Sample(-1.0).p_WP_m, Vector3d(0, 0, -1));
  EXPECT_EQ(trajectory->Sample(7.0).p_WP_m, Vector3d(1, 0, -1));
  // interior velocity: the mean of the neighbouring slopes, zero where a coordinate turns back (y here)
  const Vector3d v = trajectory->Sample(2.0).v_WP_W_mps;
  EXPECT_NEAR(v.x(), 0.5 * (1.0 + 1.0 / 1.5), 1e-12);
  EXPECT_NEAR(v.y(), 0.0, 1e-12);
  EXPECT_NEAR(v.z(), 0.5 * (-0.5 - 0.5 / 1.5), 1e-12);
}

TEST(WaypointTrajectory, DerivativesAreExact) {
  const auto trajectory = FromYaml(kWaypoints);
  ExpectDerivativesMatchDifferences(*trajectory, TestTimes(6.0, {2.0, 3.5}));
}

TEST(WaypointTrajectory, StopAtWaypointsRestsAtEveryWaypoint) {
  const auto trajectory = FromYaml(std::string(kWaypoints) + "stop_at_waypoints: true\n");
  for (const double t_s : {2.0, 3.5}) ExpectAtRest(trajectory->Sample(t_s));
  ExpectDerivativesMatchDifferences(*trajectory, TestTimes(6.0, {2.0, 3.5}));
}

TEST(WaypointTrajectory, YawTakesTheShortWayThrough180Degrees) {
  const auto trajectory = FromYaml(R"(
type: waypoints
waypoints:
  - {t_s: 0, position_m: [0, 0, -1], rpy_deg: [0, 0, 170]}
  - {t_s: 2, position_m: [0, 0, -1], rpy_deg: [0, 0, -170]}
)");
  // halfway the platform faces −x (yaw 180°), turning through +20° rather than −340°
  EXPECT_LT(trajectory->Sample(1.0).q_WP.angularDistance(AttitudeFromEuler(0, 0, M_PI)), 1e-12);
  const Quaterniond start = trajectory->Sample(0.0).q_WP;
  for (double t = 0.05; t < 2.0; t += 0.05) {
    EXPECT_GT(trajectory->Sample(t).w_WP_P_radps.z(), 0.0) << t;
    EXPECT_LE(start.angularDistance(trajectory->Sample(t).q_WP), 20.0 * kDegToRad + 1e-12) << t;
  }
}

TEST(PoseTrajectory, FiveDofCommandsKeepRollZero) {
  const auto trajectory = FromYaml(R"(
type: poses
poses:
  - {t_s: 0, position_m: [0, 0, -1]}
  - {t_s: 3, position_m: [1, 0, -1.5], pitch_deg: 10, yaw_deg: 30}
  - {t_s: 5, position_m: [1, 1, -1.5], pitch_deg: -5, yaw_deg: 60}
)");
  EXPECT_EQ(trajectory->duration_s(), 5.0);
  for (const double t_s : {-1.0, 0.0, 1.0, 3.0, 4.2, 5.0, 6.0}) EXPECT_TRUE(trajectory->Sample(t_s).five_dof);
  const PoseReference at_3 = trajectory->Sample(3.0);
  EXPECT_LT((at_3.p_WP_m - Vector3d(1, 0, -1.5)).norm(), 1e-12);
  EXPECT_LT(at_3.q_WP.angularDistance(AttitudeFromEuler(0.0, 10 * kDegToRad, 30 * kDegToRad)), 1e-12);
  // no roll: the platform's y axis stays horizontal
  for (double t = 0.0; t <= 5.0; t += 0.25) {
    EXPECT_NEAR((trajectory->Sample(t).q_WP * Vector3d::UnitY()).z(), 0.0, 1e-12) << t;
  }
  ExpectDerivativesMatchDifferences(*trajectory, TestTimes(5.0, {3.0}));
}

constexpr char kSpiral[] = R"(
type: spiral
center_m: [1, 2, -3]
start_radius_m: 4
end_radius_m: 0.5
turns: 2
climb_m: -2
duration_s: 30
start_angle_deg: 30
attitude_amplitude_deg: [10, 8, 15]
attitude_period_s: 5
yaw0_deg: 45
ramp_s: 3
)";

TEST(SpiralTrajectory, SpiralsInToTheEndRadiusFromRestToRest) {
  const auto trajectory = FromYaml(kSpiral);
  EXPECT_EQ(trajectory->duration_s(), 30.0);
  const Vector3d center(1, 2, -3);
  const Vector3d start_direction(std::cos(30 * kDegToRad), std::sin(30 * kDegToRad), 0.0);
  const PoseReference start = trajectory->Sample(0.0), end = trajectory->Sample(30.0);
  // climb_m −2: starts 2 m below the centre (NED) and ends level with it
  EXPECT_LT((start.p_WP_m - (center + 4.0 * start_direction + Vector3d(0, 0, 2))).norm(), 1e-12);
  EXPECT_LT((end.p_WP_m - (center + 0.5 * start_direction)).norm(), 1e-12) << "two whole turns";
  for (const PoseReference& at_rest : {start, end, trajectory->Sample(-2.0), trajectory->Sample(31.0)}) {
    ExpectAtRest(at_rest);
    EXPECT_LT(at_rest.q_WP.angularDistance(AttitudeFromEuler(0, 0, 45 * kDegToRad)), 1e-12) << "level, yaw0";
  }
  // the radius shrinks steadily, and the attitude varies in flight
  double radius_before = 4.0 + 1e-9;
  double largest_tilt = 0.0;
  for (double t = 0.0; t <= 30.0; t += 0.1) {
    const PoseReference reference = trajectory->Sample(t);
    const double radius = (reference.p_WP_m - center).head<2>().norm();
    EXPECT_LE(radius, radius_before) << t;
    radius_before = radius;
    largest_tilt = std::max(largest_tilt, reference.q_WP.angularDistance(start.q_WP));
  }
  EXPECT_GT(largest_tilt, 10 * kDegToRad);
}

TEST(SpiralTrajectory, DerivativesAreExact) {
  const auto trajectory = FromYaml(kSpiral);
  ExpectDerivativesMatchDifferences(*trajectory, TestTimes(30.0, {3.0, 27.0}));
}

constexpr char kCircle[] = R"(
type: circle
center_m: [0, 0, -2]
radius_m: 1.5
speed_mps: 0.5
start_angle_deg: 90
laps: 2
rpy_deg: [0, 0, 30]
)";

TEST(CircleTrajectory, ConstantRadiusAndSpeedAfterTheRamp) {
  const auto trajectory = FromYaml(kCircle);
  const double duration_s = 2 * 2 * M_PI * 1.5 / 0.5 + 2.0;  // whole laps at full speed, plus one ramp_s
  EXPECT_NEAR(trajectory->duration_s(), duration_s, 1e-12);
  EXPECT_LT((trajectory->Sample(0.0).p_WP_m - Vector3d(0, 1.5, -2)).norm(), 1e-12);
  EXPECT_LT((trajectory->Sample(duration_s).p_WP_m - Vector3d(0, 1.5, -2)).norm(), 1e-12);
  ExpectAtRest(trajectory->Sample(0.0));
  ExpectAtRest(trajectory->Sample(duration_s));
  for (double t = 0.0; t <= duration_s; t += 0.05) {
    const PoseReference reference = trajectory->Sample(t);
    EXPECT_NEAR(reference.p_WP_m.head<2>().norm(), 1.5, 1e-12) << t;
    EXPECT_EQ(reference.p_WP_m.z(), -2.0);
    const double speed_mps = reference.v_WP_W_mps.norm();
    if (t >= 2.0 && t <= duration_s - 2.0) {
      EXPECT_NEAR(speed_mps, 0.5, 1e-12) << t;
    }
    EXPECT_LE(speed_mps, 0.5 + 1e-12) << t;
    EXPECT_LT(reference.q_WP.angularDistance(AttitudeFromEuler(0, 0, 30 * kDegToRad)), 1e-12);
    EXPECT_EQ(reference.w_WP_P_radps, Vector3d::Zero());
  }
  ExpectDerivativesMatchDifferences(*trajectory, TestTimes(duration_s, {2.0, duration_s - 2.0}));
}

TEST(CircleTrajectory, DurationInsteadOfLaps) {
  const auto trajectory = FromYaml(R"(
type: circle
center_m: [0, 0, -2]
radius_m: 1
speed_mps: 0.5
duration_s: 20
ramp_s: 4
yaw_follows_path: true
)");
  EXPECT_EQ(trajectory->duration_s(), 20.0);
  EXPECT_NEAR(trajectory->Sample(10.0).v_WP_W_mps.norm(), 0.5, 1e-12);
  ExpectDerivativesMatchDifferences(*trajectory, TestTimes(20.0, {4.0, 16.0}));
}

constexpr char kFigureEight[] = R"(
type: figure_eight
center_m: [1, -1, -2]
size_m: [2, 1]
height_amplitude_m: 0.5
period_s: 20
laps: 2
yaw_follows_path: true
ramp_s: 3
)";

TEST(FigureEightTrajectory, StartsAndEndsAtTheCentreFacingAlongThePath) {
  const auto trajectory = FromYaml(kFigureEight);
  EXPECT_EQ(trajectory->duration_s(), 43.0);
  const Vector3d center(1, -1, -2);
  for (const double t_s : {0.0, 43.0}) {
    EXPECT_LT((trajectory->Sample(t_s).p_WP_m - center).norm(), 1e-12) << t_s;
    ExpectAtRest(trajectory->Sample(t_s));
  }
  Vector3d lowest = Vector3d::Zero(), highest = Vector3d::Zero();
  for (double t = 0.0; t <= 43.0; t += 0.05) {
    const PoseReference reference = trajectory->Sample(t);
    const Vector3d offset = reference.p_WP_m - center;
    EXPECT_LE(std::abs(offset.x()), 2.0 + 1e-12);
    EXPECT_LE(std::abs(offset.y()), 1.0 + 1e-12);
    lowest = lowest.cwiseMin(offset);
    highest = highest.cwiseMax(offset);
    // yaw_follows_path: the platform's x axis along the horizontal velocity
    const Vector3d forward = reference.q_WP * Vector3d::UnitX();
    const Vector3d v = reference.v_WP_W_mps;
    if (v.head<2>().norm() > 1e-3) {
      EXPECT_NEAR(forward.head<2>().normalized().dot(v.head<2>().normalized()), 1.0, 1e-9) << t;
    }
  }
  EXPECT_NEAR(lowest.x(), -2.0, 1e-3);
  EXPECT_NEAR(highest.y(), 1.0, 1e-3);
  EXPECT_NEAR(lowest.z(), -0.5, 1e-3) << "h higher (NED −z) at the lobes' tips";
  EXPECT_NEAR(highest.z(), 0.0, 1e-12);
}

TEST(FigureEightTrajectory, DerivativesAreExact) {
  const auto trajectory = FromYaml(kFigureEight);
  ExpectDerivativesMatchDifferences(*trajectory, TestTimes(43.0, {3.0, 40.0}));
}

// Files in a fresh folder per test, removed afterwards.
class RecordedTrajectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() / ("iapsim_trajectory_test_" + std::to_string(::getpid()) + "_" +
                                           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(folder_);
  }
  void TearDown() override { fs::remove_all(folder_); }

  std::string Write(const std::string& name, const std::string& text) const {
    const fs::path path = folder_ / name;
    std::ofstream(path) << text;
    return fs::canonical(path).string();
  }

  std::unique_ptr<Trajectory> Read(const std::string& path, const std::string& format,
                                   const std::string& more = "") const {
    return FromYaml("type: file\npath: " + path + "\nformat: " + format + "\n" + more,
                    (folder_ / "scenario.yaml").string());
  }

  std::string ReadError(const std::string& path, const std::string& format) const {
    return ErrorOf("type: file\npath: " + path + "\nformat: " + format + "\n",
                   (folder_ / "scenario.yaml").string());
  }

  fs::path folder_;
};

// A recording at 4 Hz from stamp 100 s: every attitude turns, and alternate quaternions have the other sign.
struct Recording {
  std::vector<double> t_s;
  std::vector<Vector3d> p_m;
  std::vector<Quaterniond> q;
};

Recording MakeRecording() {
  Recording recording;
  for (int k = 0; k <= 20; ++k) {
    const double t = 0.25 * k;
    recording.t_s.push_back(100.0 + t);
    recording.p_m.emplace_back(std::sin(t), std::cos(0.7 * t), -1.0 - 0.1 * t);
    Quaterniond q = AttitudeFromEuler(0.2 * std::sin(t), 0.1 * std::cos(t), 0.7 * t);
    if (k % 2) q.coeffs() *= -1.0;
    recording.q.push_back(q);
  }
  return recording;
}

std::string Exact(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.17g", value);
  return text;
}

bridge::StampedPose Stamped(const Recording& recording, size_t k) {
  bridge::StampedPose pose;
  pose.time_ns = std::llround(recording.t_s[k] * 1e9);
  for (int i = 0; i < 3; ++i) pose.position[i] = recording.p_m[k][i];
  for (int i = 0; i < 4; ++i) pose.orientation_xyzw[i] = recording.q[k].coeffs()[i];
  return pose;
}

void ExpectThroughSamples(const Trajectory& trajectory, const Recording& recording, double offset_s) {
  for (size_t k = 0; k < recording.t_s.size(); ++k) {
    const PoseReference reference = trajectory.Sample(recording.t_s[k] - offset_s);
    EXPECT_LT((reference.p_WP_m - recording.p_m[k]).norm(), 1e-12) << k;
    EXPECT_LT(reference.q_WP.angularDistance(recording.q[k]), 1e-9) << k;
  }
}

TEST_F(RecordedTrajectoryTest, TumAsIapsimExportWritesIt) {
  const Recording recording = MakeRecording();
  std::string text = "# t x y z qx qy qz qw\n";
  for (size_t k = 0; k < recording.t_s.size(); ++k) text += bridge::FormatTum(Stamped(recording, k)) + "\n";
  Write("flight.tum", text);
  const auto trajectory = Read("flight.tum", "tum");  // relative to the scenario's folder
  EXPECT_NEAR(trajectory->duration_s(), 5.0, 1e-12) << "the first stamp becomes t = 0";
  ExpectThroughSamples(*trajectory, recording, 100.0);
  std::vector<double> knots_s;
  for (const double t : recording.t_s) knots_s.push_back(t - 100.0);
  ExpectDerivativesMatchDifferences(*trajectory, TestTimes(5.0, knots_s));
  // ω̄ and the acceleration are continuous at the inner samples
  for (size_t k = 1; k + 1 < knots_s.size(); ++k) {
    const double t = knots_s[k];
    const PoseReference before = trajectory->Sample(t - 1e-9), after = trajectory->Sample(t + 1e-9);
    EXPECT_LT((before.w_WP_P_radps - after.w_WP_P_radps).norm(), 1e-6) << t;
    EXPECT_LT((before.a_WP_W_mps2 - after.a_WP_W_mps2).norm(), 1e-6) << t;
  }
  ExpectAtRest(trajectory->Sample(-1.0));
  ExpectAtRest(trajectory->Sample(6.0));
  EXPECT_EQ(trajectory->Sample(6.0).p_WP_m, recording.p_m.back());
}

TEST_F(RecordedTrajectoryTest, CsvWithNamedColumnsAndATimeOffset) {
  const Recording recording = MakeRecording();
  std::string text = "t_s,x_m,y_m,z_m,qx,qy,qz,qw\n";
  for (size_t k = 0; k < recording.t_s.size(); ++k) {
    const Vector3d& p = recording.p_m[k];
    const Quaterniond& q = recording.q[k];
    for (const double v : {recording.t_s[k], p.x(), p.y(), p.z(), q.x(), q.y(), q.z()})
      text += Exact(v) + ",";
    text += Exact(q.w()) + "\n";
  }
  const std::string path = Write("flight.csv", text);
  const auto trajectory = Read(path, "csv", "time_offset_s: 99\n");
  EXPECT_NEAR(trajectory->duration_s(), 6.0, 1e-12);
  ExpectThroughSamples(*trajectory, recording, 99.0);
  // before the first stamp: the first sample, at rest
  const PoseReference early = trajectory->Sample(0.5);
  ExpectAtRest(early);
  EXPECT_EQ(early.p_WP_m, recording.p_m.front());
}

TEST_F(RecordedTrajectoryTest, CsvOfAPoseTopicAsIapsimExportWritesIt) {
  const Recording recording = MakeRecording();
  std::ostringstream out;
  bridge::CsvWriter csv(out);
  for (size_t k = 0; k < recording.t_s.size(); ++k) {
    const bridge::StampedPose pose = Stamped(recording, k);
    bridge::FlatMessage message;
    message.columns = {"header.seq",         "header.stamp",      "header.frame_id",    "pose.position.x",
                       "pose.position.y",    "pose.position.z",   "pose.orientation.x", "pose.orientation.y",
                       "pose.orientation.z", "pose.orientation.w"};
    message.values = {std::to_string(k), "0.0", "W, quoted"};  // a field that needs quotes
    for (const double v : pose.position) message.values.push_back(Exact(v));
    for (const double v : pose.orientation_xyzw) message.values.push_back(Exact(v));
    csv.Write(pose.time_ns, message);
  }
  const auto trajectory = Read(Write("pose.csv", out.str()), "csv");
  EXPECT_NEAR(trajectory->duration_s(), 5.0, 1e-12);
  ExpectThroughSamples(*trajectory, recording, 100.0);
}

TEST_F(RecordedTrajectoryTest, BadFilesNameTheFileAndTheLine) {
  const std::string good = "0 0 0 -1 0 0 0 1\n";
  const struct {
    std::string name, format, text, line, what;
  } cases[] = {
      {"backwards.tum", "tum", "# header\n" + good + "1 0 0 -1 0 0 0 1\n0.5 0 0 -1 0 0 0 1\n",
       ":4:", "not after the previous sample"},
      {"repeated.tum", "tum", good + good, ":2:", "not after the previous sample"},
      {"short_row.tum", "tum", good + "1 0 0 -1 0 0 1\n", ":2:", "expected 8 values"},
      {"zero_quaternion.tum", "tum", good + "1 0 0 -1 0 0 0 0\n", ":2:", "norm 0"},
      {"scaled_quaternion.tum", "tum", good + "1 0 0 -1 0 0 0 0.9\n", ":2:", "expected a unit quaternion"},
      {"word.tum", "tum", good + "1 0 zero -1 0 0 0 1\n", ":2:", "'zero'"},
      {"short_row.csv", "csv", "t_s,x_m,y_m,z_m,qx,qy,qz,qw\n0,0,0,-1,0,0,0,1\n1,0,0,-1,0,0,1\n",
       ":3:", "expected 8 fields"},
      {"no_pose.csv", "csv", "t_s,x,y,z\n0,0,0,0\n", ":1:", "x_m"},
  };
  for (const auto& c : cases) {
    const std::string path = Write(c.name, c.text);
    const std::string error = ReadError(path, c.format);
    EXPECT_NE(error.find(path + c.line), std::string::npos) << error;
    EXPECT_NE(error.find(c.what), std::string::npos) << error;
  }
  const std::string path = Write("one.tum", "# one sample is no trajectory\n" + good);
  const std::string error = ReadError(path, "tum");
  EXPECT_NE(error.find(path + ": expected at least 2 samples, found 1"), std::string::npos) << error;
  EXPECT_NE(ReadError("missing.tum", "tum").find("trajectory.path: no file 'missing.tum'"),
            std::string::npos);
  EXPECT_NE(ReadError(path, "ros").find("trajectory.format: must be one of tum, csv, got 'ros'"),
            std::string::npos);
  const std::string no_format = ErrorOf("type: file\npath: " + path + "\n");
  EXPECT_NE(no_format.find("trajectory.format: is required"), std::string::npos) << no_format;
}

TEST(ReadTrajectory, BadSectionsNameTheKey) {
  const struct {
    std::string yaml, expected;
  } cases[] = {
      {"type: helix\n", "scenario.yaml:1:7: trajectory.type: must be one of waypoints, poses, spiral"},
      {"center_m: [0, 0, -1]\n", "trajectory.type: is required"},
      {"type: circle\ncenter_m: [0, 0, -1]\nspeed_mps: 1\nlaps: 1\n", "trajectory.radius_m: is required"},
      {"type: circle\ncenter_m: [0, 0, -1]\nradius_m: 1\nspeed_mps: 1\nlaps: 1\nduration_s: 9\n",
       "trajectory.laps: give either laps or duration_s"},
      {"type: circle\ncenter_m: [0, 0, -1]\nradius_m: 1\nspeed_mps: 1\nlaps: 1\nradius: 2\n",
       "trajectory.radius: unknown key"},
      {"type: circle\ncenter_m: [0, 0, -1]\nradius_m: 1\nspeed_mps: 1\nduration_s: 3\n",
       "trajectory.ramp_s: must be at most half the flight (3 s)"},
      {"type: circle\ncenter_m: [0, 0]\nradius_m: 1\nspeed_mps: 1\nlaps: 1\n",
       "trajectory.center_m: expected 3"},
      {"type: waypoints\nwaypoints:\n  - {t_s: 0, position_m: [0, 0, 0]}\n  - {t_s: 2, position_m: [1, 0, "
       "0]}\n"
       "  - {t_s: 2, position_m: [2, 0, 0]}\n",
       "scenario.yaml:5:11: trajectory.waypoints[2].t_s: must be after the previous item's 2 s, got 2"},
      {"type: waypoints\nwaypoints:\n  - {t_s: 1, position_m: [0, 0, 0]}\n",
       "trajectory.waypoints[0].t_s: the first item must be at t_s 0, got 1"},
      {"type: waypoints\nwaypoints:\n  - {t_s: 0, position_m: [0, 0, 0], rpy_dge: [0, 0, 1]}\n",
       "trajectory.waypoints[0].rpy_dge: unknown key (did you mean 'rpy_deg'?)"},
      {"type: waypoints\nwaypoints:\n  - {t_s: 0}\n", "trajectory.waypoints[0].position_m: is required"},
      {"type: poses\nposes: {t_s: 0}\n", "trajectory.poses: expected a list"},
      {"type: spiral\ncenter_m: [0, 0, -1]\nstart_radius_m: 2\nend_radius_m: 0\nturns: 1\nduration_s: 10\n"
       "attitude_amplitude_deg: [5, 0, 0]\n",
       "trajectory.attitude_period_s: must be positive (s) when attitude_amplitude_deg is set"},
      {"type: figure_eight\ncenter_m: [0, 0, -1]\nsize_m: [1, 0]\nperiod_s: 10\n",
       "trajectory.size_m: expected"},
  };
  for (const auto& c : cases) {
    const std::string error = ErrorOf(c.yaml);
    EXPECT_NE(error.find(c.expected), std::string::npos) << "expected '" << c.expected << "' in: " << error;
  }
}

}  // namespace
}  // namespace iapsim::control
