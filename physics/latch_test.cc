// The docking latch (seed §IV-E, Fig. 6): two free quadrotors, one carrying a cone and one a cylinder, with
// gravity and rotors off so that only each test's loads act. It closes only within tolerance, holds the two
// as one rigid body, lets them go when opened, and reads its configuration strictly.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include "bridge/config.h"
#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/multibody_world.h"
#include "physics/physics_config.h"
#include "physics/simulation.h"
#include "tests/support/test_folder.h"

namespace iapsim::physics {
namespace {

constexpr double kTolerance_m = 0.005;
// the cone's apex touches the cylinder's face when B's origin is this far behind A's along y
constexpr double kContactOffset_m = 0.66;

std::string VehicleFile(const std::string& name) {
  return std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/" + name + ".yaml";
}

VehicleSpec Docking(const std::string& file, const std::string& name, const Eigen::Vector3d& p_WP_m,
                    double yaw_rad) {
  VehicleSpec spec;
  spec.name = name;
  spec.vehicle = model::LoadVehicle(VehicleFile(file));
  spec.description = model::ParseUrdf(model::GenerateUrdf(spec.vehicle), file + ".urdf");
  spec.p_WP_m = p_WP_m;
  spec.yaw_rad = yaw_rad;
  spec.initial_rotors = InitialRotors::kIdle;
  return spec;
}

// A (the cylinder) at the origin; B (the cone) `gap_m` short of contact along +y, moved by `offset_m`.
SimulationConfig DockingPair(double gap_m, const Eigen::Vector3d& offset_m = Eigen::Vector3d::Zero(),
                             double yaw_b_rad = 0.0) {
  SimulationConfig config;
  config.world.ground = false;
  config.world.gravity_mps2 = 0.0;
  config.vehicles.push_back(Docking("docking_cylinder", "a", Eigen::Vector3d::Zero(), 0.0));
  config.vehicles.push_back(Docking(
      "docking_cone", "b", Eigen::Vector3d(0.0, -kContactOffset_m - gap_m, 0.0) + offset_m, yaw_b_rad));
  LatchSpec latch;
  latch.name = "dock";
  latch.body_a = "a/receiver";
  latch.body_b = "b/probe";
  latch.port_a = {Eigen::Vector3d(0.0, -0.02, 0.0), -Eigen::Vector3d::UnitY()};  // the cylinder's face
  latch.port_b = {Eigen::Vector3d(0.0, 0.04, 0.0), Eigen::Vector3d::UnitY()};    // the cone's apex
  latch.axial_tolerance_m = kTolerance_m;
  latch.radial_tolerance_m = kTolerance_m;
  config.latches = {latch};
  return config;
}

// Rotors off: the quadrotors are free rigid bodies.
void RotorsOff(Simulation* sim) {
  SubAircraftSetpoint off;
  off.mode = SubAircraftSetpoint::Mode::kThrustTorque;
  for (int v = 0; v < sim->vehicle_count(); ++v) sim->SetCommand(v, 0, off);
}

int Body(const Simulation& sim, const std::string& name) {
  const int body = sim.world().FindBody(name);
  EXPECT_GE(body, 0) << name;
  return body;
}

// Pushes B's quadrotor along +y for 0.1 s so that it coasts toward A at `speed_mps` (B weighs 1.8 kg).
void PushB(Simulation* sim, double speed_mps) {
  const int quad = Body(*sim, "b/quad");
  const double mass_kg = sim->vehicle(1).vehicle.TotalMass_kg();
  for (int k = 0; k < 100; ++k) {
    sim->mutable_world().AddForce_W(quad, Eigen::Vector3d(0.0, mass_kg * speed_mps / 0.1, 0.0));
    sim->Step();
  }
}

Eigen::Isometry3d Pose(const BodyState& state) { return Eigen::Translation3d(state.p_WB_m) * state.q_WB; }

// Pose of body b in body a's frame.
Eigen::Isometry3d X_AB(const MultibodyWorld& world, int a, int b) {
  return Pose(world.body(a)).inverse() * Pose(world.body(b));
}

// Linear and angular momentum (about W's origin) of every body of the world.
void Momentum(const MultibodyWorld& world, Eigen::Vector3d* linear_kgmps, Eigen::Vector3d* angular_kgm2ps) {
  linear_kgmps->setZero();
  angular_kgm2ps->setZero();
  for (int b = 0; b < world.body_count(); ++b) {
    const BodyState& s = world.body(b);
    const Eigen::Matrix3d R_WB = s.q_WB.toRotationMatrix();
    const Eigen::Vector3d p_kgmps = world.mass_kg(b) * s.v_WBcom_W;
    *linear_kgmps += p_kgmps;
    *angular_kgm2ps +=
        s.p_WBcom_m.cross(p_kgmps) + R_WB * world.inertia_B_kgm2(b) * R_WB.transpose() * s.w_WB_W;
  }
}

TEST(Latch, ClosesAtTheFirstStepWithinTolerance) {
  Simulation sim(DockingPair(0.05));
  RotorsOff(&sim);
  const LatchOutput& latch = sim.latch_output(0);
  EXPECT_FALSE(latch.latched);
  EXPECT_NEAR(latch.axial_error_m, 0.05, 1e-12);
  EXPECT_NEAR(latch.radial_error_m, 0.0, 1e-12);
  EXPECT_NEAR(latch.angular_error_rad, 0.0, 1e-12);
  PushB(&sim, 0.1);  // 5 mm of the gap closed by the push
  double last_open_axial_m = latch.axial_error_m;
  for (int k = 0; k < 1000 && !latch.latched; ++k) {
    last_open_axial_m = latch.axial_error_m;
    sim.Step();
  }
  ASSERT_TRUE(latch.latched);
  std::printf("latched at t = %.3f s: axial %.5f m, radial %.2e m, speed %.4f m/s\n", sim.time_s(),
              latch.axial_error_m, latch.radial_error_m, latch.relative_speed_mps);
  EXPECT_GT(last_open_axial_m, kTolerance_m);
  EXPECT_LE(latch.axial_error_m, kTolerance_m);
  EXPECT_GT(latch.axial_error_m, kTolerance_m - 0.1 * 0.001 * 1.01);  // one step of 0.1 m/s inside
  EXPECT_LT(latch.radial_error_m, 1e-9);
  EXPECT_NEAR(latch.relative_speed_mps, 0.1, 1e-3);
  EXPECT_EQ(latch.closes, 1u);
  EXPECT_EQ(latch.opens, 0u);
  EXPECT_TRUE(sim.world().latched(0));
}

// Loads that would shear, bend and twist the joint: the two quadrotors keep their relative pose; with
// equal and opposite loads, and then none, momentum stays what it was.
TEST(Latch, LatchedQuadrotorsMoveAsOneRigidBody) {
  Simulation sim(DockingPair(0.002));  // within tolerance and at rest: closed from the start
  RotorsOff(&sim);
  ASSERT_TRUE(sim.latch_output(0).latched);
  MultibodyWorld& world = sim.mutable_world();
  const int a = Body(sim, "a/quad");
  const int b = Body(sim, "b/quad");
  const Eigen::Isometry3d X_AB0 = X_AB(world, a, b);
  double drift_m = 0.0;
  double drift_rad = 0.0;
  const auto measure = [&] {
    const Eigen::Isometry3d X = X_AB(world, a, b);
    drift_m = std::max(drift_m, (X.translation() - X_AB0.translation()).norm());
    drift_rad = std::max(drift_rad, Eigen::AngleAxisd(X_AB0.linear().transpose() * X.linear()).angle());
  };
  // different loads on each: the pair accelerates and tumbles (at about 1 rad/s: the drift grows as the
  // square of the rate, see LatchConstraint in multibody_world.cc)
  for (int k = 0; k < 1000; ++k) {
    world.AddForce_W(a, Eigen::Vector3d(0.4, 0.2, -0.8));
    world.AddForce_W(b, Eigen::Vector3d(-0.12, 0.4, 0.28));
    world.AddTorque_W(b, Eigen::Vector3d(0.02, 0.0, 0.008));
    sim.Step();
    measure();
  }
  Eigen::Vector3d p0, L0, p1, L1, p2, L2;
  Momentum(world, &p0, &L0);
  ASSERT_GT(world.body(a).w_WB_W.norm(), 0.5);  // it does spin
  // equal and opposite: no change of linear momentum
  for (int k = 0; k < 1000; ++k) {
    world.AddForce_W(a, Eigen::Vector3d(0.1, -0.04, 0.2));
    world.AddForce_W(b, Eigen::Vector3d(-0.1, 0.04, -0.2));
    sim.Step();
    measure();
  }
  Momentum(world, &p1, &L1);
  // no loads: angular momentum too
  for (int k = 0; k < 2000; ++k) {
    sim.Step();
    measure();
  }
  Momentum(world, &p2, &L2);
  std::printf(
      "latched pair, 4 s, spinning at %.2f rad/s: relative pose drift %.2e m, %.2e rad; "
      "|dp| %.2e, %.2e kg m/s; free |dL| %.2e of %.3f kg m^2/s\n",
      world.body(a).w_WB_W.norm(), drift_m, drift_rad, (p1 - p0).norm(), (p2 - p0).norm(), (L2 - L1).norm(),
      L1.norm());
  EXPECT_LT(drift_m, 1e-6);
  EXPECT_LT(drift_rad, 1e-6);
  EXPECT_LT((p1 - p0).norm(), 1e-9);
  EXPECT_LT((p2 - p0).norm(), 1e-9);
  // Bullet's gyroscopic integration is first order in the step, as for a single free body
  EXPECT_LT((L2 - L1).norm(), 1e-3 * L1.norm());
  EXPECT_TRUE(sim.world().contacts().empty());  // the parts touch, but their contacts are filtered
}

// The shipped docking quadrotors hover level on their own thrust (their parts are balanced), apart and
// latched together in the air.
TEST(Latch, DockingQuadrotorsHoverApartAndLatched) {
  for (const double gap_m : {0.5, 0.002}) {
    SCOPED_TRACE(gap_m);
    SimulationConfig config = DockingPair(gap_m);
    config.world.gravity_mps2 = 9.81;
    for (VehicleSpec& vehicle : config.vehicles) {
      vehicle.p_WP_m.z() = -2.0;
      vehicle.initial_rotors = InitialRotors::kHover;
    }
    Simulation sim(config);
    EXPECT_EQ(sim.latch_output(0).latched, gap_m < kTolerance_m);
    std::vector<Eigen::Vector3d> start_m;
    for (int v = 0; v < 2; ++v) start_m.push_back(sim.world().body(sim.output(v).platform_body).p_WB_m);
    for (int k = 0; k < 5000; ++k) sim.Step();
    for (int v = 0; v < 2; ++v) {
      const BodyState& platform = sim.world().body(sim.output(v).platform_body);
      EXPECT_LT((platform.p_WB_m - start_m[v]).norm(), 0.01) << sim.vehicle(v).name;
      EXPECT_LT(platform.q_WB.angularDistance(Eigen::Quaterniond::Identity()), 0.01) << sim.vehicle(v).name;
    }
  }
}

// Opened, the two collide again and stay open while within tolerance; pulled apart they separate, and
// the latch closes again on the next approach.
TEST(Latch, OpensOnRequestAndClosesAgainOnlyAfterLeavingTolerance) {
  Simulation sim(DockingPair(0.002));
  RotorsOff(&sim);
  const LatchOutput& latch = sim.latch_output(0);
  ASSERT_TRUE(latch.latched);
  MultibodyWorld& world = sim.mutable_world();
  const int a = Body(sim, "a/quad");
  const int b = Body(sim, "b/quad");
  sim.OpenLatch(0);
  EXPECT_FALSE(latch.latched);
  EXPECT_FALSE(latch.armed);
  EXPECT_FALSE(world.latched(0));

  // pushed into A: the cone presses on the cylinder (a contact), A is pushed along, and no latch
  bool touched = false;
  double min_axial_m = 1.0;
  for (int k = 0; k < 300; ++k) {
    world.AddForce_W(b, Eigen::Vector3d(0.0, 2.0, 0.0));
    sim.Step();
    for (const Contact& c : world.contacts()) {
      touched = touched ||
                (world.body_name(c.body_a) == "a/receiver" && world.body_name(c.body_b) == "b/probe") ||
                (world.body_name(c.body_a) == "b/probe" && world.body_name(c.body_b) == "a/receiver");
    }
    min_axial_m = std::min(min_axial_m, latch.axial_error_m);
    ASSERT_FALSE(latch.latched) << "at t = " << sim.time_s();
  }
  EXPECT_TRUE(touched);
  EXPECT_GT(min_axial_m, -0.002);  // no more than a contact's penetration
  EXPECT_GT(world.body(a).v_WB_W.y(), 0.1);

  // pulled apart: out of tolerance, so armed again
  for (int k = 0; k < 500; ++k) {
    world.AddForce_W(a, Eigen::Vector3d(0.0, 2.0, 0.0));
    world.AddForce_W(b, Eigen::Vector3d(0.0, -2.0, 0.0));
    sim.Step();
  }
  EXPECT_GT(latch.axial_error_m, 0.05);
  EXPECT_TRUE(latch.armed);
  EXPECT_FALSE(latch.latched);

  // brought back together slowly: closes again
  const Eigen::Vector3d v_WA_W = world.body(a).v_WB_W;
  for (int k = 0; k < 5000 && !latch.latched; ++k) {
    const Eigen::Vector3d v_AB_W = world.body(b).v_WB_W - v_WA_W;
    world.AddForce_W(b, 1.8 * (Eigen::Vector3d(0.0, 0.1, 0.0) - v_AB_W) / 0.05);  // closing at 0.1 m/s
    world.AddForce_W(a, -1.8 * (world.body(a).v_WB_W - v_WA_W) / 0.05);           // A keeps its speed
    sim.Step();
  }
  EXPECT_TRUE(latch.latched);
  EXPECT_EQ(latch.closes, 2u);
  EXPECT_EQ(latch.opens, 1u);
}

TEST(Latch, StaysOpenOutsideTolerance) {
  struct Case {
    std::string what;
    SimulationConfig config;
    double speed_mps;
  };
  // B turned 20° about z about its cone's apex: the apex stays on A's axis, the axes do not face
  const double yaw_rad = 20.0 * M_PI / 180.0;
  const Eigen::Vector3d p_BQ_m(0.0, 0.34, 0.0);  // the apex in B's frame
  const Eigen::Vector3d turned = p_BQ_m - Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) * p_BQ_m;
  const std::vector<Case> cases = {
      {"radial error 8 mm", DockingPair(0.05, Eigen::Vector3d(0.008, 0.0, 0.0)), 0.1},
      {"axes 20 deg apart", DockingPair(0.05, turned, yaw_rad), 0.1},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    Simulation sim(c.config);
    RotorsOff(&sim);
    const LatchOutput& latch = sim.latch_output(0);
    PushB(&sim, c.speed_mps);
    double min_abs_axial_m = 1.0;
    for (int k = 0; k < 2000; ++k) {
      sim.Step();
      min_abs_axial_m = std::min(min_abs_axial_m, std::abs(latch.axial_error_m));
      ASSERT_FALSE(latch.latched) << "at t = " << sim.time_s();
    }
    EXPECT_LT(min_abs_axial_m, kTolerance_m);  // the cone did reach the cylinder
    EXPECT_EQ(latch.closes, 0u);
  }
}

TEST(Latch, ManualLatchClosesOnRequestOnlyWithinTolerance) {
  SimulationConfig config = DockingPair(0.02);
  config.latches[0].auto_close = false;
  Simulation sim(config);
  RotorsOff(&sim);
  EXPECT_FALSE(sim.CloseLatch(0));  // 2 cm apart
  const int b = Body(sim, "b/quad");
  const LatchOutput& latch = sim.latch_output(0);
  while (latch.axial_error_m > 0.004) {
    sim.mutable_world().AddForce_W(
        b, Eigen::Vector3d(0.0, 1.8 * (0.05 - sim.world().body(b).v_WB_W.y()) / 0.05, 0.0));
    sim.Step();
    ASSERT_FALSE(latch.latched);  // within tolerance for the last millimetre: still open
    ASSERT_LT(sim.time_s(), 2.0);
  }
  EXPECT_EQ(sim.FindLatch("dock"), 0);
  EXPECT_EQ(sim.FindLatch("other"), -1);
  EXPECT_TRUE(sim.CloseLatch(0));
  EXPECT_TRUE(latch.latched);
  EXPECT_TRUE(sim.world().latched(0));
}

// The world-level latch between a multibody link and a rigid object, both turned: exercises Bullet's
// two frame conventions (links and rigid bodies map a constraint frame differently).
TEST(MultibodyWorldLatch, HoldsALinkToAnObjectAndRefusesWhatItCannotHold) {
  WorldConfig config;
  config.ground = false;
  config.gravity_mps2 = 0.0;
  WorldObject crate;
  crate.name = "crate";
  model::Shape box;
  box.box_size_m = Eigen::Vector3d(0.2, 0.3, 0.1);
  crate.shapes = {box};
  crate.mass_kg = 2.0;
  crate.p_WO_m = Eigen::Vector3d(0.4, 0.1, -1.0);
  crate.q_WO = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 3.0).normalized());
  WorldObject wall = crate;
  wall.name = "wall";
  wall.mass_kg = 0.0;
  wall.p_WO_m = Eigen::Vector3d(5.0, 0.0, 0.0);
  config.objects = {crate, wall};
  MultibodyWorld world(config, 0.001);

  model::MultibodyDescription rod;  // one free link, inertia off its principal axes
  rod.name = "rod";
  model::LinkDescription link;
  link.name = "body";
  link.mass.mass_kg = 1.0;
  link.mass.com_B_m = Eigen::Vector3d(0.05, 0.0, 0.0);
  link.mass.inertia_B_kgm2 << 0.02, 0.003, 0.0, 0.003, 0.01, 0.001, 0.0, 0.001, 0.025;
  model::Shape cylinder;
  cylinder.kind = model::Shape::Kind::kCylinder;
  cylinder.radius_m = 0.05;
  cylinder.length_m = 0.4;
  link.collision = {cylinder};
  rod.links = {link};
  const int rod_body =
      world.AddMultibody("rod", rod, Eigen::Vector3d(0.0, 0.0, -1.0),
                         Eigen::Quaterniond(Eigen::AngleAxisd(-0.4, Eigen::Vector3d::UnitY())));
  model::MultibodyDescription ghost = rod;  // no collision shape
  ghost.links[0].collision.clear();
  const int ghost_body =
      world.AddMultibody("ghost", ghost, Eigen::Vector3d(3.0, 0.0, -1.0), Eigen::Quaterniond::Identity());
  const int crate_body = world.FindBody("crate");
  EXPECT_THROW(world.AddLatch(crate_body, world.FindBody("wall")), std::invalid_argument);  // no multibody
  EXPECT_THROW(world.AddLatch(ghost_body, crate_body), std::invalid_argument);              // no collider
  EXPECT_THROW(world.AddLatch(rod_body, rod_body), std::invalid_argument);

  const int latch = world.AddLatch(crate_body, rod_body);  // the object first: swapped inside
  EXPECT_FALSE(world.latched(latch));
  world.CloseLatch(latch);
  EXPECT_TRUE(world.latched(latch));
  const Eigen::Isometry3d X_RC0 = X_AB(world, rod_body, crate_body);
  double drift_m = 0.0, drift_rad = 0.0;
  for (int k = 0; k < 3000; ++k) {  // loads on the crate only: the rod is carried along, tumbling
    world.AddForce_W(crate_body, Eigen::Vector3d(0.6, -0.3, 0.15));
    world.AddTorque_W(crate_body, Eigen::Vector3d(0.01, 0.03, -0.02));
    world.Step();
    const Eigen::Isometry3d X = X_AB(world, rod_body, crate_body);
    drift_m = std::max(drift_m, (X.translation() - X_RC0.translation()).norm());
    drift_rad = std::max(drift_rad, Eigen::AngleAxisd(X_RC0.linear().transpose() * X.linear()).angle());
  }
  std::printf("rod latched to a crate, 3 s tumbling at %.2f rad/s: drift %.2e m, %.2e rad\n",
              world.body(rod_body).w_WB_W.norm(), drift_m, drift_rad);
  EXPECT_GT(world.body(rod_body).w_WB_W.norm(), 0.5);
  EXPECT_LT(drift_m, 1e-6);
  // a rigid body turns by Bullet's rigid-body integrator, a link by the multibody one: they differ to
  // second order in rate x step
  EXPECT_LT(drift_rad, 1e-5);

  world.OpenLatch(latch);  // free again: a push on the crate leaves the rod behind
  for (int k = 0; k < 200; ++k) {
    world.AddForce_W(crate_body, Eigen::Vector3d(0.0, 0.0, -20.0));
    world.Step();
  }
  EXPECT_FALSE(world.latched(latch));
  EXPECT_GT((X_AB(world, rod_body, crate_body).translation() - X_RC0.translation()).norm(), 0.1);
}

std::string WriteScenario(const std::string& text) {
  static const test_support::TestFolder folder("latch_test");
  return folder.Write("latch.yaml", text);
}

PhysicsConfig ReadParams(const std::string& latches) {
  const std::string text =
      "world: {ground: {enabled: false}}\n"
      "vehicles:\n"
      "  - {name: a, file: " +
      VehicleFile("docking_cylinder") +
      "}\n"
      "  - {name: b, file: " +
      VehicleFile("docking_cone") +
      ", position_m: [0, -0.662, 0]}\n"
      "latches:\n" +
      latches;
  const std::string path = WriteScenario(text);
  bridge::YamlMap params(bridge::LoadYamlFile(path), path);
  PhysicsConfig config = ReadPhysicsConfig(params, path, 0.001);
  params.Finish();
  return config;
}

TEST(LatchConfig, ReadsALatchAndNamesTheKeyOfEveryMistake) {
  const std::string good =
      "  - name: dock\n"
      "    body_a: a/receiver\n"
      "    body_b: b/probe\n"
      "    port_a: {position_m: [0, -0.02, 0], axis: [0, -2, 0]}\n"
      "    port_b: {position_m: [0, 0.04, 0], axis: [0, 1, 0]}\n"
      "    axial_tolerance_m: 0.004\n"
      "    radial_tolerance_m: 0.003\n"
      "    angular_tolerance_deg: 5\n"
      "    max_relative_speed_mps: 0.2\n"
      "    auto: false\n";
  const PhysicsConfig config = ReadParams(good);
  ASSERT_EQ(config.simulation.latches.size(), 1u);
  const LatchSpec& latch = config.simulation.latches[0];
  EXPECT_EQ(latch.body_b, "b/probe");
  EXPECT_EQ(latch.port_a.axis_B, -Eigen::Vector3d::UnitY());  // normalized
  EXPECT_EQ(latch.port_b.p_BQ_m, Eigen::Vector3d(0.0, 0.04, 0.0));
  EXPECT_DOUBLE_EQ(latch.axial_tolerance_m, 0.004);
  EXPECT_DOUBLE_EQ(latch.radial_tolerance_m, 0.003);
  EXPECT_NEAR(latch.angular_tolerance_rad, 5.0 * M_PI / 180.0, 1e-15);
  EXPECT_DOUBLE_EQ(latch.max_relative_speed_mps, 0.2);
  EXPECT_FALSE(latch.auto_close);
  const Simulation sim(config.simulation);  // the bodies exist and can be latched
  EXPECT_EQ(sim.latch_count(), 1);

  const auto replace = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    return text.replace(text.find(from), from.size(), to);
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {replace("b/probe", "b/prob"), "latches[0].body_b: 'b/prob' is not a body of the world"},
      {replace("b/probe", "b/platform"), "latches[0].body_b: 'b/platform' has no collision shape"},
      {replace("b/probe", "a/receiver"), "latches[0].body_b: is body_a"},
      {replace("axis: [0, 1, 0]", "axis: [0, 0, 0]"), "latches[0].port_b.axis: must be a non-zero vector"},
      {replace("port_b: {position_m: [0, 0.04, 0], ", "port_b: {"),
       "latches[0].port_b.position_m: is required"},
      {replace("    axial_tolerance_m: 0.004\n", ""), "latches[0].axial_tolerance_m: is required"},
      {replace("radial_tolerance_m: 0.003", "radial_tolerance_m: 0"),
       "latches[0].radial_tolerance_m: must be in"},
      {replace("angular_tolerance_deg: 5", "angular_tolerance_deg: 190"), "latches[0].angular_tolerance_deg"},
      {replace("auto: false", "automatic: false"), "latches[0].automatic: unknown key"},
      {good + good, "latches[1].name: 'dock' is used twice"},
  };
  for (const auto& [latches, expect] : cases) {
    SCOPED_TRACE(expect);
    try {
      ReadParams(latches);
      ADD_FAILURE() << "accepted";
    } catch (const bridge::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("latch.yaml"), std::string::npos) << e.what();  // the file
    }
  }
}

}  // namespace
}  // namespace iapsim::physics
