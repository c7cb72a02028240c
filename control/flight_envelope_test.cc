#include "control/flight_envelope.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>

namespace iapsim::control {
namespace {

constexpr double kDeg = M_PI / 180.0;

double TiltOf(const Eigen::Quaterniond& q) { return std::acos(q.toRotationMatrix()(2, 2)); }
double HeadingOf(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d x = q.toRotationMatrix().col(0);
  return std::atan2(x.y(), x.x());
}

FlightEnvelopeConfig Lab() {
  FlightEnvelopeConfig config;
  config.geofence_min_W_m = {-5.0, -5.0, -4.0};
  config.geofence_max_W_m = {5.0, 5.0, 0.0};
  config.max_speed_mps = 2.0;
  config.max_tilt_rad = 30.0 * kDeg;
  return config;
}

TEST(FlightEnvelope, AdmitsWhatIsInsideUnchanged) {
  FlightEnvelope envelope(Lab());
  const FlightEnvelope::PoseCommand command{
      {1.0, -2.0, -1.5}, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()))};
  const auto admitted = envelope.Admit(0.0, command, false);
  ASSERT_TRUE(admitted);
  EXPECT_EQ(admitted->p_WP_m, command.p_WP_m);
  EXPECT_TRUE(admitted->q_WP.isApprox(command.q_WP));
  EXPECT_EQ(envelope.counts().clamped, 0u);
}

TEST(FlightEnvelope, ClampsAFarCommandOntoTheGeofenceAndItsSpeed) {
  FlightEnvelope envelope(Lab());
  ASSERT_TRUE(envelope.Admit(0.0, {{0.0, 0.0, -1.0}, Eigen::Quaterniond::Identity()}, false));
  // 1e6 m away, 1 s later: onto the fence (5, 0, -1), then cut to 2 m from the previous command
  const auto admitted = envelope.Admit(1.0, {{1e6, 0.0, -1.0}, Eigen::Quaterniond::Identity()}, false);
  ASSERT_TRUE(admitted);
  EXPECT_TRUE(admitted->p_WP_m.isApprox(Eigen::Vector3d(2.0, 0.0, -1.0), 1e-12))
      << admitted->p_WP_m.transpose();
  const EnvelopeCounts& counts = envelope.counts();
  EXPECT_EQ(counts.commands, 2u);
  EXPECT_EQ(counts.clamped, 1u);
  EXPECT_EQ(counts.outside_geofence, 1u);
  EXPECT_EQ(counts.too_fast, 1u);
  // much later: the speed allows it, the fence does not
  const auto later = envelope.Admit(100.0, {{1e6, -1e6, 3.0}, Eigen::Quaterniond::Identity()}, false);
  ASSERT_TRUE(later);
  EXPECT_TRUE(later->p_WP_m.isApprox(Eigen::Vector3d(5.0, -5.0, 0.0), 1e-12));
}

TEST(FlightEnvelope, CutsTheTiltToItsLimitAndKeepsTheHeading) {
  FlightEnvelope envelope(Lab());
  const Eigen::Quaterniond tilted = Eigen::AngleAxisd(1.2, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(70.0 * kDeg, Eigen::Vector3d::UnitY());
  const auto admitted = envelope.Admit(0.0, {{0.0, 0.0, -1.0}, tilted}, false);
  ASSERT_TRUE(admitted);
  EXPECT_NEAR(TiltOf(admitted->q_WP), 30.0 * kDeg, 1e-9);
  EXPECT_NEAR(HeadingOf(admitted->q_WP), 1.2, 1e-9);
  EXPECT_EQ(envelope.counts().too_tilted, 1u);
}

TEST(FlightEnvelope, AFiveDofReferenceHasItsXAxisElevationLimited) {
  FlightEnvelope envelope(Lab());
  // x axis pitched 50 deg up, rolled freely about x: only the elevation counts
  const Eigen::Quaterniond q = Eigen::AngleAxisd(50.0 * kDeg, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX());
  const auto admitted = envelope.Admit(0.0, {{0.0, 0.0, -1.0}, q}, true);
  ASSERT_TRUE(admitted);
  const Eigen::Vector3d x = admitted->q_WP.toRotationMatrix().col(0);
  EXPECT_NEAR(std::asin(std::abs(x.z())), 30.0 * kDeg, 1e-9);
  EXPECT_LT(x.z(), 0.0);  // still pointing up (NED)
  EXPECT_TRUE(envelope.Admit(
      1.0, {{0.0, 0.0, -1.0}, Eigen::Quaterniond(Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitX()))}, true));
  EXPECT_EQ(envelope.counts().too_tilted, 1u);
}

TEST(FlightEnvelope, RejectsInsteadWhenToldAndThePreviousCommandHolds) {
  FlightEnvelopeConfig config = Lab();
  config.action = FlightEnvelopeConfig::Action::kReject;
  FlightEnvelope envelope(config);
  ASSERT_TRUE(envelope.Admit(0.0, {{0.0, 0.0, -1.0}, Eigen::Quaterniond::Identity()}, false));
  EXPECT_FALSE(envelope.Admit(0.1, {{0.0, 0.0, -1e6}, Eigen::Quaterniond::Identity()}, false));
  // the speed is measured from the last admitted command
  EXPECT_FALSE(envelope.Admit(0.2, {{1.0, 0.0, -1.0}, Eigen::Quaterniond::Identity()}, false));
  EXPECT_TRUE(envelope.Admit(0.5, {{0.9, 0.0, -1.0}, Eigen::Quaterniond::Identity()}, false));
  EXPECT_EQ(envelope.counts().rejected, 2u);
  EXPECT_EQ(envelope.counts().clamped, 0u);
}

TEST(FlightEnvelope, ReadsItsSectionAndNamesBadKeys) {
  YAML::Node node = YAML::Load(
      "geofence_min_m: [-1, -2, -3]\ngeofence_max_m: [1, 2, 0]\nmax_speed_mps: 1.5\nmax_tilt_deg: 20\n"
      "action: reject\n");
  bridge::YamlMap map(node, "s.yaml", "envelope");
  const FlightEnvelopeConfig config = ReadFlightEnvelope(map);
  map.Finish();
  EXPECT_EQ(config.geofence_min_W_m, Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(config.geofence_max_W_m, Eigen::Vector3d(1, 2, 0));
  EXPECT_DOUBLE_EQ(config.max_speed_mps, 1.5);
  EXPECT_DOUBLE_EQ(config.max_tilt_rad, 20.0 * kDeg);
  EXPECT_EQ(config.action, FlightEnvelopeConfig::Action::kReject);
  YAML::Node inverted = YAML::Load("geofence_min_m: [0, 0, 0]\ngeofence_max_m: [1, 1, 0]\n");
  bridge::YamlMap bad(inverted, "s.yaml", "envelope");
  try {
    ReadFlightEnvelope(bad);
    ADD_FAILURE() << "an empty geofence was accepted";
  } catch (const bridge::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("envelope.geofence_max_m: must exceed geofence_min_m"),
              std::string::npos)
        << e.what();
  }
}

// A trajectory that leaves the envelope is found at the first sample outside it.
class Line : public Trajectory {
 public:
  PoseReference Sample(double t_s) const override {
    PoseReference r;
    r.p_WP_m = {3.0 * t_s, 0.0, -1.0};
    r.v_WP_W_mps = {3.0, 0.0, 0.0};
    return r;
  }
  double duration_s() const override { return 10.0; }
};

TEST(FlightEnvelope, ChecksAConfiguredTrajectory) {
  FlightEnvelopeConfig config = Lab();
  config.max_speed_mps = 5.0;
  EXPECT_NE(
      FlightEnvelope(config).Check(Line(), 10.0, 0.5).find("at t = 2 s: position [6, 0, -1] m is outside"),
      std::string::npos);
  config.max_speed_mps = 2.0;
  EXPECT_NE(FlightEnvelope(config).Check(Line(), 1.0, 0.5).find("at t = 0 s: speed 3 m/s exceeds"),
            std::string::npos);
  config.max_speed_mps = 5.0;
  EXPECT_EQ(FlightEnvelope(config).Check(Line(), 1.0, 0.5), "");  // at most 3 m out, at 3 m/s
}

}  // namespace
}  // namespace iapsim::control
