// The factored contact rows (physics/internal/contact_solver.h) against Bullet's own: the Jacobian of a
// contact point and M⁻¹Jᵀ for every link of a tree with spherical and fixed joints in a random configuration,
// and a stepped contact scene with either set of rows.
#include "physics/internal/contact_solver.h"

#include <gtest/gtest.h>

#include <random>

#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/internal/collision_configuration.h"
#include "physics/simulation.h"

namespace iapsim::physics {
namespace {

btVector3 RandomVector(std::mt19937& random, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return btVector3(u(random), u(random), u(random));
}

btQuaternion RandomRotation(std::mt19937& random) {
  std::normal_distribution<double> n(0.0, 1.0);
  btQuaternion q(n(random), n(random), n(random), n(random));
  return q.normalized();
}

// A tree like a vehicle's with a tool: base, spherical links 0 and 1 on it, spherical link 2 on link 0, a
// fixed link 3 on the base and a spherical link 4 on that, every frame turned and offset arbitrarily.
std::unique_ptr<btMultiBody> MakeTree(std::mt19937& random) {
  auto tree = std::make_unique<btMultiBody>(5, 1.1, btVector3(0.02, 0.03, 0.04), false, false);
  const btVector3 inertia(0.013, 0.011, 0.024);
  tree->setupSpherical(0, 1.6, inertia, -1, RandomRotation(random), btVector3(0.48, 0.0, 0.07),
                       btVector3(0.0, 0.01, 0.02), true);
  tree->setupSpherical(1, 1.5, inertia, -1, RandomRotation(random), btVector3(-0.24, 0.41, 0.07),
                       btVector3(0.03, 0.0, -0.01), true);
  tree->setupSpherical(2, 0.4, inertia * 0.3, 0, RandomRotation(random), btVector3(0.1, 0.2, 0.0),
                       btVector3(0.0, 0.0, 0.15), true);
  tree->setupFixed(3, 0.1, btVector3(1e-5, 8e-3, 8e-3), -1, RandomRotation(random), btVector3(-0.5, 0.0, 0.0),
                   btVector3(-0.1, 0.0, 0.0));
  tree->setupSpherical(4, 0.2, inertia * 0.5, 3, RandomRotation(random), btVector3(-0.3, 0.0, 0.05),
                       btVector3(0.0, 0.05, 0.0), true);
  tree->finalizeMultiDof();
  tree->setBasePos(RandomVector(random, 1.0));
  tree->setWorldToBaseRot(RandomRotation(random));
  tree->setBaseOmega(RandomVector(random, 1.0));
  tree->setBaseVel(RandomVector(random, 1.0));
  for (const int link : {0, 1, 2, 4}) {
    const btQuaternion q = RandomRotation(random);
    const double position[4] = {q.x(), q.y(), q.z(), q.w()};
    tree->setJointPosMultiDof(link, position);
    const btVector3 rate = RandomVector(random, 2.0);
    const double velocity[3] = {rate.x(), rate.y(), rate.z()};
    tree->setJointVelMultiDof(link, velocity);
  }
  return tree;
}

TEST(MultibodyMass, JacobiansAndResponsesAreBulletsForEveryLink) {
  std::mt19937 random(7);
  for (int trial = 0; trial < 20; ++trial) {
    SCOPED_TRACE(trial);
    std::unique_ptr<btMultiBody> tree = MakeTree(random);
    // Bullet's forward dynamics caches the link frames and articulated inertias its row setup uses
    btAlignedObjectArray<btScalar> scratch_r;
    btAlignedObjectArray<btVector3> scratch_v;
    btAlignedObjectArray<btMatrix3x3> scratch_m;
    tree->computeAccelerationsArticulatedBodyAlgorithmMultiDof(0.001, scratch_r, scratch_v, scratch_m, false,
                                                               false, false);
    btAlignedObjectArray<btQuaternion> world_to_local;
    btAlignedObjectArray<btVector3> local_origin;
    world_to_local.resize(tree->getNumLinks() + 1);
    local_origin.resize(tree->getNumLinks() + 1);
    tree->updateCollisionObjectWorldTransforms(world_to_local, local_origin);

    ASSERT_TRUE(internal::MultibodyMass::Supports(*tree));
    internal::MultibodyMass mass;
    mass.Update(*tree);
    const int dofs = tree->getNumDofs() + 6;
    ASSERT_EQ(mass.dofs(), dofs);
    std::vector<double> bullet_jac(dofs), jac(dofs), bullet_response(dofs), response(dofs);
    for (int link = -1; link < tree->getNumLinks(); ++link) {
      const btVector3 p_W = RandomVector(random, 1.5);
      const btVector3 n_W = RandomVector(random, 1.0).normalized();
      tree->fillContactJacobianMultiDof(link, p_W, n_W, bullet_jac.data(), scratch_r, scratch_v, scratch_m);
      tree->calcAccelerationDeltasMultiDof(bullet_jac.data(), bullet_response.data(), scratch_r, scratch_v);
      mass.ContactJacobian(link, p_W, n_W, jac.data());
      mass.Response(link, jac.data(), response.data());
      for (int i = 0; i < dofs; ++i) {
        EXPECT_NEAR(jac[i], bullet_jac[i], 1e-12) << "link " << link << " dof " << i;
        EXPECT_NEAR(response[i], bullet_response[i], 1e-12 * (1.0 + std::abs(bullet_response[i])))
            << "link " << link << " dof " << i;
      }
    }
  }
}

TEST(MultibodyMass, RefusesAMultibodyWithOtherJoints) {
  btMultiBody revolute(1, 1.0, btVector3(1, 1, 1), false, false);
  revolute.setupRevolute(0, 1.0, btVector3(1, 1, 1), -1, btQuaternion::getIdentity(), btVector3(0, 0, 1),
                         btVector3(0.1, 0, 0), btVector3(0.1, 0, 0), true);
  revolute.finalizeMultiDof();
  EXPECT_FALSE(internal::MultibodyMass::Supports(revolute));
  btMultiBody fixed_base(0, 1.0, btVector3(1, 1, 1), true, false);
  fixed_base.finalizeMultiDof();
  EXPECT_FALSE(internal::MultibodyMass::Supports(fixed_base));
}

// The three-star on its boxes, landing from 5 mm and then pushed sideways past what friction holds (sliding
// on the ground): the factored rows and Bullet's give the same motion and the same contact forces.
TEST(ContactSolver, FactoredRowsStepAContactSceneAsBulletsRowsDo) {
  const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  std::vector<std::unique_ptr<Simulation>> sims;
  for (const bool factored : {true, false}) {
    SimulationConfig config;
    config.world.factored_contact_rows = factored;
    VehicleSpec spec;
    spec.name = "iap";
    spec.vehicle = vehicle;
    spec.description = model::ParseUrdf(model::GenerateUrdf(vehicle), "three_star.urdf");
    spec.p_WP_m = Eigen::Vector3d(0.0, 0.0, -0.125);
    spec.yaw_rad = 0.3;
    spec.initial_rotors = InitialRotors::kIdle;
    config.vehicles.push_back(spec);
    sims.push_back(std::make_unique<Simulation>(config));
  }
  double max_position_difference_m = 0.0, max_force_difference_N = 0.0;
  for (int k = 0; k < 1500; ++k) {
    for (auto& sim : sims) {
      if (k >= 500)
        sim->mutable_world().AddForce_W(sim->output(0).platform_body, Eigen::Vector3d(60.0, 20.0, 0.0));
      sim->Step();
    }
    for (int body = 0; body < sims[0]->world().body_count(); ++body) {
      max_position_difference_m =
          std::max(max_position_difference_m,
                   (sims[0]->world().body(body).p_WB_m - sims[1]->world().body(body).p_WB_m).norm());
    }
    max_force_difference_N =
        std::max(max_force_difference_N,
                 (sims[0]->output(0).external_force_W_N - sims[1]->output(0).external_force_W_N).norm());
  }
  const double slid_m = sims[0]->world().body(sims[0]->output(0).platform_body).p_WB_m.head<2>().norm();
  std::printf("factored vs Bullet's rows: %.2e m, %.2e N apart at most; slid %.3f m\n",
              max_position_difference_m, max_force_difference_N, slid_m);
  EXPECT_GT(slid_m, 0.1);
  EXPECT_LT(max_position_difference_m, 1e-9);
  EXPECT_LT(max_force_difference_N, 1e-6);
}

// The test that culls convex pairs before GJK never calls two bounds (boxes and cylinders) apart that come
// within the gap: random pairs, their distance estimated from points spread through both (an upper bound of
// the true distance).
TEST(BoundsApart, NeverSeparatesBoundsWithinTheGap) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto make = [&](bool cylinder) {
    internal::Bound bound;
    bound.kind = cylinder ? internal::Bound::Kind::kCylinder : internal::Bound::Kind::kBox;
    bound.R_WB = Eigen::Quaterniond(Eigen::Vector4d(u(random), u(random), u(random), u(random)).normalized())
                     .toRotationMatrix();
    bound.half_m = (Eigen::Vector3d(u(random), u(random), u(random)).array() + 1.2) * 0.1;
    if (cylinder) bound.half_m.y() = bound.half_m.x();
    bound.center_W = Eigen::Vector3d(u(random), u(random), u(random)) * 0.6;
    return bound;
  };
  // points through a bound: a 9 x 9 x 9 grid of its box, those of a cylinder within its radius
  const auto samples = [](const internal::Bound& bound) {
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i < 729; ++i) {
      const Eigen::Vector3d s((i % 9) / 4.0 - 1.0, (i / 9 % 9) / 4.0 - 1.0, (i / 81) / 4.0 - 1.0);
      if (bound.kind == internal::Bound::Kind::kCylinder && s.head<2>().norm() > 1.0) continue;
      points.push_back(bound.center_W + bound.R_WB * bound.half_m.cwiseProduct(s));
    }
    return points;
  };
  int apart = 0, near = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const internal::Bound a = make(trial % 3 == 0);
    const internal::Bound b = make(trial % 2 == 0);
    const double gap_m = 0.02;
    const std::vector<Eigen::Vector3d> points_a = samples(a), points_b = samples(b);
    double sampled_m = 1e9;
    for (const auto& p : points_a) {
      for (size_t j = 0; j < points_b.size(); j += 7)
        sampled_m = std::min(sampled_m, (p - points_b[j]).norm());
    }
    const bool separated = internal::BoundsApart(a, b, gap_m);
    if (sampled_m <= gap_m) {
      EXPECT_FALSE(separated) << trial;
    }
    apart += separated;
    near += sampled_m <= gap_m;
  }
  std::printf("bound pairs: %d culled, %d within the gap (never culled)\n", apart, near);
  EXPECT_GT(apart, 30);  // it does cull
  EXPECT_GT(near, 30);
}

// A pole in a hole: a cylinder of radius 15 mm along z, a wall piece 10 mm from its surface off a diagonal of
// its cross-section, where a box around the cylinder would reach within 4 mm.
TEST(BoundsApart, ACylinderIsCulledAsACylinderNotItsBox) {
  internal::Bound pole;
  pole.kind = internal::Bound::Kind::kCylinder;
  pole.half_m = Eigen::Vector3d(0.015, 0.015, 0.5);
  internal::Bound wall;
  const Eigen::Vector3d diagonal = Eigen::Vector3d(1.0, 1.0, 0.0).normalized();
  wall.R_WB.col(0) = diagonal;  // radial, the piece 5 mm thick, 4 mm wide, 100 mm long
  wall.R_WB.col(1) = Eigen::Vector3d::UnitZ().cross(diagonal);
  wall.R_WB.col(2) = Eigen::Vector3d::UnitZ();
  wall.half_m = Eigen::Vector3d(0.0025, 0.002, 0.05);
  wall.center_W = (0.025 + 0.0025) * diagonal;
  EXPECT_TRUE(internal::BoundsApart(pole, wall, 0.0066));
  internal::Bound pole_box = pole;
  pole_box.kind = internal::Bound::Kind::kBox;
  EXPECT_FALSE(internal::BoundsApart(pole_box, wall, 0.0066));
}

// A thin plate turned 30 degrees about two axes: its principal box holds every point and is as thin as the
// plate, where its bounds along the frame's axes are not.
TEST(PrincipalBox, FitsATurnedPlate) {
  const Eigen::Matrix3d R =
      (Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  std::vector<Eigen::Vector3d> points;
  for (const double x : {-0.1, 0.1}) {
    for (const double y : {-0.05, 0.05}) {
      for (const double z : {-0.002, 0.002})
        points.push_back(Eigen::Vector3d(0.3, 0.2, 0.1) + R * Eigen::Vector3d(x, y, z));
    }
  }
  const internal::ShapeBox box = internal::PrincipalBox(points);
  for (const auto& p : points) {
    const Eigen::Vector3d p_B = box.R_SB.transpose() * (p - box.center_S);
    EXPECT_TRUE((p_B.cwiseAbs().array() <= box.half_m.array() + 1e-12).all());
  }
  EXPECT_NEAR(box.half_m.minCoeff(), 0.002, 1e-9);
  EXPECT_NEAR(box.half_m.maxCoeff(), 0.1, 1e-9);
}

}  // namespace
}  // namespace iapsim::physics
