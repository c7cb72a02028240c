// The Bullet world and the IAP simulation: kinematics as described, conservation laws, contact forces
// against analytic values, collision filtering, hover.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "bridge/config.h"
#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/multibody_world.h"
#include "physics/physics_config.h"
#include "physics/simulation.h"
#include "physics/wind.h"
#include "tests/support/test_folder.h"

namespace iapsim::physics {
namespace {

model::Vehicle LoadShipped(const std::string& name) {
  return model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/" + name + ".yaml");
}

VehicleSpec Spec(const std::string& name, const Eigen::Vector3d& p_WP_m, double yaw_rad = 0.0) {
  VehicleSpec spec;
  spec.name = "iap";
  spec.vehicle = LoadShipped(name);
  spec.description = model::ParseUrdf(model::GenerateUrdf(spec.vehicle), name + ".urdf");
  spec.p_WP_m = p_WP_m;
  spec.yaw_rad = yaw_rad;
  return spec;
}

TEST(MultibodyWorld, BodiesStartWhereTheVehicleDescriptionPutsThem) {
  for (const std::string name :
       {"three_star", "three_square", "two_line", "three_line", "three_star_fixed"}) {
    SCOPED_TRACE(name);
    SimulationConfig config;
    config.world.ground = false;
    config.vehicles.push_back(Spec(name, Eigen::Vector3d(1.0, -2.0, -3.0), 0.7));
    const Simulation sim(config);
    const MultibodyWorld& world = sim.world();
    const VehicleOutput& out = sim.output(0);
    const Eigen::Quaterniond q_WP(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));
    EXPECT_LT((world.body(out.platform_body).p_WB_m - Eigen::Vector3d(1.0, -2.0, -3.0)).norm(), 1e-12);
    EXPECT_LT(world.body(out.platform_body).q_WB.angularDistance(q_WP), 1e-12);
    const model::Vehicle& vehicle = sim.vehicle(0).vehicle;
    for (size_t i = 0; i < vehicle.sub_aircraft.size(); ++i) {
      const auto& sub = vehicle.sub_aircraft[i];
      const BodyState& state = world.body(out.sub_aircraft_bodies[i]);
      // equation (1): p_i = p_0 + R_0 d_i, and the sub-aircraft's initial yaw relative to P
      EXPECT_LT((state.p_WB_m - (Eigen::Vector3d(1.0, -2.0, -3.0) + q_WP * sub.joint_P_m)).norm(), 1e-12);
      const Eigen::Quaterniond q_WS = q_WP * Eigen::AngleAxisd(sub.initial_yaw_rad, Eigen::Vector3d::UnitZ());
      EXPECT_LT(state.q_WB.angularDistance(q_WS), 1e-12);
    }
    EXPECT_TRUE(world.contacts().empty());
  }
}

// A start with an attitude and a twist (an RL reset): every body where the rotated description puts it,
// moving as one rigid body, v_B = v_P + ω × (p_B − p_P), ω_B = ω.
TEST(MultibodyWorld, AVehicleStartsWithItsAttitudeAndRigidBodyTwist) {
  SimulationConfig config;
  config.world.ground = false;
  VehicleSpec spec = Spec("three_star", Eigen::Vector3d(1.0, -2.0, -3.0), 0.7);
  spec.roll_rad = 0.1;
  spec.pitch_rad = -0.2;
  spec.v_WP_W_mps = Eigen::Vector3d(0.3, -0.1, 0.2);
  spec.w_WP_W_radps = Eigen::Vector3d(0.2, 0.5, -0.4);
  config.vehicles.push_back(spec);
  const Simulation sim(config);
  const MultibodyWorld& world = sim.world();
  const VehicleOutput& out = sim.output(0);
  const Eigen::Quaterniond q_WP = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX());
  const BodyState& platform = world.body(out.platform_body);
  EXPECT_LT(platform.q_WB.angularDistance(q_WP), 1e-12);
  for (const int body : out.sub_aircraft_bodies) {
    const BodyState& state = world.body(body);
    const Eigen::Vector3d r_m = state.p_WB_m - platform.p_WB_m;
    EXPECT_LT((state.v_WB_W - (spec.v_WP_W_mps + spec.w_WP_W_radps.cross(r_m))).norm(), 1e-12);
    EXPECT_LT((state.w_WB_W - spec.w_WP_W_radps).norm(), 1e-12);
  }
  EXPECT_LT((platform.v_WB_W - spec.v_WP_W_mps).norm(), 1e-12);
  EXPECT_LT((platform.w_WB_W - spec.w_WP_W_radps).norm(), 1e-12);
}

// The same start written in a scenario's vehicle entry: degrees in, radians in the spec.
TEST(MultibodyWorld, AVehicleEntryReadsTheStartsAttitudeAndTwist) {
  const std::string vehicle_file = std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml";
  bridge::YamlMap params(
      YAML::Load("vehicles:\n  - {name: iap, file: " + vehicle_file +
                 ", roll_deg: 5.7, pitch_deg: -11.5, yaw_deg: 40, velocity_mps: [0.3, -0.1, 0.2],"
                 " angular_velocity_deg_s: [10, 20, -30]}\n"),
      "test.yaml");
  const VehicleSpec spec = ReadPhysicsConfig(params, "test.yaml", 0.001).simulation.vehicles.at(0);
  EXPECT_DOUBLE_EQ(spec.roll_rad, 5.7 * M_PI / 180.0);
  EXPECT_DOUBLE_EQ(spec.pitch_rad, -11.5 * M_PI / 180.0);
  EXPECT_DOUBLE_EQ(spec.yaw_rad, 40.0 * M_PI / 180.0);
  EXPECT_EQ(spec.v_WP_W_mps, Eigen::Vector3d(0.3, -0.1, 0.2));
  EXPECT_LT((spec.w_WP_W_radps - Eigen::Vector3d(10, 20, -30) * M_PI / 180.0).norm(), 1e-15);
  bridge::YamlMap wrong(YAML::Load("vehicles:\n  - {name: iap, file: " + vehicle_file + ", pitch_deg: 95}\n"),
                        "test.yaml");
  try {
    ReadPhysicsConfig(wrong, "test.yaml", 0.001);
    ADD_FAILURE() << "a pitch of 95 degrees was accepted";
  } catch (const bridge::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("pitch_deg"), std::string::npos) << e.what();
  }
}

// Gravity off, a spin-up with internal torques only, then free flight: linear and angular momentum stay
// what they were, kinetic energy stays put, joints stay together (eq. (1) holds).
TEST(MultibodyWorld, FreeFloatingIapConservesMomentumAndKeepsItsJoints) {
  SimulationConfig config;
  config.world.ground = false;
  config.world.gravity_mps2 = 0.0;
  config.vehicles.push_back(Spec("three_star", Eigen::Vector3d::Zero()));
  config.vehicles[0].initial_rotors = InitialRotors::kIdle;
  Simulation sim(config);
  const VehicleOutput& out = sim.output(0);
  MultibodyWorld& world = sim.mutable_world();
  SubAircraftSetpoint idle;
  idle.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  for (int s = 0; s < 3; ++s) sim.SetCommand(0, s, idle);
  // a push: equal and opposite forces on two sub-aircraft, a joint torque on the third
  for (int k = 0; k < 200; ++k) {
    world.AddForce_W(out.sub_aircraft_bodies[0], Eigen::Vector3d(0.0, 2.0, 0.5));
    world.AddForce_W(out.sub_aircraft_bodies[1], Eigen::Vector3d(0.0, -2.0, -0.5));
    world.AddJointTorque_W(out.sub_aircraft_bodies[2], Eigen::Vector3d(0.05, 0.02, 0.1));
    sim.Step();
  }
  const auto momenta = [&](Eigen::Vector3d* linear, Eigen::Vector3d* angular, double* energy) {
    linear->setZero();
    angular->setZero();
    *energy = 0.0;
    std::vector<int> bodies = out.sub_aircraft_bodies;
    bodies.push_back(out.platform_body);
    for (const int b : bodies) {
      const BodyState& s = world.body(b);
      const double m = world.mass_kg(b);
      const Eigen::Matrix3d R = s.q_WB.toRotationMatrix();
      const Eigen::Matrix3d I_W = R * world.inertia_B_kgm2(b) * R.transpose();
      *linear += m * s.v_WBcom_W;
      *angular += s.p_WBcom_m.cross(m * s.v_WBcom_W) + I_W * s.w_WB_W;
      *energy += 0.5 * m * s.v_WBcom_W.squaredNorm() + 0.5 * s.w_WB_W.dot(I_W * s.w_WB_W);
    }
  };
  Eigen::Vector3d p0, L0, p1, L1;
  double E0, E1;
  momenta(&p0, &L0, &E0);
  ASSERT_GT(L0.norm(), 0.01);  // it does spin
  ASSERT_GT(E0, 0.01);
  double joint_drift_m = 0.0;
  for (int k = 0; k < 5000; ++k) {
    sim.Step();
    const BodyState& platform = world.body(out.platform_body);
    for (size_t i = 0; i < 3; ++i) {
      const Eigen::Vector3d expected =
          platform.p_WB_m + platform.q_WB * sim.vehicle(0).vehicle.sub_aircraft[i].joint_P_m;
      joint_drift_m =
          std::max(joint_drift_m, (world.body(out.sub_aircraft_bodies[i]).p_WB_m - expected).norm());
    }
  }
  momenta(&p1, &L1, &E1);
  std::printf(
      "free-floating three-star, 5 s: |dp| %.2e kg m/s, |dL| %.2e (of %.3f) kg m^2/s, dE/E %.2e, "
      "joint drift %.2e m\n",
      (p1 - p0).norm(), (L1 - L0).norm(), L0.norm(), std::abs(E1 - E0) / E0, joint_drift_m);
  // Bullet integrates joint coordinates (semi-implicit Euler), so momentum holds to O(step), not exactly
  EXPECT_LT((p1 - p0).norm() / sim.vehicle(0).vehicle.TotalMass_kg(), 1e-5);
  EXPECT_LT((L1 - L0).norm(), 1e-3 * L0.norm());
  EXPECT_LT(std::abs(E1 - E0), 1e-2 * E0);
  EXPECT_LT(joint_drift_m, 1e-9);
}

WorldObject Box(const std::string& name, const Eigen::Vector3d& size_m, const Eigen::Vector3d& p_WO_m,
                double mass_kg = 0.0) {
  WorldObject object;
  object.name = name;
  model::Shape shape;
  shape.box_size_m = size_m;
  object.shapes = {shape};
  object.p_WO_m = p_WO_m;
  object.mass_kg = mass_kg;
  return object;
}

// The three-star with P at p_WP_m, its rotors idle and commanded to give nothing: it falls, or rests on
// its sub-aircraft's boxes.
std::unique_ptr<Simulation> UnpoweredThreeStar(SimulationConfig config, const Eigen::Vector3d& p_WP_m,
                                               double drag_area_m2 = 0.0) {
  config.vehicles.push_back(Spec("three_star", p_WP_m));
  config.vehicles[0].initial_rotors = InitialRotors::kIdle;
  // C_d·A per axis on every part (physics/wind.h)
  model::Vehicle& vehicle = config.vehicles[0].vehicle;
  vehicle.platform_drag_area_B_m2 = Eigen::Vector3d::Constant(drag_area_m2);
  for (auto& sub : vehicle.sub_aircraft) sub.drag_area_B_m2 = Eigen::Vector3d::Constant(drag_area_m2);
  auto sim = std::make_unique<Simulation>(config);
  SubAircraftSetpoint off;
  off.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  for (int s = 0; s < 3; ++s) sim->SetCommand(0, s, off);
  return sim;
}

TEST(MultibodyWorld, ABoxAtRestReadsItsWeightAndFrictionOpposesSliding) {
  WorldConfig config;
  WorldObject box = Box("box", Eigen::Vector3d(0.4, 0.4, 0.2), Eigen::Vector3d(0.0, 0.0, -0.1), 2.0);
  box.material.friction = 0.5;
  config.objects = {box};
  MultibodyWorld world(config, 0.001);
  const int id = world.FindBody("box");
  for (int k = 0; k < 500; ++k) world.Step();
  const Eigen::Vector3d force = world.ContactForce_W(id);
  EXPECT_NEAR(force.z(), -2.0 * 9.81, 1e-6);  // the ground pushes up (−z in NED) with the weight
  EXPECT_NEAR(force.head<2>().norm(), 0.0, 1e-6);

  // pushed along +x harder than friction can hold: friction points along −x and equals μ m g. A single
  // step's friction impulse varies (sequential impulses over the manifold's points); its mean over the push
  // is what moved the box.
  Eigen::Vector3d mean_force = Eigen::Vector3d::Zero();
  const int steps = 200;
  for (int k = 0; k < steps; ++k) {
    world.AddForce_W(id, Eigen::Vector3d(15.0, 0.0, 0.0));
    world.Step();
    mean_force += world.ContactForce_W(id) / steps;
  }
  // within 1%: the box rocks a little on its leading edge while it slides
  EXPECT_NEAR(world.body(id).v_WB_W.x(), (15.0 - 0.5 * 2.0 * 9.81) / 2.0 * steps * 0.001, 0.005);
  EXPECT_NEAR(mean_force.x(), -0.5 * 2.0 * 9.81, 0.1);
  EXPECT_NEAR(mean_force.z(), -2.0 * 9.81, 0.2);
}

TEST(Simulation, AnIapRestingOnABoxReadsItsWeightAsExternalWrench) {
  SimulationConfig config;
  // static, top at z = −0.5
  config.world.objects = {Box("stand", Eigen::Vector3d(0.3, 0.3, 0.5), Eigen::Vector3d(0.0, 0.0, -0.25))};
  // platform box 0.05 m tall: its bottom on the stand's top
  auto unpowered = UnpoweredThreeStar(config, Eigen::Vector3d(0.0, 0.0, -0.5 - 0.025 - 0.002));
  Simulation& sim = *unpowered;
  for (int k = 0; k < 3000; ++k) sim.Step();
  const VehicleOutput& out = sim.output(0);
  const double weight_N = sim.vehicle(0).vehicle.TotalMass_kg() * 9.81;
  std::printf("three-star resting on a stand: external force %.4f %.4f %.4f N (weight %.4f N)\n",
              out.external_force_W_N.x(), out.external_force_W_N.y(), out.external_force_W_N.z(), weight_N);
  EXPECT_NEAR(out.external_force_W_N.z(), -weight_N, 1e-3 * weight_N);
  EXPECT_LT(out.external_force_W_N.head<2>().norm(), 1e-3 * weight_N);
  // the stand is under the platform's centre and the IAP is symmetric: no tipping moment
  EXPECT_LT(out.external_torque_W_Nm.head<2>().norm(), 0.02);
  for (const auto& sub : out.sub_aircraft) {  // each joint carries one sub-aircraft's weight
    EXPECT_NEAR(sub.joint_force_P_N.z(), 1.6 * 9.81, 1e-3);
  }
}

// The three-star standing on its sub-aircraft's boxes (12 box-plane contacts): warm started, each step's
// solve starts at the last step's impulses, which already hold the weight, so it ends after an iteration or
// two; solved cold to the same tolerance it needs far more. Both read the weight.
TEST(Simulation, AWarmStartedSolveOfAnIapAtRestEndsInAFewIterations) {
  for (const bool warm_start : {true, false}) {
    SCOPED_TRACE(warm_start);
    SimulationConfig config;
    config.world.warm_start = warm_start;
    config.world.sleep_after_s = 0.0;  // solved every step
    // the boxes (0.10 m tall, centred 0.07 m below P) on the ground
    auto unpowered = UnpoweredThreeStar(config, Eigen::Vector3d(0.0, 0.0, -0.12));
    Simulation& sim = *unpowered;
    for (int k = 0; k < 500; ++k) sim.Step();
    const SolverStats settled = sim.world().solver_stats();
    for (int k = 0; k < 500; ++k) sim.Step();
    const SolverStats& stats = sim.world().solver_stats();
    const double mean_iterations = static_cast<double>(stats.iterations - settled.iterations) /
                                   static_cast<double>(stats.solves - settled.solves);
    const double weight_N = sim.vehicle(0).vehicle.TotalMass_kg() * 9.81;
    std::printf("three-star at rest, %s: %.1f iterations a step, external force %.9f N (weight %.9f N)\n",
                warm_start ? "warm started" : "cold", mean_iterations, -sim.output(0).external_force_W_N.z(),
                weight_N);
    EXPECT_EQ(sim.world().contacts().size(), 12u);
    EXPECT_NEAR(sim.output(0).external_force_W_N.z(), -weight_N, 1e-6 * weight_N);
    EXPECT_EQ(stats.capped_solves, settled.capped_solves);  // the landing may take them all, resting never
    if (warm_start) {
      EXPECT_LE(mean_iterations, 2.0);
    } else {
      EXPECT_GE(mean_iterations, 10.0);
    }
  }
}

// The three-star standing on its boxes with its rotors off falls asleep (no point moving faster than
// sleep_speed_mps for sleep_after_s, same loads) and keeps reading its weight; thrust wakes it and it lifts
// off exactly as a twin that never sleeps does.
TEST(Simulation, AnIapAtRestSleepsAndWakesWhenItsLoadsChange) {
  std::vector<std::unique_ptr<Simulation>> sims;
  for (const double sleep_after_s : {0.5, 0.0}) {
    SimulationConfig config;
    config.world.sleep_after_s = sleep_after_s;
    config.vehicles.push_back(Spec("three_star", Eigen::Vector3d(0.0, 0.0, -0.12)));
    config.vehicles[0].initial_rotors = InitialRotors::kIdle;
    sims.push_back(std::make_unique<Simulation>(config));
  }
  SubAircraftSetpoint off;
  off.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  SubAircraftSetpoint lift = off;
  lift.thrust_W_N = Eigen::Vector3d(0.0, 0.0, -25.0);  // three of them: 75 N against 57.9 N of weight
  for (auto& sim : sims) {
    for (int s = 0; s < 3; ++s) sim->SetCommand(0, s, off);
    for (int k = 0; k < 1000; ++k) sim->Step();
  }
  Simulation& sleeper = *sims[0];
  const int platform = sleeper.output(0).platform_body;
  const double weight_N = sleeper.vehicle(0).vehicle.TotalMass_kg() * 9.81;
  EXPECT_TRUE(sleeper.world().asleep(platform));
  EXPECT_FALSE(sims[1]->world().asleep(platform));
  EXPECT_NEAR(sleeper.output(0).external_force_W_N.z(), -weight_N, 1e-6 * weight_N);
  EXPECT_EQ(sleeper.world().contacts().size(), 12u);
  const double z_asleep_m = sleeper.world().body(platform).p_WB_m.z();
  for (int k = 0; k < 500; ++k) sleeper.Step();  // idle: stays asleep and put
  EXPECT_TRUE(sleeper.world().asleep(platform));
  EXPECT_EQ(sleeper.world().body(platform).p_WB_m.z(), z_asleep_m);

  for (auto& sim : sims) {
    for (int s = 0; s < 3; ++s) sim->SetCommand(0, s, lift);
    for (int k = 0; k < 300; ++k) sim->Step();
  }
  EXPECT_FALSE(sleeper.world().asleep(platform));
  EXPECT_LT(sleeper.world().body(platform).p_WB_m.z(), -0.12 - 0.05);  // climbing
  EXPECT_LT((sleeper.world().body(platform).p_WB_m - sims[1]->world().body(platform).p_WB_m).norm(), 1e-9);
}

// A vehicle with nothing to rest on never sleeps, however still: without contacts to balance them, the
// smallest imbalance of its loads would move it.
TEST(Simulation, AHoveringIapNeverSleeps) {
  SimulationConfig config;
  config.world.ground = false;
  config.vehicles.push_back(Spec("three_star", Eigen::Vector3d(0.0, 0.0, -2.0)));
  config.vehicles[0].initial_rotors = InitialRotors::kIdle;
  Simulation sim(config);
  SubAircraftSetpoint trim;
  trim.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  trim.thrust_W_N = Eigen::Vector3d(0.0, 0.0, -sim.vehicle(0).vehicle.TotalMass_kg() * 9.81 / 3.0);
  for (int s = 0; s < 3; ++s) sim.SetCommand(0, s, trim);
  for (int k = 0; k < 2000; ++k) sim.Step();
  EXPECT_LT(sim.world().body(sim.output(0).platform_body).v_WB_W.norm(), 1e-6);
  EXPECT_FALSE(sim.world().asleep(sim.output(0).platform_body));
}

// A box dropped onto a sleeping IAP wakes it: the island of a moving body is stepped, and the IAP carries the
// box (a movable object never sleeps, so neither does an IAP it rests on).
TEST(Simulation, AFallingBoxWakesASleepingIap) {
  SimulationConfig config;
  // a 0.5 kg box 4.8 m above the platform's top (z = −0.145): it lands after about a second
  config.world.objects = {Box("box", Eigen::Vector3d(0.1, 0.1, 0.1), Eigen::Vector3d(0.0, 0.0, -5.0), 0.5)};
  auto unpowered = UnpoweredThreeStar(config, Eigen::Vector3d(0.0, 0.0, -0.12));
  Simulation& sim = *unpowered;
  const int platform = sim.output(0).platform_body;
  const int box = sim.world().FindBody("box");
  for (int k = 0; k < 900; ++k) sim.Step();
  EXPECT_TRUE(sim.world().asleep(platform));
  for (int k = 0; k < 2100; ++k) sim.Step();
  EXPECT_FALSE(sim.world().asleep(platform));
  EXPECT_NEAR(sim.world().body(box).p_WB_m.z(), -0.145 - 0.05, 1e-3);
  Eigen::Vector3d ground_force_W_N = Eigen::Vector3d::Zero();  // on the ground, from everything on it
  for (const Contact& c : sim.world().contacts()) {
    if (c.body_b == kGround) ground_force_W_N -= c.force_on_a_W_N;
    if (c.body_a == kGround) ground_force_W_N += c.force_on_a_W_N;
  }
  const double weight_N = (sim.vehicle(0).vehicle.TotalMass_kg() + 0.5) * 9.81;
  EXPECT_NEAR(ground_force_W_N.z(), weight_N, 1e-3 * weight_N);
}

// Static bodies never move, so a pair of them is not collided: a static stand on the ground makes no
// contact, while a movable box on it does.
TEST(MultibodyWorld, StaticBodiesTouchingEachOtherMakeNoContacts) {
  WorldConfig config;
  config.objects = {Box("stand", Eigen::Vector3d(0.3, 0.3, 0.5), Eigen::Vector3d(0.0, 0.0, -0.25)),
                    Box("box", Eigen::Vector3d(0.2, 0.2, 0.2), Eigen::Vector3d(0.0, 0.0, -0.6), 1.0)};
  MultibodyWorld world(config, 0.001);
  for (int k = 0; k < 100; ++k) world.Step();
  const int stand = world.FindBody("stand");
  const int box = world.FindBody("box");
  bool stand_on_ground = false, box_on_stand = false;
  for (const Contact& c : world.contacts()) {
    if ((c.body_a == stand && c.body_b == kGround) || (c.body_a == kGround && c.body_b == stand)) {
      stand_on_ground = true;
    }
    if ((c.body_a == box && c.body_b == stand) || (c.body_a == stand && c.body_b == box)) box_on_stand = true;
  }
  EXPECT_FALSE(stand_on_ground);
  EXPECT_TRUE(box_on_stand);
  EXPECT_NEAR(world.ContactForce_W(box).z(), -9.81, 1e-6);
}

// More pairs than the collision pools hold (256, physics/internal/collision_configuration.cc): the rest come
// from the heap, and every box still rests on the ground with its weight.
TEST(MultibodyWorld, MoreContactPairsThanThePoolsHoldAllRest) {
  WorldConfig config;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p_m(0.5 * (i % 20), 0.5 * (i / 20), -0.1);
    config.objects.push_back(Box("box" + std::to_string(i), Eigen::Vector3d(0.2, 0.2, 0.2), p_m, 1.0));
  }
  MultibodyWorld world(config, 0.001);
  for (int k = 0; k < 100; ++k) world.Step();
  for (int i = 0; i < 300; ++i) {
    const int box = world.FindBody("box" + std::to_string(i));
    EXPECT_NEAR(world.ContactForce_W(box).z(), -9.81, 1e-6) << i;
    EXPECT_NEAR(world.body(box).p_WB_m.z(), -0.1, 1e-3) << i;
  }
}

TEST(Simulation, CollisionFiltersLetAVehiclePassThroughAnObject) {
  SimulationConfig config;
  config.world.ground = false;
  WorldObject ghost = Box("ghost", Eigen::Vector3d(4.0, 4.0, 0.1), Eigen::Vector3d(0.0, 0.0, 0.5));
  ghost.filter.group = 4;
  ghost.filter.mask = ~1;  // collides with everything but group 1 (vehicles)
  config.world.objects = {ghost};
  auto unpowered = UnpoweredThreeStar(config, Eigen::Vector3d::Zero());
  Simulation& sim = *unpowered;
  for (int k = 0; k < 1000; ++k) sim.Step();  // falls 4.9 m through the slab at 0.5 m
  EXPECT_GT(sim.world().body(sim.output(0).platform_body).p_WB_m.z(), 1.0);
  EXPECT_TRUE(sim.world().contacts().empty());
}

// Constant level attitude setpoints and each sub-aircraft's share of the weight (the allocation (17) for
// a level hover of a symmetric IAP): the IAP stays put.
TEST(Simulation, ShippedIapsHoverOnTheirWeightShare) {
  for (const std::string name : {"three_star", "three_square", "two_line", "three_star_fixed"}) {
    SCOPED_TRACE(name);
    SimulationConfig config;
    config.vehicles.push_back(Spec(name, Eigen::Vector3d(0.0, 0.0, -2.0)));
    Simulation sim(config);
    for (int k = 0; k < 10000; ++k) sim.Step();
    const BodyState& platform = sim.world().body(sim.output(0).platform_body);
    std::printf("%s hover 10 s: platform moved %.2e m, tilted %.2e deg\n", name.c_str(),
                (platform.p_WB_m - Eigen::Vector3d(0.0, 0.0, -2.0)).norm(),
                platform.q_WB.angularDistance(Eigen::Quaterniond::Identity()) * 180.0 / M_PI);
    EXPECT_LT((platform.p_WB_m - Eigen::Vector3d(0.0, 0.0, -2.0)).norm(), 0.01);
    EXPECT_EQ(sim.output(0).saturated_steps, 0u);
  }
}

TEST(Simulation, RejectsInvalidCommandsAndHoldsTheLastOne) {
  SimulationConfig config;
  config.vehicles.push_back(Spec("two_line", Eigen::Vector3d(0.0, 0.0, -2.0)));
  Simulation sim(config);
  SubAircraftSetpoint bad;
  bad.thrust_N = std::nan("");
  EXPECT_FALSE(sim.SetCommand(0, 0, bad));
  bad.thrust_N = 10.0;
  bad.q_WS.coeffs() << 0.0, 0.0, 0.0, 2.0;
  EXPECT_FALSE(sim.SetCommand(0, 1, bad));
  EXPECT_EQ(sim.output(0).invalid_commands, 2u);
  for (int k = 0; k < 1000; ++k) sim.Step();
  EXPECT_TRUE(sim.world().body(sim.output(0).platform_body).p_WB_m.allFinite());
}

// A collective thrust beyond what the rotors give is full thrust, and a negative one none (a flight
// controller's normalised thrust is clamped to [0, 1]): 1e160 N is flown like the rotors' maximum, not as
// idle motors, and each is counted.
TEST(Simulation, ClampsAThrustBeyondTheRotorsToTheirRange) {
  const auto thrust_after = [](double thrust_N, uint64_t* clamped) {
    SimulationConfig config;
    config.world.ground = false;
    config.world.gravity_mps2 = 0.0;
    config.vehicles.push_back(Spec("two_line", Eigen::Vector3d::Zero()));
    Simulation sim(config);
    SubAircraftSetpoint setpoint;
    setpoint.thrust_N = thrust_N;
    for (int s = 0; s < 2; ++s) EXPECT_TRUE(sim.SetCommand(0, s, setpoint));
    for (int k = 0; k < 300; ++k) sim.Step();
    *clamped = sim.output(0).clamped_thrust_commands;
    return sim.output(0).sub_aircraft[0].thrust_W_N.norm();
  };
  const model::RotorSet rotors = LoadShipped("two_line").sub_aircraft[0].rotors;
  const double max_N = static_cast<double>(rotors.hub_S_m.size()) * rotors.MaxThrust_N();
  uint64_t clamped = 0;
  const double full = thrust_after(max_N, &clamped);
  EXPECT_EQ(clamped, 0u);
  EXPECT_GT(full, 0.9 * max_N);
  EXPECT_DOUBLE_EQ(thrust_after(1e160, &clamped), full);
  EXPECT_EQ(clamped, 2u);
  const double none = thrust_after(0.0, &clamped);
  EXPECT_DOUBLE_EQ(thrust_after(-5.0, &clamped), none);
  EXPECT_EQ(clamped, 2u);
  EXPECT_LT(none, 0.1 * max_N);
}

// The command link tests label setpoint k (from 0) with its thrust: 5 N plus k tenths of a millinewton, above
// the idle rotors' thrust, and 20,000 of them within what the rotors give (so none is clamped).
constexpr double kLabelFirst_N = 5.0, kLabelStep_N = 1e-4;
double LabelThrust_N(int64_t k) { return kLabelFirst_N + static_cast<double>(k) * kLabelStep_N; }
// the label of the setpoint in effect: -1 before the first arrives
int64_t LabelOf(const VehicleOutput& out) {
  const double thrust_N = -out.sub_aircraft[0].thrust_W_N.z();
  if (thrust_N < kLabelFirst_N - kLabelStep_N / 2) return -1;
  return std::lround((thrust_N - kLabelFirst_N) / kLabelStep_N);
}

// The command link: thrust-torque setpoints show up unchanged in the sub-aircraft's thrust, so the step each
// one takes effect can be read off. One new setpoint a step, each with its own thrust; returns, per setpoint,
// how many steps after the one it was set for it first took effect (-1: overtaken within a step, never seen).
std::vector<int64_t> LinkDelays(const CommandLink& link, uint64_t seed, int setpoints) {
  SimulationConfig config;
  config.world.ground = false;
  config.world.gravity_mps2 = 0.0;
  config.seed = seed;
  config.vehicles.push_back(Spec("three_star", Eigen::Vector3d::Zero()));
  config.vehicles[0].initial_rotors = InitialRotors::kIdle;
  config.vehicles[0].command_link = link;
  Simulation sim(config);
  std::vector<int64_t> delays(static_cast<size_t>(setpoints), -1);
  SubAircraftSetpoint setpoint;
  setpoint.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  int64_t last_seen = -1;
  for (int k = 0; k < setpoints + 100; ++k) {
    if (k < setpoints) {
      setpoint.thrust_W_N = Eigen::Vector3d(0.0, 0.0, -LabelThrust_N(k));
      EXPECT_TRUE(sim.SetCommand(0, 0, setpoint));
    }
    sim.Step();
    const int64_t seen = LabelOf(sim.output(0));
    EXPECT_GE(seen, last_seen) << "setpoints overtook each other at step " << k;
    if (seen > last_seen) delays[static_cast<size_t>(seen)] = k - seen;
    last_seen = seen;
  }
  return delays;
}

TEST(CommandLink, NoLinkAppliesASetpointInTheStepItWasSetFor) {
  for (const int64_t delay : LinkDelays(CommandLink{}, 1, 50)) EXPECT_EQ(delay, 0);
}

TEST(CommandLink, ADelayHoldsEverySetpointBackByExactlyThatManySteps) {
  for (const int64_t delay : LinkDelays(CommandLink{0.010, 0.0}, 1, 200)) EXPECT_EQ(delay, 10);
  // rounded to the step grid: 2.4 ms is 2 steps of 1 ms
  for (const int64_t delay : LinkDelays(CommandLink{0.0024, 0.0}, 1, 50)) EXPECT_EQ(delay, 2);
}

// Jitter: each setpoint's delay is uniform on [delay, delay + jitter] in steps, in order (a setpoint that
// would overtake arrives with the one ahead of it), the same for a seed and different for another.
TEST(CommandLink, JitterIsUniformBoundedInOrderAndSeeded) {
  const CommandLink link{0.010, 0.004};
  const std::vector<int64_t> delays = LinkDelays(link, 7, 20000);
  std::vector<int> histogram(5, 0);
  int seen = 0;
  for (const int64_t delay : delays) {
    if (delay < 0) continue;  // overtaken: never in effect on its own
    ASSERT_GE(delay, 10);
    ASSERT_LE(delay, 14);
    ++histogram[static_cast<size_t>(delay - 10)];
    ++seen;
  }
  EXPECT_GT(seen, 5000);
  for (int bin = 0; bin < 5; ++bin) EXPECT_GT(histogram[static_cast<size_t>(bin)], 0) << bin;
  EXPECT_EQ(LinkDelays(link, 7, 2000), LinkDelays(link, 7, 2000));
  EXPECT_NE(LinkDelays(link, 7, 2000), LinkDelays(link, 8, 2000));
  // setpoints sent every 5 ms (a 200 Hz controller) cannot overtake with 4 ms of jitter: each one's delay is
  // drawn independently, uniform over the five steps
  SimulationConfig config;
  config.world.ground = false;
  config.world.gravity_mps2 = 0.0;
  config.seed = 3;
  config.vehicles.push_back(Spec("three_star", Eigen::Vector3d::Zero()));
  config.vehicles[0].initial_rotors = InitialRotors::kIdle;
  config.vehicles[0].command_link = link;
  Simulation sim(config);
  SubAircraftSetpoint setpoint;
  setpoint.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  std::vector<int> counts(5, 0);
  const int sent = 4000;
  int64_t in_effect = 0;  // the number of the setpoint in effect: 1, 2, ... (0 before the first arrives)
  for (int k = 0; k < sent * 5 + 20; ++k) {
    if (k % 5 == 0 && k / 5 < sent) {
      setpoint.thrust_W_N = Eigen::Vector3d(0.0, 0.0, -LabelThrust_N(k / 5));
      sim.SetCommand(0, 0, setpoint);
    }
    sim.Step();
    const int64_t number = LabelOf(sim.output(0)) + 1;
    if (number == in_effect) continue;
    ASSERT_EQ(number, in_effect + 1) << "a setpoint was skipped or overtaken at step " << k;
    ++counts[static_cast<size_t>(k - 5 * (number - 1) - 10)];
    in_effect = number;
  }
  EXPECT_EQ(in_effect, sent);
  // each bin holds 1/5 of the setpoints: 800 +- 4 standard deviations (sqrt(4000 * 0.2 * 0.8) = 25)
  for (int bin = 0; bin < 5; ++bin) EXPECT_NEAR(counts[static_cast<size_t>(bin)], sent / 5, 100) << bin;
}

TEST(CommandLink, IsReadFromAVehicleEntryAndChecked) {
  const std::string vehicle_file = std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml";
  const std::string good = "vehicles:\n  - {name: iap, file: " + vehicle_file +
                           ", command_link: {delay_s: 0.01, jitter_s: 0.002}}\n";
  bridge::YamlMap params(YAML::Load(good), "test.yaml");
  const PhysicsConfig config = ReadPhysicsConfig(params, "test.yaml", 0.001);
  EXPECT_DOUBLE_EQ(config.simulation.vehicles.at(0).command_link.delay_s, 0.01);
  EXPECT_DOUBLE_EQ(config.simulation.vehicles.at(0).command_link.jitter_s, 0.002);
  for (const std::string bad : {"{delay_s: -0.01}", "{jitter: 0.002}"}) {
    SCOPED_TRACE(bad);
    bridge::YamlMap wrong(
        YAML::Load("vehicles:\n  - {name: iap, file: " + vehicle_file + ", command_link: " + bad + "}\n"),
        "test.yaml");
    try {
      ReadPhysicsConfig(wrong, "test.yaml", 0.001);
      ADD_FAILURE() << "accepted";
    } catch (const bridge::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("command_link"), std::string::npos) << e.what();
    }
  }
}

// Joint friction and cone limits (model::JointResistance). A platform of 10⁶ kg and 10⁶ kg·m² does not
// move, so a sub-aircraft turns about its joint with its own inertia: ω' = (τ_drive − τ_friction) / I.
struct AnchoredSub {
  std::unique_ptr<Simulation> sim;
  int sub_body = 0;
  double twist_inertia_kgm2 = 0.0;  // the F450's I_zz
};

AnchoredSub AnchoredThreeStar(const model::JointResistance& resistance) {
  SimulationConfig config;
  config.world.ground = false;
  config.world.gravity_mps2 = 0.0;
  VehicleSpec spec = Spec("three_star", Eigen::Vector3d::Zero());
  spec.vehicle.platform.mass_kg = 1e6;
  spec.vehicle.platform.inertia_B_kgm2 = 1e6 * Eigen::Matrix3d::Identity();
  for (auto& sub : spec.vehicle.sub_aircraft) sub.joint_resistance = resistance;
  spec.description = model::ParseUrdf(model::GenerateUrdf(spec.vehicle), "anchored.urdf");
  spec.initial_rotors = InitialRotors::kIdle;
  config.vehicles.push_back(spec);
  AnchoredSub out;
  out.sim = std::make_unique<Simulation>(config);
  SubAircraftSetpoint off;
  off.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  for (int s = 0; s < 3; ++s) out.sim->SetCommand(0, s, off);
  out.sub_body = out.sim->output(0).sub_aircraft_bodies[0];
  out.twist_inertia_kgm2 = spec.vehicle.sub_aircraft[0].mass.inertia_B_kgm2(2, 2);
  return out;
}

// The sub-aircraft's twist rate about its z axis relative to the platform.
double TwistRate_rad_s(const Simulation& sim, int sub_body) {
  const BodyState& sub = sim.world().body(sub_body);
  const BodyState& platform = sim.world().body(sim.output(0).platform_body);
  return (sub.q_WB * Eigen::Vector3d::UnitZ()).dot(sub.w_WB_W - platform.w_WB_W);
}

TEST(Joints, ViscousFrictionGivesTheFirstOrderResponseOfItsCoefficient) {
  model::JointResistance resistance;
  resistance.viscous_Nms_per_rad = 0.05;
  AnchoredSub a = AnchoredThreeStar(resistance);
  const double drive_Nm = 0.1, time_constant_s = a.twist_inertia_kgm2 / 0.05;  // 0.496 s
  for (int k = 1; k <= 2000; ++k) {
    const BodyState& sub = a.sim->world().body(a.sub_body);
    a.sim->mutable_world().AddJointTorque_W(a.sub_body, sub.q_WB * Eigen::Vector3d(0.0, 0.0, drive_Nm));
    a.sim->Step();
    if (k % 250 != 0) continue;
    const double expected = drive_Nm / 0.05 * (1.0 - std::exp(-k * 0.001 / time_constant_s));
    // explicit friction on a 1 ms step: first order in the step, 0.1 % of the time constant
    EXPECT_NEAR(TwistRate_rad_s(*a.sim, a.sub_body), expected, 2e-3 * drive_Nm / 0.05) << k;
  }
}

TEST(Joints, CoulombFrictionHoldsBelowItsTorqueAndSlipsAboveIt) {
  model::JointResistance resistance;
  resistance.coulomb_Nm = 0.05;
  {  // 80 % of the friction torque: it holds (creeping below the regularisation's 0.01 rad/s)
    AnchoredSub a = AnchoredThreeStar(resistance);
    for (int k = 0; k < 1000; ++k) {
      const BodyState& sub = a.sim->world().body(a.sub_body);
      a.sim->mutable_world().AddJointTorque_W(a.sub_body, sub.q_WB * Eigen::Vector3d(0.0, 0.0, 0.04));
      a.sim->Step();
    }
    EXPECT_LT(std::abs(TwistRate_rad_s(*a.sim, a.sub_body)), 0.01);
  }
  // twice the friction torque: slips with ω' = (τ − τ_c) / I
  AnchoredSub a = AnchoredThreeStar(resistance);
  for (int k = 1; k <= 1000; ++k) {
    const BodyState& sub = a.sim->world().body(a.sub_body);
    a.sim->mutable_world().AddJointTorque_W(a.sub_body, sub.q_WB * Eigen::Vector3d(0.0, 0.0, 0.1));
    a.sim->Step();
  }
  const double expected = (0.1 - 0.05) / a.twist_inertia_kgm2 * 1.0;  // 2.02 rad/s after 1 s
  EXPECT_NEAR(TwistRate_rad_s(*a.sim, a.sub_body), expected, 0.01 * expected);
}

// The cone limit stops the tilt at its angle whichever way the sub-aircraft is pushed, and leaves twist free.
TEST(Joints, AConeLimitStopsTheTiltAndLeavesTheTwistFree) {
  model::JointResistance resistance;
  resistance.max_tilt_rad = 30.0 * M_PI / 180.0;
  for (const Eigen::Vector3d& direction :
       {Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Vector3d(0.6, -0.8, 0.0), Eigen::Vector3d(0.0, 1.0, 0.0)}) {
    SCOPED_TRACE(direction.transpose());
    AnchoredSub a = AnchoredThreeStar(resistance);
    double max_tilt_rad = 0.0, tilt_rad = 0.0;
    for (int k = 0; k < 2000; ++k) {
      const BodyState& sub = a.sim->world().body(a.sub_body);
      // 0.2 N·m of tilting torque, in the platform's frame (= W), and 0.02 N·m of twist
      a.sim->mutable_world().AddJointTorque_W(a.sub_body,
                                              0.2 * direction + sub.q_WB * Eigen::Vector3d(0.0, 0.0, 0.02));
      a.sim->Step();
      const Eigen::Vector3d z_W = a.sim->world().body(a.sub_body).q_WB * Eigen::Vector3d::UnitZ();
      tilt_rad = std::acos(std::clamp(z_W.z(), -1.0, 1.0));
      max_tilt_rad = std::max(max_tilt_rad, tilt_rad);
    }
    std::printf("cone 30 deg: largest tilt %.3f deg, final %.3f deg\n", max_tilt_rad * 180.0 / M_PI,
                tilt_rad * 180.0 / M_PI);
    EXPECT_LT(max_tilt_rad, resistance.max_tilt_rad + 0.2 * M_PI / 180.0);
    EXPECT_NEAR(tilt_rad, resistance.max_tilt_rad, 0.05 * M_PI / 180.0);
    // twist spun up freely: ω = τ t / I = 0.02 × 2 / 0.0248 = 1.6 rad/s (within 10 %: the tilted axis)
    EXPECT_NEAR(TwistRate_rad_s(*a.sim, a.sub_body), 0.02 * 2.0 / a.twist_inertia_kgm2, 0.16);
  }
  // without the limit the same push tilts it far beyond
  AnchoredSub free = AnchoredThreeStar(model::JointResistance{});
  for (int k = 0; k < 2000; ++k) {
    free.sim->mutable_world().AddJointTorque_W(free.sub_body, Eigen::Vector3d(0.2, 0.0, 0.0));
    free.sim->Step();
  }
  EXPECT_LT((free.sim->world().body(free.sub_body).q_WB * Eigen::Vector3d::UnitZ()).z(), std::cos(0.6));
}

// Friction and the limit act inside the vehicle: a free IAP keeps its momentum while a joint slips and
// reaches its limit, and loses energy.
TEST(Joints, FrictionAndLimitsAreInternalToTheVehicle) {
  SimulationConfig config;
  config.world.ground = false;
  config.world.gravity_mps2 = 0.0;
  VehicleSpec spec = Spec("three_star", Eigen::Vector3d::Zero());
  for (auto& sub : spec.vehicle.sub_aircraft) {
    sub.joint_resistance.viscous_Nms_per_rad = 0.01;
    sub.joint_resistance.coulomb_Nm = 0.02;
    sub.joint_resistance.max_tilt_rad = 0.3;
  }
  spec.description = model::ParseUrdf(model::GenerateUrdf(spec.vehicle), "resisting.urdf");
  spec.initial_rotors = InitialRotors::kIdle;
  config.vehicles.push_back(spec);
  Simulation sim(config);
  SubAircraftSetpoint off;
  off.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  for (int s = 0; s < 3; ++s) sim.SetCommand(0, s, off);
  const VehicleOutput& out = sim.output(0);
  // the vehicle's angular momentum, and the sum of its bodies' magnitudes as the scale of its error
  const auto angular_momentum = [&](double* scale) {
    Eigen::Vector3d L = Eigen::Vector3d::Zero();
    *scale = 0.0;
    std::vector<int> bodies = out.sub_aircraft_bodies;
    bodies.push_back(out.platform_body);
    for (const int b : bodies) {
      const BodyState& s = sim.world().body(b);
      const Eigen::Matrix3d R = s.q_WB.toRotationMatrix();
      const Eigen::Vector3d L_b = s.p_WBcom_m.cross(sim.world().mass_kg(b) * s.v_WBcom_W) +
                                  R * sim.world().inertia_B_kgm2(b) * R.transpose() * s.w_WB_W;
      L += L_b;
      *scale += L_b.norm();
    }
    return L;
  };
  // spin every sub-aircraft about its own x against the platform: each reaches its limit
  for (int k = 0; k < 1500; ++k) {
    for (int s = 0; s < 3; ++s) {
      const BodyState& sub = sim.world().body(out.sub_aircraft_bodies[s]);
      sim.mutable_world().AddJointTorque_W(out.sub_aircraft_bodies[s],
                                           sub.q_WB * Eigen::Vector3d(0.3, 0.0, 0.03));
    }
    sim.Step();
  }
  double scale = 0.0;
  // from rest under internal torques; Bullet's semi-implicit joint integration holds momentum to O(step)
  const Eigen::Vector3d L = angular_momentum(&scale);
  std::printf("|L| %.2e of %.3f kg m^2/s at the limits\n", L.norm(), scale);
  EXPECT_LT(L.norm(), 1e-3 * scale);
  ASSERT_GT(scale, 0.01);
  double still = 0.0;  // friction stops the relative motion; what the vehicle has left, it keeps
  for (int k = 0; k < 2000; ++k) sim.Step();
  EXPECT_LT((angular_momentum(&still) - L).norm(), 1e-3 * scale);
  // friction has stopped the relative motion: the vehicle turns as one body
  for (int s = 0; s < 3; ++s) {
    const Eigen::Vector3d relative =
        sim.world().body(out.sub_aircraft_bodies[s]).w_WB_W - sim.world().body(out.platform_body).w_WB_W;
    EXPECT_LT(relative.norm(), 0.02) << s;
  }
}

TEST(Joints, AreReadFromTheVehicleFileAndWrittenToTheUrdf) {
  const test_support::TestFolder folder("world_test");
  const std::string path = (folder.path() / "resisting.yaml").string();
  {
    std::ofstream file(path);
    file << "name: resisting\nplatform: {mass_kg: 1.1, inertia_kgm2: [0.02, 0.02, 0.04], collision: [{box: "
            "[0.2, 0.2, 0.05]}]}\n"
            "sub_aircraft_defaults:\n  base: "
         << IAPSIM_SOURCE_DIR
         << "/configs/vehicles/parts/f450.yaml\n"
            "  joint_friction: {viscous_Nms_per_rad: 0.01, coulomb_Nm: 0.02}\n  joint_max_tilt_deg: 35\n"
            "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n";
  }
  const model::Vehicle vehicle = model::LoadVehicle(path);
  const model::MultibodyDescription description = model::ParseUrdf(model::GenerateUrdf(vehicle), "r.urdf");
  ASSERT_EQ(description.joints.size(), 2u);
  for (const auto& joint : description.joints) {
    EXPECT_DOUBLE_EQ(joint.resistance.viscous_Nms_per_rad, 0.01);
    EXPECT_DOUBLE_EQ(joint.resistance.coulomb_Nm, 0.02);
    EXPECT_NEAR(joint.resistance.max_tilt_rad, 35.0 * M_PI / 180.0, 1e-12);
  }
  for (const std::string bad :
       {"<dynamics damping=\"-1\"/>", "<limit upper=\"4\"/>", "<limit lower=\"0\"/>"}) {
    SCOPED_TRACE(bad);
    const std::string urdf =
        "<robot name=\"r\"><link name=\"p\"/><link name=\"s\"/><joint name=\"j\" type=\"spherical\">"
        "<parent link=\"p\"/><child link=\"s\"/>" +
        bad + "</joint></robot>";
    try {
      model::ParseUrdf(urdf, "bad.urdf");
      ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("bad.urdf: line 1: joint 'j'"), std::string::npos) << e.what();
    }
  }
}

// Drag (physics/wind.h) on a whole IAP against analytic solutions of m v' = −½ ρ ΣCdA |v − wind| (v − wind).

TEST(Air, AFallingIapReachesTheTerminalVelocityOfItsDragArea) {
  const double area_m2 = 0.945, density = 1.225;
  SimulationConfig config;
  config.air.enabled = true;
  config.world.ground = false;
  auto sim = UnpoweredThreeStar(config, Eigen::Vector3d::Zero(), area_m2);
  // no ground, no wind: the IAP falls, its rotors give nothing
  const double mass_kg = sim->vehicle(0).vehicle.TotalMass_kg();
  const double terminal_mps = std::sqrt(2.0 * mass_kg * 9.81 / (density * 4.0 * area_m2));  // 5.0 m/s
  for (int k = 0; k < 5000; ++k) sim->Step();  // ten time constants v_t / g
  const BodyState& platform = sim->world().body(sim->output(0).platform_body);
  std::printf("terminal velocity %.5f m/s (analytic %.5f)\n", platform.v_WBcom_W.z(), terminal_mps);
  EXPECT_NEAR(platform.v_WBcom_W.z(), terminal_mps, 1e-3 * terminal_mps);
  EXPECT_NEAR(sim->output(0).air_force_W_N.z(), -mass_kg * 9.81, 1e-2 * mass_kg * 9.81);
  EXPECT_LT(platform.v_WBcom_W.head<2>().norm(), 1e-6);
}

TEST(Air, AFreeIapIsCarriedAlongByTheWindAsQuadraticDragPredicts) {
  const double area_m2 = 0.05, density = 1.225, wind_mps = 3.0;
  SimulationConfig config;
  config.air.enabled = true;
  config.world.ground = false;
  config.world.gravity_mps2 = 0.0;
  config.air.wind_W_mps = Eigen::Vector3d(wind_mps, 0.0, 0.0);
  auto sim = UnpoweredThreeStar(config, Eigen::Vector3d::Zero(), area_m2);
  const double mass_kg = sim->vehicle(0).vehicle.TotalMass_kg();
  // the relative speed r = wind − v obeys r' = −k r², k = ρ ΣCdA / (2 m): r(t) = r0 / (1 + k r0 t)
  const double k = density * 4.0 * area_m2 / (2.0 * mass_kg);
  for (int step = 1; step <= 4000; ++step) {
    sim->Step();
    if (step % 1000 != 0) continue;
    const double t_s = step * 0.001;
    const double expected_mps = wind_mps - wind_mps / (1.0 + k * wind_mps * t_s);
    // the whole IAP's centre of mass: the parts' drag acts at different heights, so it pitches a little
    Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
    std::vector<int> bodies = sim->output(0).sub_aircraft_bodies;
    bodies.push_back(sim->output(0).platform_body);
    for (const int body : bodies) momentum += sim->world().mass_kg(body) * sim->world().body(body).v_WBcom_W;
    EXPECT_NEAR(momentum.x() / mass_kg, expected_mps, 1e-3 * expected_mps) << t_s << " s";
  }
  EXPECT_EQ(sim->output(0).wind_W_mps, config.air.wind_W_mps);
}

// Turbulence reaches the vehicles through the Simulation: gusts about the mean wind, of the Dryden
// intensity for the vehicle's height, the same for a seed.
TEST(Air, TurbulentWindVariesAboutTheMeanAndRepeatsForASeed) {
  SimulationConfig config;
  config.air.enabled = true;
  config.air.wind_W_mps = Eigen::Vector3d(0.0, 4.0, 0.0);  // toward the east
  config.air.turbulence = true;
  config.air.w20_mps = 7.72;
  config.seed = 5;
  std::vector<Eigen::Vector3d> winds[2];
  for (int run = 0; run < 2; ++run) {
    auto sim = UnpoweredThreeStar(config, Eigen::Vector3d(0.0, 0.0, -20.0), 0.01);
    for (int k = 0; k < 2000; ++k) {
      sim->Step();
      winds[run].push_back(sim->output(0).wind_W_mps);
    }
  }
  EXPECT_EQ(winds[0], winds[1]);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& w : winds[0]) mean += w / static_cast<double>(winds[0].size());
  const DrydenScales scales = LowAltitudeDryden(20.0, 7.72);
  // two seconds of gusts with correlation times of seconds: the mean stays within a few sigma of the wind
  EXPECT_LT((mean - config.air.wind_W_mps).norm(), 4.0 * scales.sigma_u_mps);
  EXPECT_GT((winds[0].front() - winds[0].back()).norm(), 1e-3);
}

// The hovering three-star's k_f ω² at its trim speed, per rotor.
double HoverRotorThrust_N(const Simulation& sim) {
  const model::RotorSet& rotors = sim.vehicle(0).vehicle.sub_aircraft[0].rotors;
  const double speed = sim.output(0).sub_aircraft[0].rotor_speeds_rad_s[0];
  return rotors.thrust_coefficient * speed * speed;
}

TEST(Air, WithoutAnAirBlockNothingAerodynamicActs) {
  SimulationConfig config;
  config.air.wind_W_mps = Eigen::Vector3d(5.0, 0.0, 0.0);  // not enabled: the paper's still, ideal air
  auto sim = UnpoweredThreeStar(config, Eigen::Vector3d(0.0, 0.0, -0.3), 0.05);
  sim->Step();
  EXPECT_EQ(sim->output(0).wind_W_mps, Eigen::Vector3d::Zero());
  EXPECT_EQ(sim->output(0).air_force_W_N, Eigen::Vector3d::Zero());
}

// Each rotor's thrust in ground effect against Cheeseman–Bennett at z/R = 0.5 … 4, over the ground plane and
// over a static slab below one sub-aircraft only (the F450's 10" propellers, R = 0.127 m). The three-star
// hovers level with its hubs 0.07 m below the platform's origin.
TEST(Air, GroundEffectRaisesEachRotorsThrustAsCheesemanBennettPredicts) {
  const double radius_m = 0.127;
  for (const double z_over_r : {0.5, 1.0, 2.0, 4.0}) {
    SCOPED_TRACE(z_over_r);
    SimulationConfig config;
    config.air.enabled = true;
    config.vehicles.push_back(Spec("three_star", Eigen::Vector3d(0.0, 0.0, -z_over_r * radius_m - 0.07)));
    Simulation sim(config);
    const double thrust_N = HoverRotorThrust_N(sim);
    sim.Step();
    const double expected = 1.0 / (1.0 - std::pow(1.0 / (4.0 * z_over_r), 2));
    for (const SubAircraftOutput& sub : sim.output(0).sub_aircraft) {
      for (int j = 0; j < 4; ++j) EXPECT_NEAR(sub.thrust_ratio[j], expected, 1e-9);
      EXPECT_NEAR(sub.thrust_W_N.norm(), 4.0 * thrust_N * expected, 1e-9);
    }
  }
  // no ground; a 1 m slab whose top is 2 R below the hubs, under sub-aircraft 1 (x = 0.48 m) only
  SimulationConfig config;
  config.air.enabled = true;
  config.world.ground = false;
  const double top_z_m = -2.0 + 0.07 + 2.0 * radius_m;
  config.world.objects = {
      Box("slab", Eigen::Vector3d(0.5, 0.6, 1.0), Eigen::Vector3d(0.48, 0.0, top_z_m + 0.5))};
  config.vehicles.push_back(Spec("three_star", Eigen::Vector3d(0.0, 0.0, -2.0)));
  Simulation sim(config);
  sim.Step();
  for (int j = 0; j < 4; ++j) {
    EXPECT_NEAR(sim.output(0).sub_aircraft[0].thrust_ratio[j], 64.0 / 63.0, 1e-6);  // within Bullet's margin
    EXPECT_EQ(sim.output(0).sub_aircraft[1].thrust_ratio[j], 1.0);
    EXPECT_EQ(sim.output(0).sub_aircraft[2].thrust_ratio[j], 1.0);
  }
  // switched off, the same hover sees none
  config.air.ground_effect = false;
  Simulation off(config);
  off.Step();
  EXPECT_EQ(off.output(0).sub_aircraft[0].thrust_ratio[0], 1.0);
}

// A hovering IAP in a steady wind: every rotor's drag is ω c_D times the wind, along it (RotorS' model with
// the F450's published coefficient); body drag is off for this (no drag areas).
TEST(Air, RotorDragOfAHoveringIapInWindIsTheSumOfItsRotors) {
  SimulationConfig config;
  config.air.enabled = true;
  config.air.wind_W_mps = Eigen::Vector3d(3.0, -1.0, 0.0);
  config.vehicles.push_back(Spec("three_star", Eigen::Vector3d(0.0, 0.0, -3.0)));
  Simulation sim(config);
  const double speed = sim.output(0).sub_aircraft[0].rotor_speeds_rad_s[0];
  sim.Step();
  const Eigen::Vector3d expected_W = 12.0 * speed * 8.06428e-5 * config.air.wind_W_mps;
  EXPECT_LT((sim.output(0).air_force_W_N - expected_W).norm(), 1e-12)
      << sim.output(0).air_force_W_N.transpose();
  for (const SubAircraftOutput& sub : sim.output(0).sub_aircraft) {
    EXPECT_LT((sub.air_force_W_N - expected_W / 3.0).norm(), 1e-12);
  }
  config.air.rotor_drag = false;
  Simulation off(config);
  off.Step();
  EXPECT_EQ(off.output(0).air_force_W_N, Eigen::Vector3d::Zero());
}

TEST(Air, DiscreteGustsAddToTheWindOnTheirSchedule) {
  SimulationConfig config;
  config.air.enabled = true;
  config.world.ground = false;
  config.air.wind_W_mps = Eigen::Vector3d(1.0, 0.0, 0.0);
  DiscreteGust gust;
  gust.start_s = 0.1;
  gust.rise_s = 0.2;
  gust.hold_s = 0.05;
  gust.amplitude_W_mps = Eigen::Vector3d(0.0, 3.0, -1.0);
  config.air.gusts = {gust, gust};
  config.air.gusts[1].start_s = 0.3;  // overlapping: they add
  auto sim = UnpoweredThreeStar(config, Eigen::Vector3d::Zero(), 0.02);
  for (int k = 0; k < 800; ++k) {
    const double t_s = k * 0.001;
    sim->Step();
    const Eigen::Vector3d expected = config.air.wind_W_mps + GustVelocity_W(config.air.gusts[0], t_s) +
                                     GustVelocity_W(config.air.gusts[1], t_s);
    ASSERT_LT((sim->output(0).wind_W_mps - expected).norm(), 1e-12) << t_s;
  }
  EXPECT_EQ(sim->output(0).wind_W_mps, config.air.wind_W_mps);  // both over
}

// Downwash: a movable slab d = 2 R below the hubs of the hovering three-star, read from its acceleration in
// the first step (m (a − g)), against C_D / 2 of each wake's momentum flux at d (physics/rotor.h, checked
// there against the Biot–Savart slipstream). No ground: nothing else acts on the slab.
Eigen::Vector3d DownwashOnSlab(SimulationConfig config, const WorldObject& slab, double* rotor_thrust_N) {
  config.air.enabled = true;
  config.world.ground = false;
  config.world.objects.push_back(slab);
  config.vehicles.push_back(Spec("three_star", Eigen::Vector3d(0.0, 0.0, -3.0)));
  Simulation sim(config);
  *rotor_thrust_N = HoverRotorThrust_N(sim);
  const int body = sim.world().FindBody(slab.name);
  sim.Step();
  EXPECT_EQ(sim.output(0).air_force_W_N.z(), 0.0);  // no wake of the three-star reaches its own parts
  return sim.world().mass_kg(body) * (sim.world().body(body).v_WBcom_W / 0.001 - Eigen::Vector3d(0, 0, 9.81));
}

TEST(Air, DownwashPushesWhatIsBelowARotorWithItsWakesMomentumFlux) {
  const double radius_m = 0.127, depth_m = 2.0 * radius_m, c_d = 1.17;
  const double top_z_m = -3.0 + 0.07 + depth_m;  // the hubs are 0.07 m below P's origin
  double thrust_N = 0.0;
  const double flux_N = [&] {
    SimulationConfig probe;
    probe.vehicles.push_back(Spec("three_star", Eigen::Vector3d(0.0, 0.0, -3.0)));
    Simulation sim(probe);
    return WakeMomentumFlux_N(HoverRotorThrust_N(sim), depth_m, radius_m);
  }();
  // across all twelve wakes
  const WorldObject wide =
      Box("slab", Eigen::Vector3d(3.0, 3.0, 0.1), Eigen::Vector3d(0, 0, top_z_m + 0.05), 2.0);
  Eigen::Vector3d force = DownwashOnSlab(SimulationConfig{}, wide, &thrust_N);
  std::printf("downwash on a slab 2 R below: %.4f N of %.4f N thrust\n", force.z(), 12.0 * thrust_N);
  EXPECT_NEAR(force.z(), 12.0 * 0.5 * c_d * flux_N, 1e-6 * force.z());
  EXPECT_LT(force.head<2>().norm(), 1e-9);
  // across the outer halves (x > 0) of sub-aircraft 1's two front rotors (x = 0.48 + 0.159 m): 9 cells each
  const double edge_m = 0.48 + 0.225 / std::sqrt(2.0) + 1e-3;
  const WorldObject half =
      Box("slab", Eigen::Vector3d(3.0, 3.0, 0.1), Eigen::Vector3d(edge_m + 1.5, 0, top_z_m + 0.05), 2.0);
  force = DownwashOnSlab(SimulationConfig{}, half, &thrust_N);
  EXPECT_NEAR(force.z(), 2.0 * 9.0 / kWakeCells * 0.5 * c_d * flux_N, 1e-6 * force.z());
  // a wind carries the wakes along: F_x / F_z = wind / (2 v_h)
  SimulationConfig windy;
  windy.air.wind_W_mps = Eigen::Vector3d(3.0, 0.0, 0.0);
  force = DownwashOnSlab(windy, wide, &thrust_N);
  const double far_speed_mps = 2.0 * std::sqrt(thrust_N / (2.0 * 1.225 * M_PI * radius_m * radius_m));
  EXPECT_NEAR(force.x() / force.z(), 3.0 / far_speed_mps, 1e-9);
  // a static slab between stops the wakes; switched off, nothing
  SimulationConfig shielded;
  shielded.world.objects = {
      Box("table", Eigen::Vector3d(3.0, 3.0, 0.02), Eigen::Vector3d(0, 0, top_z_m - 0.1))};
  EXPECT_LT(DownwashOnSlab(shielded, wide, &thrust_N).norm(), 1e-9);
  SimulationConfig off;
  off.air.downwash = false;
  EXPECT_LT(DownwashOnSlab(off, wide, &thrust_N).norm(), 1e-9);
}

// One IAP hovering 0.6 m above another: the upper one's wakes press on the lower one's sub-aircraft (the
// thrust loss of flying under another vehicle), counted in the lower one's air force, alike on its three
// sub-aircraft by symmetry; the upper one feels nothing.
TEST(Air, DownwashOfOneVehicleActsOnAnotherBelowIt) {
  SimulationConfig config;
  config.air.enabled = true;
  config.world.ground = false;
  config.vehicles = {Spec("three_star", Eigen::Vector3d(0.0, 0.0, -3.6)),
                     Spec("three_star", Eigen::Vector3d(0.0, 0.0, -3.0))};
  config.vehicles[0].name = "upper";
  config.vehicles[1].name = "lower";
  Simulation sim(config);
  sim.Step();
  EXPECT_EQ(sim.output(0).air_force_W_N, Eigen::Vector3d::Zero());
  const VehicleOutput& lower = sim.output(1);
  const double first_N = lower.sub_aircraft[0].air_force_W_N.z();
  EXPECT_GT(first_N, 0.5);
  for (const SubAircraftOutput& sub : lower.sub_aircraft)
    EXPECT_NEAR(sub.air_force_W_N.z(), first_N, 1e-6 * first_N);
  EXPECT_NEAR(lower.air_force_W_N.z(), 3.0 * first_N, 1e-9);
  std::printf("downwash on the lower IAP: %.3f N (its weight %.3f N)\n", lower.air_force_W_N.z(),
              sim.vehicle(1).vehicle.TotalMass_kg() * 9.81);
}

TEST(Air, IsReadFromThePhysicsParamsAndChecked) {
  const std::string vehicles = "vehicles:\n  - {name: iap, file: " + std::string(IAPSIM_SOURCE_DIR) +
                               "/configs/vehicles/three_star.yaml}\n";
  bridge::YamlMap params(
      YAML::Load(vehicles +
                 "air: {density_kgpm3: 1.1, wind_W_mps: [3, -1, 0], turbulence: {w20_mps: 15.4},\n"
                 "      rotor_drag: false, gusts: [{start_s: 2, rise_s: 0.5, amplitude_W_mps: [0, 4, 0]}],\n"
                 "      downwash_drag_coefficient: 1.5}\n"),
      "test.yaml");
  const AirConfig air = ReadPhysicsConfig(params, "test.yaml", 0.001).simulation.air;
  EXPECT_TRUE(air.enabled);
  EXPECT_TRUE(air.body_drag);
  EXPECT_FALSE(air.rotor_drag);
  EXPECT_TRUE(air.ground_effect);
  EXPECT_TRUE(air.downwash);
  EXPECT_EQ(air.downwash_drag_coefficient, 1.5);
  ASSERT_EQ(air.gusts.size(), 1u);
  EXPECT_EQ(air.gusts[0].start_s, 2.0);
  EXPECT_EQ(air.gusts[0].rise_s, 0.5);
  EXPECT_EQ(air.gusts[0].hold_s, 0.0);
  EXPECT_EQ(air.gusts[0].amplitude_W_mps, Eigen::Vector3d(0.0, 4.0, 0.0));
  bridge::YamlMap still(YAML::Load(vehicles), "test.yaml");
  EXPECT_FALSE(ReadPhysicsConfig(still, "test.yaml", 0.001).simulation.air.enabled);
  EXPECT_EQ(air.density_kgpm3, 1.1);
  EXPECT_EQ(air.wind_W_mps, Eigen::Vector3d(3.0, -1.0, 0.0));
  EXPECT_TRUE(air.turbulence);
  EXPECT_EQ(air.w20_mps, 15.4);
  for (const std::string bad :
       {"{density_kgpm3: -1}", "{wind_W_mps: [3, 0]}", "{turbulence: {model: von_karman}}", "{gusts: 1}",
        "{gusts: [{start_s: 1, rise_s: 0, amplitude_W_mps: [1, 0, 0]}]}",
        "{gusts: [{start_s: 1, rise_s: 1}]}", "{ground_effect: maybe}", "{downwash_drag_coefficient: 0}",
        "{downwash_drag_coefficient: 2.5}", "{downwash_drag_coefficient: .nan}"}) {
    SCOPED_TRACE(bad);
    bridge::YamlMap wrong(YAML::Load(vehicles + "air: " + bad + "\n"), "test.yaml");
    try {
      ReadPhysicsConfig(wrong, "test.yaml", 0.001);
      ADD_FAILURE() << "accepted";
    } catch (const bridge::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("air"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace iapsim::physics
