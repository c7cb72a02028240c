// Rotor and motor model, mixer priorities, and the flight controller on a free quadrotor.
#include <gtest/gtest.h>

#include <cmath>

#include "model/vehicle.h"
#include "physics/flight_controller.h"
#include "physics/multibody_world.h"
#include "physics/rotor.h"

namespace iapsim::physics {
namespace {

model::SubAircraft F450() {
  const model::Vehicle vehicle = model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  return vehicle.sub_aircraft[0];
}

TEST(Rotors, ThrustAndTorqueFollowTheQuadraticLaw) {
  const model::SubAircraft sub = F450();
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  const double k_f = sub.rotors.thrust_coefficient, k_m = sub.rotors.torque_coefficient;
  RotorVector speeds(4);
  speeds << 600.0, 600.0, 600.0, 600.0;
  rotors.SetSpeeds(speeds);
  Eigen::Vector3d force, torque;
  rotors.Wrench_S(&force, &torque);
  EXPECT_NEAR(force.z(), -4.0 * k_f * 600.0 * 600.0, 1e-12);  // along −z_S (up)
  EXPECT_NEAR(force.head<2>().norm(), 0.0, 1e-15);
  EXPECT_NEAR(torque.norm(), 0.0, 1e-12);  // symmetric layout, cancelling spins

  // one faster rotor (1: front-right, spinning CCW): rolls left (−x), pitches up (+y), yaws right (+z)
  speeds[0] = 800.0;
  rotors.SetSpeeds(speeds);
  rotors.Wrench_S(&force, &torque);
  const double extra = k_f * (800.0 * 800.0 - 600.0 * 600.0);
  const double arm = 0.225 / std::sqrt(2.0);
  EXPECT_NEAR(torque.x(), -arm * extra, 1e-12);
  EXPECT_NEAR(torque.y(), arm * extra, 1e-12);
  EXPECT_NEAR(torque.z(), k_m * (800.0 * 800.0 - 600.0 * 600.0), 1e-12);
}

TEST(Rotors, MotorsFollowAFirstOrderLagAndSaturate) {
  const model::SubAircraft sub = F450();
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  const double tau = sub.rotors.motor_time_constant_s;
  rotors.SetSpeeds(RotorVector::Constant(4, 200.0));
  const double dt = 0.001;
  for (int k = 0; k < 20; ++k) rotors.Step(RotorVector::Constant(4, 900.0), dt);
  EXPECT_NEAR(rotors.speeds_rad_s()[0], 900.0 - 700.0 * std::exp(-0.02 / tau), 1e-9);
  for (int k = 0; k < 2000; ++k) rotors.Step(RotorVector::Constant(4, 5000.0), dt);
  EXPECT_NEAR(rotors.speeds_rad_s()[2], sub.rotors.max_speed_rad_s, 1e-9);
  for (int k = 0; k < 2000; ++k) rotors.Step(RotorVector::Constant(4, 0.0), dt);
  EXPECT_NEAR(rotors.speeds_rad_s()[3], sub.rotors.min_speed_rad_s, 1e-9);
}

TEST(Rotors, MixerIsExactInsideTheLimitsAndKeepsTiltOverYaw) {
  const model::SubAircraft sub = F450();
  Rotors rotors(sub.rotors, Eigen::Vector3d(0.0, 0.0, 0.01));
  RotorVector thrusts, speeds;
  const Eigen::Vector3d torque(0.3, -0.2, 0.05);
  EXPECT_FALSE(rotors.Mix(18.0, torque, &thrusts).any());
  rotors.SpeedsForThrusts(thrusts, &speeds);
  rotors.SetSpeeds(speeds);
  Eigen::Vector3d force, made;
  rotors.Wrench_S(&force, &made);
  EXPECT_NEAR(-force.z(), 18.0, 1e-9);
  EXPECT_LT((made - torque).norm(), 1e-9);

  // a yaw demand no motor can meet is cut; roll and thrust survive
  const MixerCut cut = rotors.Mix(18.0, Eigen::Vector3d(0.3, 0.0, 5.0), &thrusts);
  EXPECT_TRUE(cut.yaw);
  EXPECT_FALSE(cut.roll_pitch);
  EXPECT_FALSE(cut.thrust);
  rotors.SpeedsForThrusts(thrusts, &speeds);
  rotors.SetSpeeds(speeds);
  rotors.Wrench_S(&force, &made);
  EXPECT_NEAR(made.x(), 0.3, 1e-9);
  EXPECT_NEAR(-force.z(), 18.0, 1e-9);
  EXPECT_GT(made.z(), 0.0);
  EXPECT_LT(made.z(), 5.0);
  for (int j = 0; j < 4; ++j) {
    EXPECT_LE(thrusts[j], rotors.max_thrust_N() + 1e-12);
    EXPECT_GE(thrusts[j], rotors.min_thrust_N() - 1e-12);
  }
}

// The mixer's order, axis by axis alone and in pairs: yaw is given up first, then the collective thrust,
// and roll/pitch last (PX4's mixer: a quadrotor keeps its attitude).
TEST(Rotors, MixerGivesUpYawThenThrustThenRollPitch) {
  const model::SubAircraft sub = F450();
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  const double hover_N = 15.0, max_N = 4.0 * rotors.max_thrust_N();
  // what the rotors make of a demand: collective thrust and torque
  const auto made = [&](double thrust_N, const Eigen::Vector3d& torque_S, MixerCut* cut) {
    RotorVector thrusts, speeds;
    *cut = rotors.Mix(thrust_N, torque_S, &thrusts);
    rotors.SpeedsForThrusts(thrusts, &speeds);
    rotors.SetSpeeds(speeds);
    Eigen::Vector3d force, torque;
    rotors.Wrench_S(&force, &torque);
    Eigen::Vector4d out;
    out << -force.z(), torque;
    return out;
  };
  const Eigen::Vector3d roll(1.2, 0.0, 0.0), yaw(0.0, 0.0, 2.0);  // yaw: more than fits on top of a hover
  MixerCut cut;
  // alone
  Eigen::Vector4d out = made(1.5 * max_N, Eigen::Vector3d::Zero(), &cut);
  EXPECT_TRUE(cut.thrust && !cut.roll_pitch && !cut.yaw);
  EXPECT_NEAR(out[0], max_N, 1e-9);
  out = made(0.9 * max_N, roll, &cut);  // roll kept whole, the thrust lowered to make room
  EXPECT_TRUE(cut.thrust && !cut.roll_pitch && !cut.yaw);
  EXPECT_NEAR(out[1], roll.x(), 1e-9);
  EXPECT_LT(out[0], 0.9 * max_N);
  out = made(hover_N, yaw, &cut);
  EXPECT_TRUE(cut.yaw && !cut.thrust && !cut.roll_pitch);
  EXPECT_NEAR(out[0], hover_N, 1e-9);
  EXPECT_GT(out[3], 0.0);
  EXPECT_LT(out[3], yaw.z());
  out = made(hover_N, 5.0 * roll, &cut);  // more roll than the motors' range: roll itself is cut
  EXPECT_TRUE(cut.roll_pitch);
  EXPECT_GT(out[1], roll.x());
  // in pairs: the lower axis gives way, the higher keeps what it had alone
  out = made(hover_N, roll + yaw, &cut);
  EXPECT_TRUE(cut.yaw);
  EXPECT_NEAR(out[1], roll.x(), 1e-9);
  EXPECT_NEAR(out[0], hover_N, 1e-9);
  EXPECT_LT(out[3], made(hover_N, yaw, &cut)[3]);  // less yaw than alone: roll took the motors' room
  out = made(1.5 * max_N, yaw, &cut);
  EXPECT_TRUE(cut.thrust && cut.yaw);
  EXPECT_NEAR(out[0], max_N, 1e-9);
  EXPECT_NEAR(out[3], 0.0, 1e-9);  // every motor at its maximum: no room for yaw
  out = made(1.5 * max_N, roll, &cut);
  EXPECT_TRUE(cut.thrust && !cut.roll_pitch);
  EXPECT_NEAR(out[1], roll.x(), 1e-9);
  EXPECT_LT(out[0], max_N);
}

// Ground effect against Cheeseman & Bennett's T_IGE / T_OGE = 1 / (1 − (R / 4z)²), worked by hand.
TEST(Rotors, GroundEffectFollowsCheesemanBennettFromHalfARadiusUp) {
  EXPECT_NEAR(CheesemanBennettThrustRatio(0.5), 4.0 / 3.0, 1e-15);
  EXPECT_NEAR(CheesemanBennettThrustRatio(1.0), 16.0 / 15.0, 1e-15);
  EXPECT_NEAR(CheesemanBennettThrustRatio(2.0), 64.0 / 63.0, 1e-15);
  EXPECT_NEAR(CheesemanBennettThrustRatio(4.0), 256.0 / 255.0, 1e-15);
  EXPECT_NEAR(CheesemanBennettThrustRatio(0.3), 4.0 / 3.0, 1e-15);  // held below the formula's range
  EXPECT_NEAR(CheesemanBennettThrustRatio(0.0), 4.0 / 3.0, 1e-15);

  // a ratio scales that rotor's thrust, and so its roll and pitch moments, not its drag torque
  const model::SubAircraft sub = F450();
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  const double k_f = sub.rotors.thrust_coefficient;
  rotors.SetSpeeds(RotorVector::Constant(4, 600.0));
  RotorVector ratio = RotorVector::Ones(4);
  ratio[0] = 1.25;  // front-right
  Eigen::Vector3d force, torque;
  rotors.Wrench_S(ratio, &force, &torque);
  const double thrust = k_f * 600.0 * 600.0, arm = 0.225 / std::sqrt(2.0);
  EXPECT_NEAR(force.z(), -4.25 * thrust, 1e-12);
  EXPECT_NEAR(torque.x(), -arm * 0.25 * thrust, 1e-12);
  EXPECT_NEAR(torque.y(), arm * 0.25 * thrust, 1e-12);
  EXPECT_NEAR(torque.z(), 0.0, 1e-15);
}

// Rotor drag and rolling moment against F = −|ω| c_D v⊥ and M = −spin |ω| c_R v⊥ per rotor, with the
// coefficients RotorS and PX4's x500 publish (parts/f450.yaml), worked by hand.
TEST(Rotors, RotorDragAndRollingMomentFollowTheModelWithItsPublishedCoefficients) {
  const model::SubAircraft sub = F450();
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  const double c_d = 8.06428e-5, c_r = 1e-6, arm = 0.225 / std::sqrt(2.0);
  rotors.SetSpeeds(RotorVector::Constant(4, 800.0));
  Eigen::Vector3d force, torque;
  // flying forward at 5 m/s through still air: 4 × 800 × 8.06428e-5 × 5 = 1.2902848 N back; the drag of
  // the four hubs and the rolling moments of the counter-rotating pairs cancel as moments
  rotors.AirWrench_S(Eigen::Vector3d(5.0, 0.0, 0.0), Eigen::Vector3d::Zero(), &force, &torque);
  EXPECT_NEAR(force.x(), -1.2902848, 1e-12);
  EXPECT_NEAR(force.tail<2>().norm(), 0.0, 1e-15);
  EXPECT_NEAR(torque.norm(), 0.0, 1e-15);
  // climbing: the air flows along the rotor axes, nothing in-plane
  rotors.AirWrench_S(Eigen::Vector3d(0.0, 0.0, -3.0), Eigen::Vector3d::Zero(), &force, &torque);
  EXPECT_EQ(force.norm() + torque.norm(), 0.0);

  // the front-right rotor (CCW) 200 rad/s faster: its advancing blade rolls S about −x (the flight
  // direction), and its extra drag at the hub (+arm, +arm) yaws S about +z
  RotorVector speeds = RotorVector::Constant(4, 800.0);
  speeds[0] = 1000.0;
  rotors.SetSpeeds(speeds);
  rotors.AirWrench_S(Eigen::Vector3d(5.0, 0.0, 0.0), Eigen::Vector3d::Zero(), &force, &torque);
  EXPECT_NEAR(force.x(), -(3.0 * 800.0 + 1000.0) * c_d * 5.0, 1e-12);
  EXPECT_NEAR(torque.x(), -200.0 * c_r * 5.0, 1e-15);
  EXPECT_NEAR(torque.y(), 0.0, 1e-15);
  EXPECT_NEAR(torque.z(), arm * 200.0 * c_d * 5.0, 1e-15);

  // yawing at 2 rad/s in still air: every hub moves tangentially at 2 × 0.225 m/s, a damping torque
  // −4 ω c_D r² w_z
  rotors.SetSpeeds(RotorVector::Constant(4, 800.0));
  rotors.AirWrench_S(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.0, 0.0, 2.0), &force, &torque);
  EXPECT_NEAR(force.norm(), 0.0, 1e-15);
  EXPECT_NEAR(torque.z(), -4.0 * 800.0 * c_d * 0.225 * 0.225 * 2.0, 1e-14);
}

// The wake's momentum flux against an independent computation of the actuator disk's slipstream: the
// axial velocity on the axis, summed numerically from the Biot–Savart law over the vortex rings of a
// semi-infinite cylinder of sheet strength γ = 2 v_h shed from the disk's edge (each ring of width dζ at
// depth ζ induces γ dζ R² / (2 (R² + (d − ζ)²)^{3/2}) at depth d), then continuity (ρ πR² v_h w) and
// T = 2 ρ πR² v_h². Far below, the flux is the thrust: momentum theory's balance.
TEST(Wake, MomentumFluxIsThatOfTheActuatorDisksSlipstream) {
  const double radius_m = 0.127, thrust_N = 5.0, density = 1.225;
  const double area_m2 = M_PI * radius_m * radius_m;
  const double v_h = std::sqrt(thrust_N / (2.0 * density * area_m2));
  for (const double d_over_r : {0.0, 0.25, 0.5, 1.0, 2.0, 5.0, 20.0}) {
    SCOPED_TRACE(d_over_r);
    // over u = (ζ − d) / R from −d/R to U by Simpson's rule, plus the tail ∫_U^∞ du / (2u³) = 1 / (4U²) to
    // leading order
    const double lo = -d_over_r, hi = 400.0;
    const int n = 400000;
    const double h = (hi - lo) / n;
    double sum = 0.0;
    for (int i = 0; i <= n; ++i) {
      const double u = lo + i * h;
      const double f = 0.5 / std::pow(1.0 + u * u, 1.5);
      sum += (i == 0 || i == n ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0)) * f;
    }
    const double w_mps = 2.0 * v_h * (sum * h / 3.0 + 1.0 / (4.0 * hi * hi));
    const double flux_N = density * area_m2 * v_h * w_mps;
    EXPECT_NEAR(WakeMomentumFlux_N(thrust_N, d_over_r * radius_m, radius_m), flux_N, 1e-7 * thrust_N);
  }
  EXPECT_NEAR(WakeMomentumFlux_N(thrust_N, 1e4 * radius_m, radius_m), thrust_N, 1e-8 * thrust_N);
  // the top hat just below the disk is the contracted slipstream: area πR²/2 at 2 v_h carries the thrust
  const double r0_m = WakeRadius_m(0.0, radius_m);
  EXPECT_NEAR(density * M_PI * r0_m * r0_m * 4.0 * v_h * v_h, thrust_N, 1e-12);
  // a round jet widens by 0.094 of the distance in half-velocity radius (Pope); a top hat of the same
  // centreline velocity and momentum flux has a radius √(1 / (2 ln 2)) of it
  EXPECT_NEAR(WakeRadius_m(10.0, radius_m) - r0_m, 10.0 * 0.094 * std::sqrt(1.0 / (2.0 * std::log(2.0))),
              1e-12);
}

// The rays sample the wake's cross-section in cells of equal area: balanced about the axis (a uniform wake
// on a body across all of it turns it about nothing), and with the disk's polar moment (R²/2 per unit
// area) within 1 %, so a body across part of the wake takes close to its share of the flux and moment.
TEST(Wake, CellsTileTheDiskEvenly) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  double polar = 0.0;
  int right = 0;
  for (const Eigen::Vector2d& cell : WakeCells()) {
    EXPECT_LT(cell.norm(), 1.0);
    mean += cell / kWakeCells;
    polar += cell.squaredNorm() / kWakeCells;
    if (cell.x() > 1e-9) ++right;
  }
  EXPECT_LT(mean.norm(), 1e-15);
  EXPECT_NEAR(polar, 0.5, 0.005);
  EXPECT_EQ(right, 9);  // the half-plane x > 0 holds 9 of the 19 cells; the centre sits on its edge
}

TEST(FlightController, AttitudeErrorGivesARateTowardTheSetpoint) {
  const model::SubAircraft sub = F450();
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  FlightController controller(sub.flight_controller, sub.mass.inertia_B_kgm2, rotors);
  const Eigen::Quaterniond level = Eigen::Quaterniond::Identity();
  const Eigen::Quaterniond rolled(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()));
  const Eigen::Vector3d rate = controller.RateSetpoint(rolled, level);
  EXPECT_NEAR(rate.x(), 6.5 * 2.0 * std::sin(0.05), 1e-9);  // P on the quaternion error
  EXPECT_NEAR(rate.y(), 0.0, 1e-12);
  // a yaw error is served at the (lower) yaw gain
  const Eigen::Quaterniond yawed(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()));
  const double yaw_weight = 2.8 / 6.5;  // PX4: the yaw error is scaled into the tilt gain
  EXPECT_NEAR(controller.RateSetpoint(yawed, level).z(), 2.0 * 2.8 / yaw_weight * std::sin(yaw_weight * 0.05),
              1e-9);
}

// A single quadrotor as a one-link multibody, gravity off: the cascade turns it to a 30° roll setpoint.
TEST(FlightController, ReachesAnAttitudeSetpointOnAFreeQuadrotor) {
  const model::SubAircraft sub = F450();
  model::MultibodyDescription description;
  description.name = "quad";
  description.links.push_back({"body", sub.mass, {}, ""});
  WorldConfig config;
  config.gravity_mps2 = 0.0;
  config.ground = false;
  const double dt = 0.001;
  MultibodyWorld world(config, dt);
  const int body = world.AddMultibody("quad", description, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  FlightController controller(sub.flight_controller, sub.mass.inertia_B_kgm2, rotors);
  SubAircraftSetpoint setpoint;
  setpoint.thrust_N = 10.0;
  setpoint.q_WS = Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
  double max_overshoot_rad = 0.0;
  double error_at_1s_rad = 0.0;
  for (int k = 0; k < 5000; ++k) {
    if (k == 1000) error_at_1s_rad = world.body(body).q_WB.angularDistance(setpoint.q_WS);
    const BodyState& state = world.body(body);
    Eigen::Vector3d force_S, torque_S;
    rotors.Wrench_S(&force_S, &torque_S);
    world.AddTorque_W(body, state.q_WB * torque_S);  // no force: keep it in place
    RotorVector thrusts, speeds;
    controller.Update(setpoint, state.q_WB, state.q_WB.conjugate() * state.w_WB_W, Eigen::Vector3d::Zero(),
                      dt, &thrusts);
    rotors.SpeedsForThrusts(thrusts, &speeds);
    rotors.Step(speeds, dt);
    world.Step();
    const double roll = std::atan2(2 * (world.body(body).q_WB.w() * world.body(body).q_WB.x() +
                                        world.body(body).q_WB.y() * world.body(body).q_WB.z()),
                                   1 - 2 * (std::pow(world.body(body).q_WB.x(), 2) + std::pow(world.body(body).q_WB.y(), 2)));
    max_overshoot_rad = std::max(max_overshoot_rad, roll - 0.5236);
  }
  const double error_rad = world.body(body).q_WB.angularDistance(setpoint.q_WS);
  std::printf("30 deg roll + 17 deg yaw step: error %.2f deg after 1 s, %.3f deg after 5 s, overshoot %.2f deg\n",
              error_at_1s_rad * 180.0 / M_PI, error_rad * 180.0 / M_PI, max_overshoot_rad * 180.0 / M_PI);
  EXPECT_LT(error_at_1s_rad, 2.0 * M_PI / 180.0);
  EXPECT_LT(error_rad, 0.1 * M_PI / 180.0);
  EXPECT_LT(max_overshoot_rad, 5.0 * M_PI / 180.0);
}

}  // namespace
}  // namespace iapsim::physics
