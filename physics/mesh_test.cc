// Mesh collision shapes in the Bullet world: a static triangle-mesh floor and a convex-hull body carry
// their loads at the right heights, bodies dropped into the shipped funnel settle where its geometry puts
// them, and a moving body's non-convex mesh is refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
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

namespace fs = std::filesystem;

constexpr double kStep_s = 0.001;
constexpr double kGravity_mps2 = 9.81;

std::string WriteFile(const std::string& name, const std::string& text) {
  static const test_support::TestFolder folder("physics_mesh_test");
  return folder.Write(name, text);
}

// the shipped funnel (tools/generate_funnel_mesh.py): axis +z from the mouth's centre
const std::string kFunnelFile = std::string(IAPSIM_SOURCE_DIR) + "/configs/meshes/funnel.obj";
constexpr double kFunnelMouthRadius_m = 0.10;
constexpr double kFunnelHoleRadius_m = 0.025;
constexpr double kFunnelConeLength_m = 0.075;
constexpr double kFunnelFloor_m = 0.175;  // the hole's floor, below the mouth

model::Shape Mesh(const std::string& file, bool convex,
                  const Eigen::Vector3d& scale = Eigen::Vector3d::Ones()) {
  model::Shape shape;
  shape.kind = model::Shape::Kind::kMesh;
  shape.mesh_file = file;
  shape.mesh_scale = scale;
  shape.mesh_convex = convex;
  return shape;
}

WorldObject Object(const std::string& name, const model::Shape& shape, const Eigen::Vector3d& p_WO_m,
                   double mass_kg = 0.0) {
  WorldObject object;
  object.name = name;
  object.shapes = {shape};
  object.p_WO_m = p_WO_m;
  object.mass_kg = mass_kg;
  return object;
}

model::Shape Sphere(double radius_m) {
  model::Shape shape;
  shape.kind = model::Shape::Kind::kSphere;
  shape.radius_m = radius_m;
  return shape;
}

constexpr char kUnitCubeObj[] =
    "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv -0.5 0.5 -0.5\nv 0.5 0.5 -0.5\n"
    "v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv -0.5 0.5 0.5\nv 0.5 0.5 0.5\n"
    "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";

// A floor of two triangles, 4 m square, at z = 0 of its file.
constexpr char kFloorObj[] = "v -2 -2 0\nv 2 -2 0\nv 2 2 0\nv -2 2 0\nf 1 2 3\nf 1 3 4\n";

TEST(MeshCollision, ABoxRestsOnATriangleMeshFloorAndReadsItsWeight) {
  WorldConfig config;
  config.ground = false;
  // the floor's surface at z = −0.3; the box starts 1 cm above it
  WorldObject box = Object("box", model::Shape{}, Eigen::Vector3d(0.0, 0.0, -0.3 - 0.1 - 0.01), 2.0);
  box.shapes[0].box_size_m = Eigen::Vector3d(0.4, 0.4, 0.2);
  config.objects = {
      Object("floor", Mesh(WriteFile("floor.obj", kFloorObj), false), Eigen::Vector3d(0.0, 0.0, -0.3)), box};
  MultibodyWorld world(config, kStep_s);
  const int id = world.FindBody("box");
  for (int k = 0; k < 1000; ++k) world.Step();
  const Eigen::Vector3d force = world.ContactForce_W(id);
  std::printf(
      "box on a triangle-mesh floor: centre %.6f m (expected -0.4), contact force %.6f N (weight %.4f)\n",
      world.body(id).p_WB_m.z(), force.z(), 2.0 * kGravity_mps2);
  EXPECT_NEAR(world.body(id).p_WB_m.z(), -0.4, 1e-4);
  EXPECT_NEAR(force.z(), -2.0 * kGravity_mps2, 1e-6);
  EXPECT_LT(force.head<2>().norm(), 1e-6);
  EXPECT_LT(world.body(id).v_WB_W.norm(), 1e-6);
}

// The hull of a 0.3 x 0.2 x 0.1 m mesh box: its faces, not its margin, touch the ground.
TEST(MeshCollision, AConvexMeshBodyRestsOnTheGroundAtItsOwnHeight) {
  WorldConfig config;
  const model::Shape hull = Mesh(WriteFile("cube.obj", kUnitCubeObj), true, Eigen::Vector3d(0.3, 0.2, 0.1));
  config.objects = {Object("block", hull, Eigen::Vector3d(0.0, 0.0, -0.06), 1.5)};
  MultibodyWorld world(config, kStep_s);
  const int id = world.FindBody("block");
  for (int k = 0; k < 1000; ++k) world.Step();
  const Eigen::Vector3d force = world.ContactForce_W(id);
  std::printf("convex mesh block on the ground: centre %.6f m (expected -0.05), contact force %.6f N\n",
              world.body(id).p_WB_m.z(), force.z());
  EXPECT_NEAR(world.body(id).p_WB_m.z(), -0.05, 1e-4);
  EXPECT_NEAR(force.z(), -1.5 * kGravity_mps2, 1e-6);
  EXPECT_LT(world.body(id).q_WB.angularDistance(Eigen::Quaterniond::Identity()), 1e-4);
}

// A world with the funnel's mouth 0.5 m up (NED), facing up, over the ground.
WorldConfig FunnelWorld() {
  WorldConfig config;
  config.objects = {Object("funnel", Mesh(kFunnelFile, true), Eigen::Vector3d(0.0, 0.0, -0.5))};
  return config;
}

// A ball smaller than the hole, dropped off-axis onto the funnel's wall, rolls into the hole and onto its
// floor (where, with no rolling resistance, it keeps rolling round); a ball too big for the hole rests in the
// cone, where the wall is tangent to it. One hull for the whole funnel would plug the hole and the cone.
TEST(MeshCollision, BallsDroppedIntoTheFunnelSettleOnItsAxis) {
  struct Case {
    double radius_m;
    double rest_below_mouth_m;  // the ball's centre, below the mouth at rest
  };
  // the cone's apex (extended) lies mouth_radius / tan(half angle) below the mouth
  const double half_angle_rad = std::atan((kFunnelMouthRadius_m - kFunnelHoleRadius_m) / kFunnelConeLength_m);
  const double apex_below_mouth_m = kFunnelMouthRadius_m / std::tan(half_angle_rad);
  const std::vector<Case> cases = {
      {0.02, kFunnelFloor_m - 0.02},
      {0.05, apex_below_mouth_m - 0.05 / std::sin(half_angle_rad)},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.radius_m);
    WorldConfig config = FunnelWorld();
    config.objects.push_back(Object("ball", Sphere(c.radius_m), Eigen::Vector3d(0.06, 0.02, -0.7), 0.1));
    MultibodyWorld world(config, kStep_s);
    const int id = world.FindBody("ball");
    for (int k = 0; k < 3000; ++k) world.Step();
    const Eigen::Vector3d p_m = world.body(id).p_WB_m;
    std::printf(
        "ball r %.3f m in the funnel: %.2f mm off the axis, centre %.3f mm below the mouth "
        "(expected %.3f), speed %.2e m/s\n",
        c.radius_m, 1e3 * p_m.head<2>().norm(), 1e3 * (p_m.z() + 0.5), 1e3 * c.rest_below_mouth_m,
        world.body(id).v_WB_W.norm());
    // the small ball has 5 mm of play in the hole; the facets (48 around) hold the big one 0.09 mm higher
    // than a round cone would
    const bool in_hole = c.radius_m < kFunnelHoleRadius_m;
    EXPECT_LT(p_m.head<2>().norm(), in_hole ? kFunnelHoleRadius_m - c.radius_m : 1e-3);
    EXPECT_NEAR(p_m.z() + 0.5, c.rest_below_mouth_m, 2e-4);
    EXPECT_LT(in_hole ? std::abs(world.body(id).v_WB_W.z()) : world.body(id).v_WB_W.norm(), 1e-6);
  }
}

// A pole 0.3 m long and 30 mm thick, 0.3 kg: a multibody link, what a vehicle's tool is.
constexpr double kPoleRadius_m = 0.015;
constexpr double kPoleLength_m = 0.3;
model::MultibodyDescription Pole() { return model::SolidCylinder("pole", 0.3, kPoleRadius_m, kPoleLength_m); }

// Dropped upright with its lower end 2 cm above the funnel's mouth and 4 cm off the axis.
int DropPole(MultibodyWorld* world) {
  return world->AddMultibody("pole", Pole(), Eigen::Vector3d(0.04, 0.0, -0.5 - 0.02 - 0.5 * kPoleLength_m),
                             Eigen::Quaterniond::Identity());
}

// The pole dropped into the funnel slides down its wall into the hole and stands on the floor.
TEST(MeshCollision, APoleDroppedIntoTheFunnelEndsInTheHole) {
  const model::LinkDescription link = Pole().links[0];
  MultibodyWorld world(FunnelWorld(), kStep_s);
  const int id = DropPole(&world);
  // kinetic + potential (gravity along +z in NED): contacts without restitution never add energy
  const auto energy_J = [&] {
    const BodyState& body = world.body(id);
    const Eigen::Vector3d w_B = body.q_WB.conjugate() * body.w_WB_W;
    return 0.5 * link.mass.mass_kg * body.v_WBcom_W.squaredNorm() +
           0.5 * w_B.dot(link.mass.inertia_B_kgm2 * w_B) -
           link.mass.mass_kg * kGravity_mps2 * body.p_WBcom_m.z();
  };
  for (int k = 0; k < 2000; ++k) world.Step();
  const Eigen::Vector3d p_WB_2s_m = world.body(id).p_WB_m;
  const double energy_2s_J = energy_J();
  double energy_gain_J = 0.0;
  for (int k = 0; k < 1000; ++k) {
    world.Step();
    energy_gain_J = std::max(energy_gain_J, energy_J() - energy_2s_J);
  }
  const BodyState& state = world.body(id);
  const Eigen::Vector3d p_W_lower_end =
      state.p_WB_m + state.q_WB * Eigen::Vector3d(0.0, 0.0, 0.5 * kPoleLength_m);
  const double tilt_rad = std::acos(std::min(1.0, (state.q_WB * Eigen::Vector3d::UnitZ()).z()));
  std::printf("pole in the funnel: lower end %.2f mm off the axis, %.3f mm above the floor, tilt %.2f deg\n",
              1e3 * p_W_lower_end.head<2>().norm(), 1e3 * (-0.5 + kFunnelFloor_m - p_W_lower_end.z()),
              tilt_rad * 180.0 / M_PI);
  EXPECT_LT(p_W_lower_end.head<2>().norm(), kFunnelHoleRadius_m - kPoleRadius_m + 1e-3);
  // leaning in the hole, the end's centre is above the floor by up to radius·sin(tilt)
  EXPECT_NEAR(p_W_lower_end.z(), -0.5 + kFunnelFloor_m, kPoleRadius_m * std::sin(tilt_rad) + 5e-4);
  // leaning on the wall it may twist about its axis, which no friction resists (no rolling or torsional
  // friction), but it never gains energy and does not leave the wall
  EXPECT_LT((state.p_WB_m - p_WB_2s_m).norm(), 2e-3);
  EXPECT_LT(energy_gain_J, 1e-5);
}

// Within Bullet's breaking distance (3.5 mm for the funnel) the pole leaning in the hole keeps points on the
// wall pieces around each line of contact, some millimetres off, and the solve gets every one; capped at
// 1 mm only the near ones are searched for and kept, and the pole comes to rest where it did.
TEST(MeshCollision, ACappedBreakingDistanceSolvesFewerPointsAndThePoleRestsWhereItDid) {
  const auto settle = [](double breaking_m, double* points_per_solve, Eigen::Vector3d* p_m) {
    WorldConfig config = FunnelWorld();
    config.contact_breaking_distance_m = breaking_m;
    MultibodyWorld world(config, kStep_s);
    const int id = DropPole(&world);
    for (int k = 0; k < 3000; ++k) world.Step();
    const SolverStats& stats = world.solver_stats();
    *points_per_solve = static_cast<double>(stats.contact_points) / static_cast<double>(stats.solves);
    *p_m = world.body(id).p_WB_m;
  };
  double points_bullet = 0.0, points_capped = 0.0;
  Eigen::Vector3d p_bullet_m, p_capped_m;
  settle(0.0, &points_bullet, &p_bullet_m);
  settle(1e-3, &points_capped, &p_capped_m);
  std::printf("contact points a solve: %.1f (Bullet's distance), %.1f (1 mm); rests %.3f mm apart\n",
              points_bullet, points_capped, 1e3 * (p_bullet_m - p_capped_m).norm());
  EXPECT_LT(points_capped, 0.8 * points_bullet);
  EXPECT_LT((p_bullet_m - p_capped_m).norm(), 5e-4);
}

TEST(MeshCollision, AMovingBodyRefusesANonConvexMeshAndAConvexPartNeedsAVolume) {
  WorldConfig config;
  config.objects = {Object("crate", Mesh(kFunnelFile, false), Eigen::Vector3d::Zero(), 1.0)};
  try {
    MultibodyWorld world(config, kStep_s);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("object 'crate': mesh " + kFunnelFile +
                                         ": a moving body collides as one convex hull"),
              std::string::npos)
        << e.what();
  }
  // a convex part needs a volume, even on a static body
  const std::string floor = WriteFile("floor.obj", kFloorObj);
  config.objects[0].shapes[0] = Mesh(floor, true);
  config.objects[0].mass_kg = 0.0;
  try {
    MultibodyWorld world(config, kStep_s);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("object 'crate': mesh " + floor + ": part 1 is flat"),
              std::string::npos)
        << e.what();
  }
  config.objects[0].shapes[0] = Mesh("/no/such/mesh.obj", true);
  try {
    MultibodyWorld world(config, kStep_s);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("object 'crate': /no/such/mesh.obj: no such mesh file"),
              std::string::npos)
        << e.what();
  }
}

PhysicsConfig ReadPhysicsParams(const std::string& path) {
  const YAML::Node root = bridge::LoadYamlFile(path);
  bridge::YamlMap params(root["processes"]["physics"]["params"], path, "processes.physics.params");
  return ReadPhysicsConfig(params, path, kStep_s);
}

// The shipped peg-in-hole and wall world builds; an object's mesh resolves next to the scenario, and a
// moving object's non-convex mesh and a negative contact distance are named with their keys.
TEST(MeshCollision, TheShippedFunnelAndWallWorldBuildsAndMeshKeysAreChecked) {
  const PhysicsConfig config =
      ReadPhysicsParams(std::string(IAPSIM_SOURCE_DIR) + "/configs/scenarios/peg_in_hole_world.yaml");
  Simulation sim(config.simulation);
  for (const std::string name : {"funnel", "wall"}) EXPECT_GE(sim.world().FindBody(name), 0) << name;
  for (int k = 0; k < 100; ++k) sim.Step();
  // the peg-in-hole flight keeps its contact points within 1 mm (README: Performance)
  EXPECT_EQ(ReadPhysicsParams(std::string(IAPSIM_SOURCE_DIR) + "/configs/regression/peg_in_hole.yaml")
                .simulation.world.contact_breaking_distance_m,
            1e-3);

  const std::string scenario =
      "processes:\n  physics:\n    params:\n"
      "      world:\n        objects:\n"
      "          - {name: crate, mass_kg: 1.0, shapes: [{mesh: {file: " +
      kFunnelFile +
      ", convex: false}}]}\n"
      "      vehicles: [{name: iap, file: " +
      std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml}]\n";
  const std::string path = WriteFile("crate.yaml", scenario);
  try {
    ReadPhysicsParams(path);
    ADD_FAILURE() << "accepted";
  } catch (const bridge::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("world.objects[0].shapes[0].mesh.convex: false"), std::string::npos)
        << e.what();
  }
  const std::string negative =
      WriteFile("negative.yaml",
                "processes:\n  physics:\n    params:\n      world: {contact_breaking_distance_m: -0.001}\n");
  try {
    ReadPhysicsParams(negative);
    ADD_FAILURE() << "accepted";
  } catch (const bridge::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("world.contact_breaking_distance_m"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace iapsim::physics
