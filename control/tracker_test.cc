#include "control/tracker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "control/control_config.h"
#include "control/iap_controller.h"

namespace iapsim::control {
namespace {

constexpr double kGravity = 9.81;
constexpr double kDt = 0.005;

model::Vehicle Shipped(const std::string& name) {
  return model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/" + name + ".yaml");
}

Vector6d Gravity(const model::Vehicle& vehicle, const Eigen::Matrix3d& R_WP) {
  const Eigen::Vector3d weight_P =
      vehicle.TotalMass_kg() * kGravity * (R_WP.transpose() * Eigen::Vector3d::UnitZ());
  Vector6d G;
  G << weight_P, vehicle.CenterOfMass_P_m().cross(weight_P);
  return G;
}

TEST(LumpedInertia, ThreeStarMatchesEquationThree) {
  // d_c = 0 and point-mass sub-aircraft: J = J_0 − Σ m_i (d_i^)² exactly.
  const model::Vehicle v = Shipped("three_star");
  Eigen::Matrix3d J = v.platform.inertia_B_kgm2;
  for (const auto& s : v.sub_aircraft) {
    Eigen::Matrix3d hat;
    const Eigen::Vector3d& d = s.joint_P_m;
    hat << 0, -d.z(), d.y(), d.z(), 0, -d.x(), -d.y(), d.x(), 0;
    J -= s.mass.mass_kg * hat * hat;
  }
  EXPECT_LT((v.LumpedInertia_P_kgm2() - J).norm(), 1e-12);
}

TEST(Tracker, AtTheReferenceItAsksForMinusG) {
  const model::Vehicle v = Shipped("three_star");
  Tracker tracker(v, TrackerGains(), kGravity);
  PoseReference reference;
  reference.p_WP_m = {1, 2, -3};
  reference.q_WP = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized());
  PlatformState state;
  state.p_WP_m = reference.p_WP_m;
  state.q_WP = reference.q_WP;
  const Vector6d U = tracker.Update(reference, state, Vector6d::Zero(), kDt, true);
  EXPECT_LT((U + Gravity(v, state.q_WP.toRotationMatrix())).norm(), 1e-12);
  EXPECT_LT(tracker.error().e_T.norm(), 1e-12);
}

TEST(Tracker, FeedsTheReferenceAccelerationForward) {
  const model::Vehicle v = Shipped("three_star");
  Tracker tracker(v, TrackerGains(), kGravity);
  PoseReference reference;
  reference.v_WP_W_mps = {0.5, 0, 0};
  reference.a_WP_W_mps2 = {0, 2, 0};
  PlatformState state;
  state.v_WP_P_mps = reference.v_WP_W_mps;
  const Vector6d U = tracker.Update(reference, state, Vector6d::Zero(), kDt, true);
  const Vector6d expected = (Vector6d() << 0, 2 * v.TotalMass_kg(), 0, 0, 0, 0).finished() -
                            Gravity(v, Eigen::Matrix3d::Identity());
  EXPECT_LT((U - expected).norm(), 1e-12);
}

TEST(Tracker, ErrorsFollowTableTwoGainsAndSigns) {
  const model::Vehicle v = Shipped("three_star");
  Tracker tracker(v, TrackerGains(), kGravity);
  PoseReference reference;
  reference.q_WP = Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ());  // 0.01 rad yaw ahead
  PlatformState state;
  state.p_WP_m = {1.0, 0, 0};  // 1 m ahead in x
  state.v_WP_P_mps = {0, 0, 0.5};
  const Vector6d U = tracker.Update(reference, state, Vector6d::Zero(), kDt, false) +
                     Gravity(v, Eigen::Matrix3d::Identity());
  EXPECT_NEAR(U[0], -8.0, 1e-12);                 // k^P_x e_x pushes back
  EXPECT_NEAR(U[2], -5.0 * 0.5, 1e-12);           // k^D_z damps the descent
  EXPECT_NEAR(U[5], 6.0 * std::sin(0.01), 1e-9);  // yaw torque turns toward the reference
}

TEST(Tracker, IntegralIsClampedAndHeldOnRequest) {
  const model::Vehicle v = Shipped("three_star");
  TrackerGains gains;
  Tracker tracker(v, gains, kGravity);
  PoseReference reference;
  PlatformState state;
  state.p_WP_m = {10.0, 0, 0};
  for (int k = 0; k < 1000; ++k) tracker.Update(reference, state, Vector6d::Zero(), kDt, true);
  EXPECT_DOUBLE_EQ(tracker.integral()[0], gains.integral_limit[0]);
  tracker.Reset();
  tracker.Update(reference, state, Vector6d::Zero(), kDt, false);
  EXPECT_EQ(tracker.integral()[0], 0.0);
}

// A position error held 1 s at yaw 0 (1 m·s of integral in x), then the platform and its reference yawed
// 90°: the integral's force, in W, as each frame of the position integral leaves it.
Eigen::Vector3d IntegralForceAfterAYaw_W(PositionIntegralFrame frame) {
  const model::Vehicle v = Shipped("three_star");
  TrackerGains gains;
  gains.kp.setZero();
  gains.kd.setZero();
  gains.position_integral_frame = frame;
  Tracker tracker(v, gains, kGravity);
  PoseReference reference;
  PlatformState state;
  state.p_WP_m = {1.0, 0, 0};
  for (int k = 0; k < 200; ++k) tracker.Update(reference, state, Vector6d::Zero(), kDt, true);
  reference.q_WP = state.q_WP = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  const Eigen::Matrix3d R = state.q_WP.toRotationMatrix();
  const Vector6d U = tracker.Update(reference, state, Vector6d::Zero(), kDt, false) + Gravity(v, R);
  return R * U.head<3>();
}

TEST(Tracker, APlatformIntegralTurnsWithThePlatformAWorldIntegralHoldsItsDirection) {
  // k^I_x = 1 over 1 m·s: 1 N against the error, along −x of W where it was learnt
  EXPECT_LT((IntegralForceAfterAYaw_W(PositionIntegralFrame::kWorld) - Eigen::Vector3d(-1, 0, 0)).norm(),
            1e-9);
  // (10) as written: along −x of P, now −y of W
  EXPECT_LT((IntegralForceAfterAYaw_W(PositionIntegralFrame::kPlatform) - Eigen::Vector3d(0, -1, 0)).norm(),
            1e-9);
}

TEST(ReadControllerConfig, PositionIntegralIsTheSeedsUnlessTheScenarioSaysWorld) {
  const auto read = [](const std::string& yaml) {
    bridge::YamlMap params(YAML::Load(yaml), "scenario.yaml", "processes.control.params");
    return ReadControllerConfig(params).gains.position_integral_frame;
  };
  EXPECT_EQ(read("gravity_mps2: 9.81\n"), PositionIntegralFrame::kPlatform);
  EXPECT_EQ(read("gains: {position_integral: world}\n"), PositionIntegralFrame::kWorld);
  try {
    read("gains: {position_integral: body}\n");
    ADD_FAILURE() << "no error for position_integral: body";
  } catch (const bridge::ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find(
            "processes.control.params.gains.position_integral: must be one of platform, world, got 'body'"),
        std::string::npos)
        << e.what();
  }
}

TEST(Tracker, ExternalWrenchIsCancelled) {
  const model::Vehicle v = Shipped("three_star");
  Tracker tracker(v, TrackerGains(), kGravity);
  const Vector6d F_e = (Vector6d() << 3, -2, 1, 0.5, 0, -0.4).finished();
  const Vector6d U0 = tracker.Update(PoseReference(), PlatformState(), Vector6d::Zero(), kDt, false);
  const Vector6d U1 = tracker.Update(PoseReference(), PlatformState(), F_e, kDt, false);
  EXPECT_LT((U1 - U0 + F_e).norm(), 1e-12);
}

TEST(Tracker, UnderActuatedIgnoresRollAboutTheJointLine) {
  const model::Vehicle v = Shipped("two_line");
  Tracker tracker(v, TrackerGains(), kGravity);
  ASSERT_FALSE(tracker.fully_actuated());
  EXPECT_LT((tracker.tracked_axis_P() - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  PoseReference reference;
  reference.five_dof = true;
  reference.w_WP_P_radps = {2.0, 0, 0};  // a roll rate: no motion of r̄
  PlatformState state;
  state.q_WP = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX());  // rolled 23°, same x axis
  state.w_WP_P_radps = {-1.0, 0, 0};
  tracker.Update(reference, state, Vector6d::Zero(), kDt, true);
  EXPECT_LT(tracker.error().e_T.norm(), 1e-12);
  EXPECT_LT(tracker.error().e_xi.norm(), 1e-12);

  // A pitch error of the x axis is an error, of the sign of the fully-actuated law.
  state.q_WP = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY());
  tracker.Update(reference, state, Vector6d::Zero(), kDt, true);
  EXPECT_NEAR(tracker.error().e_T[4], std::sin(0.1), 1e-12);
  EXPECT_NEAR(tracker.error().e_T[3], 0.0, 1e-12);
}

TEST(Tracker, UnderActuatedFeedsTheDirectionRateForward) {
  const model::Vehicle v = Shipped("three_line");
  Tracker tracker(v, TrackerGains(), kGravity);
  PoseReference reference;
  reference.w_WP_P_radps = {0.7, 0.0, 0.3};  // roll (free) and yaw
  PlatformState state;
  state.w_WP_P_radps = {0.0, 0.0, 0.3};
  tracker.Update(reference, state, Vector6d::Zero(), kDt, false);
  EXPECT_LT(tracker.error().e_xi.norm(), 1e-12);  // the yaw rate turns r̄; the roll rate does not
}

TEST(IapController, HoverCommandsCarryTheWeight) {
  for (const std::string name : {"three_star", "three_square", "two_line", "three_line"}) {
    const model::Vehicle v = Shipped(name);
    IapController controller(v, IapControllerConfig());
    PoseReference reference;
    reference.p_WP_m = {0, 0, -2};
    PlatformState state;
    state.p_WP_m = reference.p_WP_m;
    ASSERT_TRUE(controller.Update(reference, state, Vector6d::Zero(), kDt));
    Eigen::Vector3d total_W = Eigen::Vector3d::Zero();
    for (const auto& sub : controller.output().sub_aircraft) {
      total_W += sub.q_WS * Eigen::Vector3d(0, 0, -sub.thrust_N);  // (18) round trip: thrust along −z_S
    }
    EXPECT_LT((total_W - Eigen::Vector3d(0, 0, -v.TotalMass_kg() * kGravity)).norm(), 1e-9) << name;
    EXPECT_FALSE(controller.output().saturated) << name;
  }
}

TEST(IapController, CommandsPointEachThrustVectorAlongTheAllocation) {
  const model::Vehicle v = Shipped("three_star");
  IapController controller(v, IapControllerConfig());
  PoseReference reference;
  reference.a_WP_W_mps2 = {1.0, -0.5, -0.3};
  reference.q_WP =
      Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX());
  PlatformState state;
  state.q_WP = Eigen::AngleAxisd(0.15, Eigen::Vector3d::UnitZ());
  ASSERT_TRUE(controller.Update(reference, state, Vector6d::Zero(), kDt));
  const ControlOutput& out = controller.output();
  ASSERT_FALSE(out.saturated);
  for (size_t i = 0; i < out.sub_aircraft.size(); ++i) {
    const Eigen::Vector3d commanded_W =
        out.sub_aircraft[i].q_WS * Eigen::Vector3d(0, 0, -out.sub_aircraft[i].thrust_N);
    EXPECT_LT((commanded_W - state.q_WP * out.thrusts_P_N.segment<3>(3 * i)).norm(), 1e-9) << i;
    // yaw policy kReference: the reference's yaw plus the initial yaw
    const double yaw = YawOf(out.sub_aircraft[i].q_WS.toRotationMatrix());
    EXPECT_NEAR(std::remainder(yaw - 0.2 - v.sub_aircraft[i].initial_yaw_rad, 2 * M_PI), 0.0, 1e-9) << i;
  }
}

TEST(IapController, RejectsNonFiniteInputAndHoldsTheLastCommand) {
  const model::Vehicle v = Shipped("three_star");
  IapController controller(v, IapControllerConfig());
  PoseReference reference;
  PlatformState state;
  ASSERT_TRUE(controller.Update(reference, state, Vector6d::Zero(), kDt));
  const ControlOutput before = controller.output();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  reference.p_WP_m.x() = nan;
  EXPECT_FALSE(controller.Update(reference, state, Vector6d::Zero(), kDt));
  reference.p_WP_m.x() = 0;
  state.w_WP_P_radps.y() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(controller.Update(reference, state, Vector6d::Zero(), kDt));
  state.w_WP_P_radps.y() = 0;
  EXPECT_FALSE(controller.Update(reference, state, (Vector6d() << nan, 0, 0, 0, 0, 0).finished(), kDt));
  EXPECT_EQ(controller.rejected_updates(), 3u);
  for (size_t i = 0; i < before.sub_aircraft.size(); ++i) {
    EXPECT_EQ(controller.output().sub_aircraft[i].thrust_N, before.sub_aircraft[i].thrust_N);
    EXPECT_TRUE(controller.output().sub_aircraft[i].q_WS.isApprox(before.sub_aircraft[i].q_WS));
  }
  // before any valid update the output is already a finite level hover
  IapController fresh(v, IapControllerConfig());
  for (const auto& sub : fresh.output().sub_aircraft) EXPECT_GT(sub.thrust_N, 0.0);
}

TEST(IapController, SaturationCutsToTheLimitsAndStopsTheIntegral) {
  const model::Vehicle v = Shipped("three_star");
  IapControllerConfig config;
  IapController controller(v, config);
  PoseReference reference;
  reference.a_WP_W_mps2 = {30.0, 0, -20.0};  // far beyond what the rotors give
  PlatformState state;
  state.p_WP_m = {-5.0, 0, 0};
  ASSERT_TRUE(controller.Update(reference, state, Vector6d::Zero(), kDt));
  EXPECT_TRUE(controller.output().saturated);
  EXPECT_EQ(controller.saturated_updates(), 1u);
  for (size_t i = 0; i < v.sub_aircraft.size(); ++i) {
    const auto& rotors = v.sub_aircraft[i].rotors;
    const Eigen::Vector3d thrust_W = controller.output().thrusts_P_N.segment<3>(3 * i);
    EXPECT_LE(thrust_W.norm(), config.max_thrust_fraction * 4 * rotors.MaxThrust_N() + 1e-9);
    EXPECT_LE(std::acos(-thrust_W.normalized().z()), config.max_tilt_rad + 1e-9);
  }
  const Vector6d integral = controller.tracker().integral();
  ASSERT_TRUE(controller.Update(reference, state, Vector6d::Zero(), kDt));
  EXPECT_EQ(controller.tracker().integral(), integral);  // held while saturated
}

}  // namespace
}  // namespace iapsim::control
