// Interaction control (seed §IV-B, §IV-C) closing the loop on the Bullet IAP in-process: physics at 1 kHz,
// control at 200 Hz, the contact wrench through the sensors' second-order filter (§VI-E) as in the graph.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

#include "control/admittance.h"
#include "control/wrench_control.h"
#include "physics/simulation.h"
#include "sensors/wrench_filter.h"
#include "tests/control/in_process_iap.h"

namespace iapsim::control {
namespace {

using testing::kGravity;
using testing::kPhysicsStep_s;
using testing::kStepsPerControl;
constexpr double kControlStep_s = kStepsPerControl * kPhysicsStep_s;

// The three-star IAP with its 1 m pole along −x at (0, 0, −2), optionally facing a wall.
class PoleIap {
 public:
  explicit PoleIap(const std::vector<physics::WorldObject>& objects = {})
      : vehicle_(testing::LoadTestVehicle("three_star_pole")),
        filter_(sensors::WrenchFilterConfig(), kPhysicsStep_s) {
    sim_ = testing::MakeSimulation(vehicle_, Eigen::Vector3d(0, 0, -2), objects);
  }

  const model::Vehicle& vehicle() const { return vehicle_; }

  PlatformState State() const { return testing::PlatformStateOf(*sim_); }

  /// The contact wrench on the platform through the §VI-E low-pass, in P about its origin.
  const Vector6d& filtered_wrench_P() const { return filtered_P_; }
  double max_raw_force_N() const { return max_raw_force_N_; }

  /// Runs the physics for one control period with `command` held, `force_W_N` pushing the platform.
  void Step(const ControlOutput& command, const Eigen::Vector3d& force_W_N = Eigen::Vector3d::Zero()) {
    for (size_t i = 0; i < vehicle_.sub_aircraft.size(); ++i) {
      physics::SubAircraftSetpoint setpoint;
      setpoint.thrust_N = command.sub_aircraft[i].thrust_N;
      setpoint.q_WS = command.sub_aircraft[i].q_WS;
      ASSERT_TRUE(sim_->SetCommand(0, static_cast<int>(i), setpoint));
    }
    const int platform = sim_->output(0).platform_body;
    for (int s = 0; s < kStepsPerControl; ++s) {
      sim_->mutable_world().AddForce_W(platform, force_W_N);
      sim_->Step();
      const physics::VehicleOutput& out = sim_->output(0);
      Vector6d raw_P;
      raw_P << out.external_force_P_N, out.external_torque_P_Nm;
      max_raw_force_N_ = std::max(max_raw_force_N_, out.external_force_P_N.norm());
      filtered_P_ = filter_.Update(raw_P);
    }
  }

 private:
  model::Vehicle vehicle_;
  std::unique_ptr<physics::Simulation> sim_;
  sensors::WrenchFilter filter_;
  Vector6d filtered_P_ = Vector6d::Zero();
  double max_raw_force_N_ = 0.0;
};

PoseReference Hold(const Eigen::Vector3d& p_WP_m) {
  PoseReference reference;
  reference.p_WP_m = p_WP_m;
  return reference;
}

// §VI-F on Bullet: the baseline flies the pole onto a wall, (21) engages on contact and holds the commanded
// wrench on the axes the contact carries.
// A rigid wall facing +x 5 cm beyond the pole's tip; rough (friction 8 times the vehicle's 0.5: μ 4, as the
// real flight's rough plate): the 4 N sideways command rides on 1.5 N of normal force.
physics::WorldObject RoughWall() {
  physics::WorldObject wall;
  wall.name = "wall";
  wall.shapes.resize(1);
  wall.shapes[0].box_size_m = Eigen::Vector3d(0.2, 4.0, 4.0);
  wall.p_WO_m = Eigen::Vector3d(-1.05 - 0.1, 0.0, -2.0);
  wall.material.friction = 8.0;
  return wall;
}

// §VI-F's command; Table V's k_w^D (2 s, 1 s) acts on the force rate through the §VI-E filter's lag and the
// sub-aircraft's thrust lag; on a rigid contact the loop rings and the IAP bounces off the wall (stable up to
// 0.3 times, diverging at 0.5 times, measured). The scenario and these tests use 0.1 times.
DirectWrenchConfig WallPushConfig() {
  DirectWrenchConfig config;
  config.command_wrench_P << 1.5, 4, 0, 0, 0, -4;
  config.wrench_gains.kd *= 0.1;
  return config;
}

// the reference lies 0.1 m into the wall: the baseline flies the pole onto it (the x error stays, §VI-F)
const Eigen::Vector3d kBeyondTheWall_m(-0.15, 0.0, -2.0);

TEST(Interaction, DirectWrenchControlPushesAWallWithTheCommandedWrench) {
  PoleIap iap({RoughWall()});
  DirectWrenchController controller(iap.vehicle(), IapControllerConfig(), WallPushConfig(), kControlStep_s);
  const PoseReference reference = Hold(kBeyondTheWall_m);
  const double duration_s = 90.0, average_from_s = 80.0;  // the y integral (k_w^I 0.1/s) is slow
  Vector6d mean_P = Vector6d::Zero(), pose_error = Vector6d::Zero();
  double engaged_at_s = -1.0;
  int samples = 0;
  for (int k = 0; k * kControlStep_s < duration_s; ++k) {
    const PlatformState state = iap.State();
    ASSERT_TRUE(controller.Update(reference, state, iap.filtered_wrench_P()));
    if (engaged_at_s < 0 && controller.engaged()) engaged_at_s = k * kControlStep_s;
    iap.Step(controller.output());
    if (k * kControlStep_s >= average_from_s) {
      mean_P += iap.filtered_wrench_P();
      pose_error.head<3>() += state.p_WP_m - reference.p_WP_m;
      pose_error.tail<3>() += Eigen::AngleAxisd(state.q_WP).angle() * Eigen::AngleAxisd(state.q_WP).axis();
      ++samples;
    }
  }
  mean_P /= samples;
  pose_error /= samples;
  std::printf(
      "wall push: engaged at %.2f s; mean wrench over the last %.0f s (P): force [%.3f %.3f %.3f] N, "
      "torque [%.3f %.3f %.3f] N·m; commanded [1.5 4 0] N, [0 0 -4] N·m\n",
      engaged_at_s, duration_s - average_from_s, mean_P[0], mean_P[1], mean_P[2], mean_P[3], mean_P[4],
      mean_P[5]);
  std::printf(
      "           pose error: [%.3f %.3f %.3f] m, rotation vector [%.2f %.2f %.2f] deg; max raw contact "
      "force %.2f N; wrench integral [%.2f %.2f %.2f %.2f %.2f %.2f]\n",
      pose_error[0], pose_error[1], pose_error[2], pose_error[3] * 180 / M_PI, pose_error[4] * 180 / M_PI,
      pose_error[5] * 180 / M_PI, iap.max_raw_force_N(), controller.wrench_pid().integral_term()[0],
      controller.wrench_pid().integral_term()[1], controller.wrench_pid().integral_term()[2],
      controller.wrench_pid().integral_term()[3], controller.wrench_pid().integral_term()[4],
      controller.wrench_pid().integral_term()[5]);
  ASSERT_GT(engaged_at_s, 0.0);
  // the axes the contact carries: normal force, friction along y, and the yaw moment of the tip force;
  // measured 1.501 N, 3.946 N, -3.925 N·m (y and yaw still settle on k_w^I's slow integral)
  EXPECT_NEAR(mean_P[0], 1.5, 0.005);
  EXPECT_NEAR(mean_P[1], 4.0, 0.11);
  EXPECT_NEAR(mean_P[5], -4.0, 0.15);
  EXPECT_EQ(controller.active_controller().rejected_updates(), 0u);
}

// A gust that pulls the IAP off the wall in the middle of the push (6 N away from the wall for 1 s, twice
// what the realistic profile's 4 m/s wind pushes). Released on the lost contact, the baseline flies the pose
// reference beyond the wall again, (21) engages again and holds the command; kept engaged, as the seed's
// (21) is, its wrench error (all of F̄_e, nothing to push on) carries the IAP along the wall and turns it.
constexpr double kNever = std::numeric_limits<double>::infinity();

struct GustOutcome {
  Vector6d mean_P = Vector6d::Zero();  // the filtered wrench over the last 10 s
  double max_yaw_deg = 0.0;            // after the gust
  double back_at_s = kNever;           // when the filtered force is above 1 N again after the gust
  uint64_t releases = 0;
  bool engaged_at_end = false;
};

GustOutcome PushThroughAGust(double release_threshold_N) {
  PoleIap iap({RoughWall()});
  DirectWrenchConfig config = WallPushConfig();
  config.trigger.release_threshold_N = release_threshold_N;
  DirectWrenchController controller(iap.vehicle(), IapControllerConfig(), config, kControlStep_s);
  const PoseReference reference = Hold(kBeyondTheWall_m);
  const double gust_from_s = 30.0, gust_s = 1.0, duration_s = 110.0, average_from_s = 100.0;
  GustOutcome outcome;
  int samples = 0;
  for (int k = 0; k * kControlStep_s < duration_s; ++k) {
    const double t_s = k * kControlStep_s;
    const PlatformState state = iap.State();
    EXPECT_TRUE(controller.Update(reference, state, iap.filtered_wrench_P()));
    const bool gust = t_s >= gust_from_s && t_s < gust_from_s + gust_s;
    iap.Step(controller.output(), gust ? Eigen::Vector3d(6.0, 0.0, 0.0) : Eigen::Vector3d::Zero());
    if (outcome.back_at_s == kNever && t_s >= gust_from_s + gust_s &&
        iap.filtered_wrench_P().head<3>().norm() > 1.0) {
      outcome.back_at_s = t_s;
    }
    if (t_s >= gust_from_s) {
      outcome.max_yaw_deg =
          std::max(outcome.max_yaw_deg, std::abs(YawOf(state.q_WP.toRotationMatrix())) * 180 / M_PI);
    }
    if (t_s >= average_from_s) {
      outcome.mean_P += iap.filtered_wrench_P();
      ++samples;
    }
  }
  outcome.mean_P /= samples;
  outcome.releases = controller.releases();
  outcome.engaged_at_end = controller.engaged();
  std::printf(
      "gust on the wall push, release below %.2f N: %llu releases, engaged at the end: %d; mean wrench over "
      "the "
      "last 10 s (P): force [%.3f %.3f %.3f] N, torque z %.3f N·m; largest yaw after the gust %.1f deg; "
      "pushing (> 1 N) again at %.2f s\n",
      release_threshold_N, static_cast<unsigned long long>(outcome.releases), outcome.engaged_at_end,
      outcome.mean_P[0], outcome.mean_P[1], outcome.mean_P[2], outcome.mean_P[5], outcome.max_yaw_deg,
      outcome.back_at_s);
  return outcome;
}

TEST(Interaction, DirectWrenchControlLetsGoWhenAGustBreaksTheContactAndPushesAgain) {
  const GustOutcome released = PushThroughAGust(ContactTrigger().release_threshold_N);
  EXPECT_GE(released.releases, 1u);
  EXPECT_TRUE(released.engaged_at_end);
  EXPECT_NEAR(released.mean_P[0], 1.5, 0.05);
  EXPECT_NEAR(released.mean_P[1], 4.0, 0.2);
  EXPECT_NEAR(released.mean_P[5], -4.0, 0.25);
  // measured: back on the wall 1.7 s after the gust (12.8 s when held), 29° of yaw at most: the push's yaw
  // moment acts until the sensor's low-pass (§VI-E) has let the force fall below the release threshold
  EXPECT_LT(released.back_at_s, 31.0 + 3.0);
  EXPECT_LT(released.max_yaw_deg, 45.0);
  // the seed's (21), never released: the same gust turns the IAP right round before the pole finds the wall
  const GustOutcome held = PushThroughAGust(0.0);
  EXPECT_EQ(held.releases, 0u);
  EXPECT_GT(held.max_yaw_deg, 90.0);
  EXPECT_GT(held.back_at_s, released.back_at_s + 5.0);
}

TEST(Interaction, AdmittanceMovesTheReferenceByForceOverStiffness) {
  PoleIap iap;
  IapController controller(iap.vehicle(), IapControllerConfig());
  Admittance admittance(AdmittanceConfig(), kControlStep_s);
  const PoseReference nominal = Hold(Eigen::Vector3d(0, 0, -2));
  const Eigen::Vector3d push_W_N(3.0, -2.0, 0.0);
  PoseReference revised;
  const Vector6d push_W = (Vector6d() << push_W_N, Eigen::Vector3d::Zero()).finished();
  for (int k = 0; k * kControlStep_s < 20.0; ++k) {
    const PlatformState state = iap.State();
    // the admittance yields to the known push and (10) cancels it as its F_e, so the IAP follows the
    // revised reference
    revised = admittance.Update(nominal, push_W);
    ASSERT_TRUE(controller.Update(revised, state, WrenchInP(state.q_WP, push_W), kControlStep_s));
    iap.Step(controller.output(), push_W_N);
  }
  const Eigen::Vector3d expected_m = nominal.p_WP_m + push_W_N / 100.0;  // K_e = 100 N/m (Table IV)
  const Eigen::Vector3d reached_m = iap.State().p_WP_m;
  std::printf(
      "admittance: reference moved by [%.4f %.4f %.4f] m, the IAP by [%.4f %.4f %.4f] m (F/K: [%.3f %.3f "
      "0])\n",
      revised.p_WP_m.x() - nominal.p_WP_m.x(), revised.p_WP_m.y() - nominal.p_WP_m.y(),
      revised.p_WP_m.z() - nominal.p_WP_m.z(), reached_m.x() - nominal.p_WP_m.x(),
      reached_m.y() - nominal.p_WP_m.y(), reached_m.z() - nominal.p_WP_m.z(), push_W_N.x() / 100,
      push_W_N.y() / 100);
  EXPECT_LT((revised.p_WP_m - expected_m).norm(), 1e-6);
  EXPECT_LT((reached_m - expected_m).norm(), 0.0015);  // measured 0.0007 m
}

}  // namespace
}  // namespace iapsim::control
