#include "control/wrench_control.h"

#include <gtest/gtest.h>

#include <cmath>

#include "control/control_config.h"
#include "model/vehicle.h"

namespace iapsim::control {
namespace {

constexpr double kControlStep_s = 0.005;

// One axis of the IAP (5.9 kg, Table V's k^P, k^D on x) against a wall at x = 0 that it meets moving
// toward −x: a stiff spring-damper pushing along +x (the wrench on the IAP, F_e,x > 0). The reference sits
// on the wall's surface, so only the wrench loop makes the IAP push. `literal` closes (21) as written,
// e_w = F_e − F̄_e. Returns F_e,x after `duration_s` (or the largest |F_e,x| seen when it diverges).
double PushAgainstWall(double command_N, bool literal, double duration_s, double* max_force_N) {
  const double mass_kg = 5.9, kp = 7.0, kd = 20.0, wall_N_per_m = 5000.0, wall_Ns_per_m = 50.0;
  WrenchPid pid(WrenchPidGains(), kControlStep_s);
  double x_m = 0.01, v_mps = 0.0, force_N = 0.0, u_N = 0.0;
  *max_force_N = 0.0;
  const int substeps = 50;
  const double h = kControlStep_s / substeps;
  for (int k = 0; k * kControlStep_s < duration_s; ++k) {
    Vector6d measured = Vector6d::Zero(), command = Vector6d::Zero();
    measured[0] = force_N;
    command[0] = command_N;
    const double sign = literal ? -1.0 : 1.0;  // −e_w of the literal law is e_w of the implemented one
    const Vector6d w = pid.Update(sign * measured, sign * command, true);
    u_N = -kp * x_m - kd * v_mps - w[0];
    for (int s = 0; s < substeps; ++s) {
      force_N = x_m < 0.0 ? std::max(0.0, -wall_N_per_m * x_m - wall_Ns_per_m * v_mps) : 0.0;
      v_mps += (u_N + force_N) / mass_kg * h;
      x_m += v_mps * h;
      *max_force_N = std::max(*max_force_N, std::abs(force_N));
    }
    if (std::abs(x_m) > 10.0) break;
  }
  return force_N;
}

TEST(WrenchPid, TheContactWrenchReachesTheCommandInItsDirection) {
  double max_force_N = 0.0;
  const double force_N = PushAgainstWall(1.5, false, 120.0, &max_force_N);
  std::printf("wall push, implemented sign: F_e,x = %.4f N for 1.5 N commanded (max %.3f N)\n", force_N,
              max_force_N);
  EXPECT_NEAR(force_N, 1.5, 0.015);
  EXPECT_LT(max_force_N, 4.0);  // the first touch overshoots
  // taken literally, (21) backs the IAP off the wall (a command it feels too little of raises U_x)
  const double literal_N = PushAgainstWall(1.5, true, 120.0, &max_force_N);
  std::printf("wall push, literal (21): F_e,x = %.4f N, max %.3f N\n", literal_N, max_force_N);
  EXPECT_GT(std::abs(literal_N - 1.5), 1.0);
}

TEST(WrenchPid, ErrorIsCommandMinusMeasurementAndTheIntegralIsClamped) {
  WrenchPidGains gains;
  WrenchPid pid(gains, kControlStep_s);
  const Vector6d measured = (Vector6d() << 1, 2, 3, 0.1, 0.2, 0.3).finished();
  const Vector6d command = (Vector6d() << 1.5, 4, 0, 0, 0, -4).finished();
  // a constant measurement: no derivative, so the first output is k_w^P e_w + k_w^I e_w dt
  const Vector6d w = pid.Update(measured, command, true);
  EXPECT_TRUE(pid.error_P().isApprox(command - measured));
  EXPECT_TRUE(w.isApprox(gains.kp.cwiseProduct(command - measured) +
                         gains.ki.cwiseProduct(command - measured) * kControlStep_s));
  // held integral, then the clamp
  pid.Update(measured, command, false);
  EXPECT_TRUE(pid.integral_term().isApprox(gains.ki.cwiseProduct(command - measured) * kControlStep_s));
  pid.SetIntegralTerm(Vector6d::Constant(1e3));
  EXPECT_TRUE(pid.integral_term().isApprox(gains.integral_limit));
  // the derivative acts on the measurement only: a command step does not kick it
  WrenchPid fresh(gains, kControlStep_s);
  fresh.Update(measured, Vector6d::Zero(), false);
  const Vector6d stepped = fresh.Update(measured, command, false);
  EXPECT_TRUE(stepped.isApprox(gains.kp.cwiseProduct(command - measured)));
}

TEST(WrenchPid, AWrenchInWIsExpressedInTheRotatedPlatformFrame) {
  // platform yawed 90° and pitched 30°: a force along W's x is along −y_P... checked through R_WP
  const Eigen::Quaterniond q_WP = AttitudeFromEuler(0.1, 30 * M_PI / 180, M_PI / 2);
  const Vector6d command_P = (Vector6d() << 1.5, 4, 0, 0, 0, -4).finished();
  const Eigen::Matrix3d R_WP = q_WP.toRotationMatrix();
  Vector6d measured_W;
  measured_W << R_WP * command_P.head<3>(), R_WP * command_P.tail<3>();
  // the same wrench measured in W: once in P, no error is left
  const Vector6d measured_P = WrenchInP(q_WP, measured_W);
  EXPECT_LT((measured_P - command_P).norm(), 1e-12);
  WrenchPid pid(WrenchPidGains(), kControlStep_s);
  EXPECT_LT(pid.Update(measured_P, command_P, true).norm(), 1e-12);
  // while read as if it were in P, it would be an error of several newtons
  EXPECT_GT((measured_W - command_P).norm(), 3.0);
  // yawed by 90°: W's x is the platform's −y
  Vector6d along_x_W = Vector6d::Zero();
  along_x_W[0] = 1.0;
  const Vector6d in_P = WrenchInP(AttitudeFromEuler(0, 0, M_PI / 2), along_x_W);
  EXPECT_NEAR(in_P[1], -1.0, 1e-12);
  // and back to W, for the admittance, which works in W
  EXPECT_LT((WrenchInW(q_WP, measured_P) - measured_W).norm(), 1e-12);
}

TEST(DirectWrenchController, SwitchesOnContactWithUContinuousUpToTheDampingStep) {
  const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  DirectWrenchConfig config;
  config.command_wrench_P << 1.5, 4, 0, 0, 0, -4;
  config.trigger.hold_s = 1.0;  // the PID's filter (0.05 s) has settled: its derivative term is negligible
  DirectWrenchController controller(vehicle, IapControllerConfig(), config, kControlStep_s);
  // a pose and velocity error, so Table II and Table V gains give different U
  PoseReference reference;
  reference.p_WP_m << -0.1, 0.05, -2.0;
  reference.q_WP = AttitudeFromEuler(0.0, 0.05, 0.1);
  PlatformState state;
  state.p_WP_m << 0.0, 0.0, -2.0;
  state.v_WP_P_mps << -0.05, 0.02, 0.0;
  Vector6d contact_P = (Vector6d() << 1.0, 0.5, 0.0, 0.0, 0.0, -0.5).finished();
  Vector6d previous_U = Vector6d::Zero();
  double change_before = 0.0, max_change_after = 0.0;
  Vector6d switch_jump = Vector6d::Zero();
  int switched_at = -1;
  Vector6d command_at_switch = Vector6d::Zero();
  for (int k = 0; k < 700; ++k) {
    ASSERT_TRUE(controller.Update(reference, state, k >= 40 ? contact_P : Vector6d::Zero()));
    const Vector6d U = controller.output().wrench_P;
    if (switched_at < 0 && controller.engaged()) {
      switched_at = k;
      switch_jump = U - previous_U;
      command_at_switch = controller.command_wrench_P();
    } else if (switched_at >= 0) {
      max_change_after = std::max(max_change_after, (U - previous_U).norm());
    } else {
      change_before = (U - previous_U).norm();  // the baseline's integral, k^I e_T dt per step
    }
    previous_U = U;
  }
  // the filtered force needs a few steps to pass 0.5 N, then the hold
  std::printf(
      "engaged at step %d; change of U per step: %.2e before, %.2e at the switch, at most %.4f after\n",
      switched_at, change_before, switch_jump.norm(), max_change_after);
  EXPECT_GT(switched_at, 40 + 1.0 / kControlStep_s - 1);
  EXPECT_LT(switched_at, 40 + 1.0 / kControlStep_s + 10);
  // what the switch would cost without the transfer: Table V's (21) from a zero wrench integral
  IapControllerConfig direct_config;
  direct_config.gains = config.gains;
  IapController direct(vehicle, direct_config);
  direct.Update(reference, state, config.wrench_gains.kp.cwiseProduct(config.command_wrench_P - contact_P),
                kControlStep_s);
  IapController baseline(vehicle, IapControllerConfig());
  baseline.Update(reference, state, Vector6d::Zero(), kControlStep_s);
  const double unbumped = (direct.output().wrench_P - baseline.output().wrench_P).norm();
  std::printf("without bumpless transfer U would jump by %.3f\n", unbumped);
  EXPECT_GT(unbumped, 1.0);
  // the static part carries over; U steps only by the difference of the damping terms −k^D e_ξ of Table V
  // and Table II (a transient the transfer must not bake into the wrench integral), plus one integral step
  // of each law
  const Vector6d damping_step = -(config.gains.kd - IapControllerConfig().gains.kd)
                                     .cwiseProduct(controller.active_controller().tracker().error().e_xi);
  std::printf("jump at the switch %.4f, the damping step %.4f\n", switch_jump.norm(), damping_step.norm());
  EXPECT_GT(damping_step.norm(), 0.1);
  EXPECT_LT((switch_jump - damping_step).norm(), 2.5 * change_before);
  EXPECT_LT(max_change_after, 0.02 * unbumped);
  // the command ramps from the wrench measured at the switch to F̄_e over command_ramp_s (2 s)
  EXPECT_LT((command_at_switch - contact_P).norm(), 1e-12);
  EXPECT_LT((controller.command_wrench_P() - config.command_wrench_P).norm(), 1e-12);
}

TEST(DirectWrenchController, ReleasesOnALostContactToTheBaselineAsItLastFlewAndEngagesAgain) {
  const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  DirectWrenchConfig config;
  config.command_wrench_P << 1.5, 4, 0, 0, 0, -4;
  config.trigger.hold_s = 1.0;  // the PID's filter has settled at each switch: no wrench damping step
  DirectWrenchController controller(vehicle, IapControllerConfig(), config, kControlStep_s);
  // the baseline alone, fed what the controller's baseline sees while it approaches
  IapController baseline(vehicle, IapControllerConfig());
  PoseReference reference;
  reference.p_WP_m << -0.1, 0.05, -2.0;
  PlatformState state;
  state.p_WP_m << 0.0, 0.0, -2.0;
  const Vector6d contact_P = (Vector6d() << 1.0, 0.5, 0.0, 0.0, 0.0, -0.5).finished();
  int k = 0;
  for (; !controller.engaged(); ++k) {
    ASSERT_LT(k, 400);
    ASSERT_TRUE(controller.Update(reference, state, k >= 20 ? contact_P : Vector6d::Zero()));
    baseline.Update(reference, state, Vector6d::Zero(), kControlStep_s);  // the switch's step too
  }
  // pushing on: a brief drop of the force (0.075 s, shorter than the release hold) does not release
  for (int j = 0; j < 400; ++j) {
    ASSERT_TRUE(controller.Update(reference, state, j >= 100 && j < 115 ? Vector6d::Zero() : contact_P));
  }
  EXPECT_TRUE(controller.engaged());
  const Vector6d pushing_integral = controller.wrench_pid().integral_term();
  // the contact is gone: released once the hold (0.1 s) has passed, the wrench integral held meanwhile
  int released_after = -1;
  for (int j = 0; j < 200 && released_after < 0; ++j) {
    ASSERT_TRUE(controller.Update(reference, state, Vector6d::Zero()));
    if (!controller.engaged()) released_after = j + 1;
  }
  std::printf("released %d steps after the contact was lost\n", released_after);
  EXPECT_NEAR(released_after * kControlStep_s, config.trigger.release_hold_s, 0.006);
  EXPECT_EQ(controller.releases(), 1u);
  EXPECT_EQ(controller.wrench_pid().integral_term(), Vector6d::Zero());  // kept aside for the next push
  // the baseline takes over with the integral it had at the switch: U is the lone baseline's next step,
  // without the push
  baseline.Update(reference, state, Vector6d::Zero(), kControlStep_s);
  EXPECT_LT((controller.output().wrench_P - baseline.output().wrench_P).norm(), 1e-12);
  // touching again: engaged after the trigger's hold, the command ramping anew from the measured wrench
  // and (21)'s motion integral started afresh
  int engaged_after = -1;
  Vector6d jump = Vector6d::Zero();
  for (int j = 0; j < 400 && engaged_after < 0; ++j) {
    const Vector6d before = controller.output().wrench_P;
    ASSERT_TRUE(controller.Update(reference, state, contact_P));
    if (controller.engaged()) engaged_after = j + 1;
    jump = controller.output().wrench_P - before;
  }
  EXPECT_GT(engaged_after * kControlStep_s, config.trigger.hold_s);
  EXPECT_LT(engaged_after * kControlStep_s, config.trigger.hold_s + 0.05);
  EXPECT_LT((controller.command_wrench_P() - contact_P).norm(), 1e-12);
  const Vector6d one_step = controller.active_controller().tracker().error().e_T * kControlStep_s;
  EXPECT_LT((controller.active_controller().tracker().integral() - one_step).norm(), 1e-12);
  EXPECT_EQ(controller.releases(), 1u);
  // bumpless again (the state is at rest: no damping step), while the integral is to go back to where
  // (21) left it over the command's ramp: with the measurement following the command, nothing else is
  // integrated
  std::printf("U jumps by %.2e at the second switch\n", jump.norm());
  EXPECT_LT(jump.norm(), 0.01);
  EXPECT_GT((controller.wrench_pid().integral_term() - pushing_integral).norm(), 0.1);
  for (int j = 0; j * kControlStep_s <= config.command_ramp_s; ++j) {
    ASSERT_TRUE(controller.Update(reference, state, controller.command_wrench_P()));
  }
  EXPECT_LT((controller.wrench_pid().integral_term() - pushing_integral).norm(), 5e-3);
}

TEST(DirectWrenchController, WithoutARampTheIntegralReturnsAtOnce) {
  const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  DirectWrenchConfig config;
  config.command_wrench_P << 1.5, 4, 0, 0, 0, -4;
  config.command_ramp_s = 0.0;
  DirectWrenchController controller(vehicle, IapControllerConfig(), config, kControlStep_s);
  PoseReference reference;
  PlatformState state;
  const Vector6d contact_P = (Vector6d() << 1.0, 0.5, 0.0, 0.0, 0.0, -0.5).finished();
  for (int k = 0; k < 400; ++k) ASSERT_TRUE(controller.Update(reference, state, contact_P));
  ASSERT_TRUE(controller.engaged());
  const Vector6d pushing_integral = controller.wrench_pid().integral_term();
  for (int k = 0; k < 40; ++k) ASSERT_TRUE(controller.Update(reference, state, Vector6d::Zero()));
  ASSERT_EQ(controller.releases(), 1u);
  int k = 0;
  for (; !controller.engaged(); ++k) {
    ASSERT_LT(k, 100);
    ASSERT_TRUE(controller.Update(reference, state, contact_P));
  }
  // bumpless at the switch, then all of it back on the next step (one step of k_w^I e_w dt aside)
  ASSERT_TRUE(controller.Update(reference, state, contact_P));
  EXPECT_GT(pushing_integral.norm(), 0.1);
  EXPECT_LT((controller.wrench_pid().integral_term() - pushing_integral).norm(), 0.01);
}

TEST(DirectWrenchController, WithAZeroReleaseThresholdStaysEngagedAsTheSeedFliesIt) {
  const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  DirectWrenchConfig config;
  config.command_wrench_P << 1.5, 4, 0, 0, 0, -4;
  config.trigger.release_threshold_N = 0.0;
  DirectWrenchController controller(vehicle, IapControllerConfig(), config, kControlStep_s);
  PoseReference reference;
  PlatformState state;
  const Vector6d contact_P = (Vector6d() << 1.0, 0.5, 0.0, 0.0, 0.0, -0.5).finished();
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(controller.Update(reference, state, contact_P));
  ASSERT_TRUE(controller.engaged());
  for (int k = 0; k < 1000; ++k) ASSERT_TRUE(controller.Update(reference, state, Vector6d::Zero()));
  EXPECT_TRUE(controller.engaged());
  EXPECT_EQ(controller.releases(), 0u);
}

TEST(DirectWrenchController, ReadsItsSection) {
  bridge::YamlMap params(
      YAML::Load(
          "wrench_control: {command_force_N: [1.5, 4, 0], command_torque_Nm: [0, 0, -4],\n"
          "  gains: {kp: [1, 2, 3, 4, 5, 6]}, wrench_gains: {ki: [0, 0, 0, 0, 0, 1]},\n"
          "  trigger: {force_threshold_N: 0.8, hold_s: 0.3, release_threshold_N: 0.4, release_hold_s: 0.5}}"),
      "s.yaml");
  const DirectWrenchConfig config = ReadDirectWrenchConfig(params);
  EXPECT_TRUE(config.command_wrench_P.isApprox((Vector6d() << 1.5, 4, 0, 0, 0, -4).finished()));
  EXPECT_EQ(config.gains.kp[5], 6.0);
  EXPECT_EQ(config.gains.kd[0], 20.0);  // Table V
  EXPECT_EQ(config.wrench_gains.ki[5], 1.0);
  EXPECT_EQ(config.wrench_gains.kd[0], 2.0);
  EXPECT_EQ(config.trigger.hold_s, 0.3);
  EXPECT_EQ(config.trigger.release_threshold_N, 0.4);
  EXPECT_EQ(config.trigger.release_hold_s, 0.5);
  bridge::YamlMap bad(YAML::Load("wrench_control: {command_force_N: [1, 2]}"), "s.yaml");
  EXPECT_THROW(ReadDirectWrenchConfig(bad), bridge::ConfigError);
  // a release threshold at or above the trigger's would release and engage on the same force
  bridge::YamlMap chattering(YAML::Load("wrench_control: {trigger: {release_threshold_N: 0.5}}"), "s.yaml");
  try {
    ReadDirectWrenchConfig(chattering);
    ADD_FAILURE() << "a release threshold equal to the trigger's was accepted";
  } catch (const bridge::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("wrench_control.trigger.release_threshold_N"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("force_threshold_N"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace iapsim::control
