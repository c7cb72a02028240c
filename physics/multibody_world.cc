#include "physics/multibody_world.h"

#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyFixedConstraint.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>
#include <LinearMath/btConvexHullComputer.h>
#include <btBulletDynamicsCommon.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "model/mesh.h"
#include "physics/internal/bullet_eigen.h"
#include "physics/internal/collision_configuration.h"
#include "physics/internal/cone_limit.h"
#include "physics/internal/contact_solver.h"

namespace iapsim::physics {
namespace {

using internal::Bt;
using internal::BtMatrix;
using internal::Eig;

// Bullet grows a cone outward by its collision margin (0.04 m by default, the size of a docking cone)
constexpr double kConeMargin_m = 0.001;

// GJK and EPA collide convex shapes grown by a margin. A mesh's hull is first moved inward by it, so the
// grown surface is the mesh's own with edges rounded to this radius (a smaller one where the hull's centre is
// closer than four margins to a face: Bullet clamps the inward move there).
constexpr double kMeshMargin_m = 0.001;

// compound shapes with more children than this find the ones near a contact through a tree of their bounds
constexpr size_t kCompoundTreeChildren = 8;

// Bullet's fixed constraint, correcting most of its position error in one step. The velocity-level solve
// leaves an error of order (ω·step)²·r each step (a tumbling pair's centripetal motion); the world's error
// reduction (0.2 a step, tuned for contacts) would let it build up to five times that. Not 1: some margin
// for the iterative solver.
class LatchConstraint final : public btMultiBodyFixedConstraint {
 public:
  using btMultiBodyFixedConstraint::btMultiBodyFixedConstraint;
  void createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                            const btContactSolverInfo& info) override {
    btContactSolverInfo latch_info = info;
    latch_info.m_erp = 0.8;
    btMultiBodyFixedConstraint::createConstraintRows(rows, data, latch_info);
  }
};

// Bullet's per-body frame C: the CoM with principal axes (Bullet takes diagonal inertias only).
struct PrincipalFrame {
  Eigen::Isometry3d X_BC = Eigen::Isometry3d::Identity();
  Eigen::Vector3d inertia_C = Eigen::Vector3d::Zero();
};

PrincipalFrame PrincipalFrameOf(const model::MassProperties& mass) {
  PrincipalFrame frame;
  frame.X_BC.translation() = mass.com_B_m;
  const Eigen::Matrix3d& I = mass.inertia_B_kgm2;
  if ((I - Eigen::Matrix3d(I.diagonal().asDiagonal())).isZero(0.0)) {
    frame.inertia_C = I.diagonal();  // already principal: keep the body axes
    return frame;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(I);
  Eigen::Matrix3d R_BC = solver.eigenvectors();
  if (R_BC.determinant() < 0.0) R_BC.col(2) *= -1.0;
  frame.X_BC.linear() = R_BC;
  frame.inertia_C = solver.eigenvalues();
  return frame;
}

}  // namespace

struct MultibodyWorld::Impl {
  struct Body {
    std::string name;
    btMultiBody* multibody = nullptr;                        // a multibody link, or
    btRigidBody* rigid = nullptr;                            // a world object
    int link = -1;                                           // multibody: -1 for the base
    int parent_body = -2;                                    // multibody links: the joint's parent body
    Eigen::Isometry3d X_CB = Eigen::Isometry3d::Identity();  // B in Bullet's frame C
    double mass_kg = 0.0;
    Eigen::Matrix3d inertia_B_kgm2 = Eigen::Matrix3d::Zero();
    int multibody_index = -1;  // into `multibodies`, -1 for an object
    double radius_m = 0.0;     // of its collision shapes about its CoM: a point's speed is at most v + ω r
  };

  // what was applied to a body in a step (AddForce_W, AddTorque_W)
  struct Load {
    Eigen::Vector3d force_W_N = Eigen::Vector3d::Zero();
    Eigen::Vector3d torque_W_Nm = Eigen::Vector3d::Zero();
    bool SameAs(const Load& other) const {
      constexpr double kTolerance = 1e-6;  // N, N·m
      return (force_W_N - other.force_W_N).cwiseAbs().maxCoeff() <= kTolerance &&
             (torque_W_Nm - other.torque_W_Nm).cwiseAbs().maxCoeff() <= kTolerance;
    }
  };

  struct Sleep {
    double still_s = 0.0;  // how long it has been at rest under the same loads
    bool asleep = false;   // we put it to sleep (Bullet's island follows within two steps)
    bool settled = false;  // Bullet's island sleeps too: from now on a stepped island means a wake-up
  };

  // The constraint is made when the latch is declared, so closing it in the loop does not allocate.
  struct Latch {
    int body_a = 0;  // the constraint's A: always a multibody link
    int body_b = 0;
    btCollisionObject* collider_a = nullptr;
    btCollisionObject* collider_b = nullptr;
    std::unique_ptr<LatchConstraint> constraint;
    bool closed = false;

    bool Joins(const void* a, const void* b) const {
      return (a == collider_a && b == collider_b) || (a == collider_b && b == collider_a);
    }
  };

  // Bullet's own group/mask test, and no contact pair between the two bodies of a closed latch. A pair
  // filter because setIgnoreCollisionCheck has no effect between multibody links (NOTES).
  struct LatchPairFilter : btOverlapFilterCallback {
    explicit LatchPairFilter(const std::vector<Latch>* all) : latches(all) {}
    bool needBroadphaseCollision(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) const override {
      if (!(proxy0->m_collisionFilterGroup & proxy1->m_collisionFilterMask) ||
          !(proxy1->m_collisionFilterGroup & proxy0->m_collisionFilterMask)) {
        return false;
      }
      // two static bodies never move: their contacts carry no force and only cost narrowphase time (a
      // static compound on the ground is a pair per part: 97 for the peg-in-hole funnel)
      const auto* object0 = static_cast<const btCollisionObject*>(proxy0->m_clientObject);
      const auto* object1 = static_cast<const btCollisionObject*>(proxy1->m_clientObject);
      if (object0->isStaticObject() && object1->isStaticObject()) return false;
      for (const Latch& latch : *latches) {
        if (latch.closed && latch.Joins(proxy0->m_clientObject, proxy1->m_clientObject)) return false;
      }
      return true;
    }
    const std::vector<Latch>* latches;
  };

  double step_s;
  WorldConfig settings;
  // before the broadphase that calls the filter, so both outlive it
  std::vector<Latch> latches;
  LatchPairFilter latch_filter{&latches};

  // friction of a spherical joint (model::JointResistance), applied as joint torques before each step
  struct JointFriction {
    btMultiBody* multibody;
    int link;
    double viscous_Nms_per_rad, coulomb_Nm;
    double stiction_speed_rad_s;  // Coulomb friction grows linearly up to this relative speed
  };
  std::vector<JointFriction> joint_frictions;
  std::vector<std::unique_ptr<internal::ConeLimit>> cone_limits;

  void ApplyJointFriction() {
    for (const JointFriction& joint : joint_frictions) {
      const btScalar* rate = joint.multibody->getJointVelMultiDof(joint.link);  // ω relative, child frame
      const double speed = std::sqrt(rate[0] * rate[0] + rate[1] * rate[1] + rate[2] * rate[2]);
      const double per_rate =
          joint.viscous_Nms_per_rad + joint.coulomb_Nm / std::max(speed, joint.stiction_speed_rad_s);
      for (int i = 0; i < 3; ++i) joint.multibody->addJointTorqueMultiDof(joint.link, i, -per_rate * rate[i]);
    }
  }
  internal::CollisionConfiguration collision_config;
  internal::Dispatcher dispatcher{&collision_config, settings.contact_breaking_distance_m};
  btDbvtBroadphase broadphase;
  internal::ContactSolver solver;
  btMultiBodyDynamicsWorld world{&dispatcher, &broadphase, &solver, &collision_config};

  // triangle meshes (the data Bullet's mesh shapes point into), before the shapes that use them
  std::vector<std::unique_ptr<model::TriangleMesh>> meshes;
  std::vector<std::unique_ptr<btTriangleIndexVertexArray>> mesh_arrays;
  std::vector<std::unique_ptr<internal::ShapeBox>> shape_boxes;  // before the shapes that point to them
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btMultiBody>> multibodies;
  std::vector<std::vector<int>> multibody_bodies;  // per multibody: body id of Bullet link k − 1 (base first)
  std::vector<std::unique_ptr<btMultiBodyLinkCollider>> colliders;
  std::vector<std::unique_ptr<btMotionState>> motion_states;
  std::vector<std::unique_ptr<btRigidBody>> rigid_bodies;  // objects, and the ground
  struct StaticObject {
    btRigidBody* rigid;
    btVector3 aabb_min, aabb_max;  // in W, fixed
  };
  std::vector<StaticObject> static_objects;

  std::vector<Body> bodies;
  std::vector<BodyState> states;
  std::vector<Load> loads, last_loads,
      sleep_loads;             // per body: this step's, the last step's, when it fell asleep
  std::vector<Sleep> sleep;    // per multibody
  std::vector<char> touching;  // per multibody: it has a contact point this step
  std::vector<Contact> contacts;
  int64_t step_count = 0;

  // forward kinematics scratch (grown once per multibody size)
  btAlignedObjectArray<btQuaternion> world_to_local;
  btAlignedObjectArray<btVector3> local_origin;
  std::vector<btVector3> link_omega, link_velocity;

  Impl(const WorldConfig& config, double step) : step_s(step), settings(config) {
    world.setGravity(btVector3(0.0, 0.0, config.gravity_mps2));
    btContactSolverInfo& info = world.getSolverInfo();
    info.m_numIterations = config.solver_iterations;
    // Bullet compares the largest squared velocity change of a row in an iteration with this
    info.m_leastSquaresResidualThreshold = config.solver_tolerance_mps * config.solver_tolerance_mps;
    solver.set_warm_start(config.warm_start);
    solver.set_factored_rows(config.factored_contact_rows);
    // rigid bodies' contacts (movable world objects) are Bullet's own rows, warm started by Bullet with the
    // whole last impulse as well (its default 0.85 leaves a resting crate 1e-3 N off its weight at the
    // tolerance)
    if (config.warm_start) {
      info.m_warmstartingFactor = 1.0;
    } else {
      info.m_solverMode &= ~SOLVER_USE_WARMSTARTING;
    }
    info.m_reportSolverAnalytics = 1;  // iterations and residual per island solve, for SolverStats
    world.getPairCache()->setOverlapFilterCallback(&latch_filter);
  }

  // every collision object gets it: a manifold solves the points within the smaller of its two bodies'
  void SetContactProcessingThreshold(btCollisionObject* object) const {
    object->setContactProcessingThreshold(settings.speculative_contact_speed_mps * step_s);
  }

  SolverStats solver_stats;
  btAlignedObjectArray<btSolverAnalyticsData> island_analytics;

  void CollectSolverStats() {
    world.getAnalyticsData(island_analytics);
    for (int i = 0; i < island_analytics.size(); ++i) {
      const btSolverAnalyticsData& island = island_analytics[i];
      if (island.m_numIterationsUsed <= 0) continue;
      ++solver_stats.solves;
      solver_stats.iterations += static_cast<uint64_t>(island.m_numIterationsUsed);
      solver_stats.max_iterations = std::max(solver_stats.max_iterations, island.m_numIterationsUsed);
      const double residual_mps = std::sqrt(std::max(0.0, island.m_remainingLeastSquaresResidual));
      if (island.m_numIterationsUsed >= settings.solver_iterations &&
          residual_mps > settings.solver_tolerance_mps) {
        ++solver_stats.capped_solves;
        solver_stats.max_residual_mps = std::max(solver_stats.max_residual_mps, residual_mps);
      }
    }
  }

  ~Impl() {
    for (auto& latch : latches) {
      if (latch.closed) world.removeMultiBodyConstraint(latch.constraint.get());
    }
    for (auto& cone : cone_limits) world.removeMultiBodyConstraint(cone.get());
    for (auto& body : rigid_bodies) world.removeRigidBody(body.get());
    for (auto& collider : colliders) world.removeCollisionObject(collider.get());
    for (auto& multibody : multibodies) world.removeMultiBody(multibody.get());
  }

  // A convex mesh collides as one hull per part of its file (a convex decomposition loads as its pieces); a
  // mesh on a static body may collide with its triangles (btBvhTriangleMeshShape). Bullet's shape for
  // triangles on a moving body (GImpact) is not used: its maintainers advise convex pieces for moving bodies
  // and triangle meshes for static ones only (bullet3 issue #106), and PyBullet also reads an OBJ's objects
  // as one hull each (bullet3 issue #4532). So a moving body's non-convex mesh is an error.
  void MakeMeshShapes(const model::Shape& shape, model::BodyMotion motion, const std::string& body,
                      std::vector<std::unique_ptr<btCollisionShape>>* out) {
    const std::string what = body + ": mesh " + shape.mesh_file;
    if (!shape.mesh_convex && motion == model::BodyMotion::kMoving) {
      throw std::invalid_argument(what +
                                  ": a moving body collides as one convex hull per part of the file "
                                  "(split the mesh into convex parts); triangles collide on static bodies");
    }
    auto mesh = std::make_unique<model::TriangleMesh>();
    try {
      *mesh = model::LoadTriangleMesh(shape.mesh_file, shape.mesh_scale);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(body + ": " + e.what());
    }
    if (shape.mesh_convex) {
      std::vector<Eigen::Vector3d> points_m;
      for (size_t p = 0; p < mesh->parts.size(); ++p) {
        const model::TriangleMesh::Part& part = mesh->parts[p];
        points_m.clear();
        for (int t = part.first_triangle; t < part.first_triangle + part.triangle_count; ++t) {
          for (const int v : mesh->triangles[t]) points_m.push_back(mesh->vertices_m[v]);
        }
        // the hull's corners only (GJK's support search is linear in them), moved inward by the margin
        btConvexHullComputer hull;
        const double shrink_m = hull.compute(points_m[0].data(), sizeof(Eigen::Vector3d),
                                             static_cast<int>(points_m.size()), kMeshMargin_m,
                                             /*shrinkClamp=*/0.25);
        if (!(shrink_m > 0.0)) {  // clamped to nothing: no face has anything behind it
          throw std::invalid_argument(what + ": part " + std::to_string(p + 1) +
                                      " is flat (a convex part needs a volume)");
        }
        auto convex = std::make_unique<btConvexHullShape>();
        for (int i = 0; i < hull.vertices.size(); ++i) {
          convex->addPoint(hull.vertices[i], /*recalcAabb=*/false);
        }
        convex->recalcLocalAabb();
        convex->setMargin(shrink_m);
        // the piece's own box, for culling it against other shapes before GJK (the hull with its margin lies
        // within the mesh's points)
        shape_boxes.push_back(std::make_unique<internal::ShapeBox>(internal::PrincipalBox(points_m)));
        convex->setUserPointer(shape_boxes.back().get());
        out->push_back(std::move(convex));
      }
      return;
    }
    // Bullet reads the triangles in place: 3 ints and 3 doubles each, as Eigen stores them
    static_assert(sizeof(Eigen::Vector3i) == 3 * sizeof(int) &&
                  sizeof(Eigen::Vector3d) == 3 * sizeof(btScalar));
    auto array = std::make_unique<btTriangleIndexVertexArray>(
        static_cast<int>(mesh->triangles.size()), mesh->triangles[0].data(),
        static_cast<int>(sizeof(Eigen::Vector3i)), static_cast<int>(mesh->vertices_m.size()),
        mesh->vertices_m[0].data(), static_cast<int>(sizeof(Eigen::Vector3d)));
    out->push_back(
        std::make_unique<btBvhTriangleMeshShape>(array.get(), /*useQuantizedAabbCompression=*/true));
    meshes.push_back(std::move(mesh));
    mesh_arrays.push_back(std::move(array));
  }

  btCollisionShape* MakeShape(const std::vector<model::Shape>& list, const Eigen::Isometry3d& X_CB,
                              model::BodyMotion motion, const std::string& body) {
    std::vector<std::unique_ptr<btCollisionShape>> children;
    std::vector<btTransform> X_C_children;
    for (const auto& shape : list) {
      switch (shape.kind) {
        case model::Shape::Kind::kBox:
          children.push_back(std::make_unique<btBoxShape>(Bt(0.5 * shape.box_size_m)));
          break;
        case model::Shape::Kind::kCylinder:
          children.push_back(std::make_unique<btCylinderShapeZ>(
              btVector3(shape.radius_m, shape.radius_m, 0.5 * shape.length_m)));
          break;
        case model::Shape::Kind::kSphere:
          children.push_back(std::make_unique<btSphereShape>(shape.radius_m));
          break;
        case model::Shape::Kind::kCone:
          children.push_back(std::make_unique<btConeShapeZ>(shape.radius_m, shape.length_m));
          children.back()->setMargin(kConeMargin_m);
          break;
        case model::Shape::Kind::kMesh:
          MakeMeshShapes(shape, motion, body, &children);
          break;
      }
      Eigen::Isometry3d X_BS = Eigen::Isometry3d::Identity();
      X_BS.translation() = shape.origin_B_m;
      X_BS.linear() = model::RotationFromRpy(shape.rpy_B_rad);
      const Eigen::Isometry3d X_CS = X_CB * X_BS;
      btTransform transform;
      transform.setOrigin(Bt(Eigen::Vector3d(X_CS.translation())));
      transform.setRotation(Bt(Eigen::Quaterniond(X_CS.linear())));
      X_C_children.resize(children.size(), transform);  // every piece this shape made
    }
    // one shape in the body's frame needs no compound around it (a sub-aircraft's box: its collision against
    // the ground then skips a compound algorithm a step)
    if (children.size() == 1 && X_C_children[0] == btTransform::getIdentity()) {
      shapes.push_back(std::move(children[0]));
      return shapes.back().get();
    }
    // a tree of the children's bounds pays off for many (a decomposed mesh: a pole in the funnel's 97 pieces
    // steps 8% faster), not for a vehicle's few shapes
    auto compound = std::make_unique<btCompoundShape>(
        /*enableDynamicAabbTree=*/children.size() > kCompoundTreeChildren, static_cast<int>(children.size()));
    for (size_t i = 0; i < children.size(); ++i) {
      compound->addChildShape(X_C_children[i], children[i].get());
      shapes.push_back(std::move(children[i]));
    }
    shapes.push_back(std::move(compound));
    return shapes.back().get();
  }

  static void ApplyMaterial(btCollisionObject* object, const Material& material) {
    object->setFriction(material.friction);
    object->setRestitution(material.restitution);
    if (material.contact_stiffness_N_per_m > 0.0) {
      object->setContactStiffnessAndDamping(material.contact_stiffness_N_per_m,
                                            material.contact_damping_Ns_per_m);
    }
  }

  void AddGround(const WorldConfig& config) {
    // the plane n·x = c with n = −z (up in NED): z = ground_z_m
    shapes.push_back(std::make_unique<btStaticPlaneShape>(btVector3(0.0, 0.0, -1.0), -config.ground_z_m));
    btRigidBody::btRigidBodyConstructionInfo info(0.0, nullptr, shapes.back().get());
    rigid_bodies.push_back(std::make_unique<btRigidBody>(info));
    btRigidBody* ground = rigid_bodies.back().get();
    ApplyMaterial(ground, config.ground_material);
    ground->setUserIndex(kGround);
    SetContactProcessingThreshold(ground);
    world.addRigidBody(ground, btBroadphaseProxy::StaticFilter, btBroadphaseProxy::AllFilter);
  }

  void AddObject(const WorldObject& object) {
    if (object.shapes.empty()) throw std::invalid_argument("object '" + object.name + "' has no shape");
    btCollisionShape* shape =
        MakeShape(object.shapes, Eigen::Isometry3d::Identity(),
                  object.mass_kg > 0.0 ? model::BodyMotion::kMoving : model::BodyMotion::kStatic,
                  "object '" + object.name + "'");
    btVector3 inertia = Bt(object.inertia_kgm2);
    if (object.mass_kg > 0.0 && object.inertia_kgm2.isZero())
      shape->calculateLocalInertia(object.mass_kg, inertia);
    btTransform pose;
    pose.setOrigin(Bt(object.p_WO_m));
    pose.setRotation(Bt(object.q_WO.normalized()));
    motion_states.push_back(std::make_unique<btDefaultMotionState>(pose));
    btRigidBody::btRigidBodyConstructionInfo info(object.mass_kg, motion_states.back().get(), shape, inertia);
    info.m_linearDamping = 0.0;
    info.m_angularDamping = 0.0;
    rigid_bodies.push_back(std::make_unique<btRigidBody>(info));
    btRigidBody* rigid = rigid_bodies.back().get();
    ApplyMaterial(rigid, object.material);
    // a movable object never sleeps (Bullet's test for rigid bodies is its own); a static one is inactive,
    // so a sleeping vehicle resting on it is not collided with it
    if (object.mass_kg > 0.0) rigid->setActivationState(DISABLE_DEACTIVATION);
    rigid->setUserIndex(static_cast<int>(bodies.size()));
    SetContactProcessingThreshold(rigid);
    world.addRigidBody(rigid, object.filter.group, object.filter.mask);
    if (object.mass_kg == 0.0) {
      StaticObject fixed{rigid, {}, {}};
      shape->getAabb(pose, fixed.aabb_min, fixed.aabb_max);
      static_objects.push_back(fixed);
    }

    Body body;
    body.name = object.name;
    body.rigid = rigid;
    body.mass_kg = object.mass_kg;
    body.inertia_B_kgm2 = Eig(inertia).asDiagonal();
    btVector3 center_O;  // an object's frame is its centre of mass
    btScalar radius_m;
    shape->getBoundingSphere(center_O, radius_m);
    body.radius_m = center_O.length() + radius_m;
    bodies.push_back(body);
    states.emplace_back();
    ResizeLoads();
  }

  void UpdateBody(int id, const Eigen::Quaterniond& q_WC, const Eigen::Vector3d& p_WC,
                  const Eigen::Vector3d& w_W, const Eigen::Vector3d& v_WC_W, bool first) {
    const Body& body = bodies[id];
    BodyState& state = states[id];
    const Eigen::Isometry3d X_WC = Eigen::Translation3d(p_WC) * q_WC;
    const Eigen::Isometry3d X_WB = X_WC * body.X_CB;
    const Eigen::Vector3d v_WB_W = v_WC_W + w_W.cross(X_WB.translation() - p_WC);
    if (first) {
      state.a_WB_W.setZero();
      state.alpha_WB_W.setZero();
      state.a_WBcom_W.setZero();
    } else {  // the mean acceleration over the last step
      state.a_WB_W = (v_WB_W - state.v_WB_W) / step_s;
      state.alpha_WB_W = (w_W - state.w_WB_W) / step_s;
      state.a_WBcom_W = (v_WC_W - state.v_WBcom_W) / step_s;
    }
    state.p_WB_m = X_WB.translation();
    state.q_WB = Eigen::Quaterniond(X_WB.linear());
    state.v_WB_W = v_WB_W;
    state.w_WB_W = w_W;
    state.p_WBcom_m = p_WC;
    state.v_WBcom_W = v_WC_W;
  }

  void UpdateStates(bool first) {
    for (size_t m = 0; m < multibodies.size(); ++m) {
      btMultiBody* mb = multibodies[m].get();
      const int n = mb->getNumLinks();
      world_to_local.resize(n + 1);
      local_origin.resize(n + 1);
      link_omega.resize(n + 1);
      link_velocity.resize(n + 1);
      mb->forwardKinematics(world_to_local, local_origin);
      mb->compTreeLinkVelocities(link_omega.data(), link_velocity.data());
      for (int k = 0; k <= n; ++k) {  // k = Bullet link + 1 (0: the base); values in the link's frame C
        const Eigen::Quaterniond q_WC = Eig(world_to_local[k].inverse());
        UpdateBody(multibody_bodies[m][k], q_WC, Eig(local_origin[k]), q_WC * Eig(link_omega[k]),
                   q_WC * Eig(link_velocity[k]), first);
      }
    }
    for (size_t i = 0; i < bodies.size(); ++i) {
      const btRigidBody* rigid = bodies[i].rigid;
      if (!rigid) continue;
      const btTransform& X = rigid->getCenterOfMassTransform();
      UpdateBody(static_cast<int>(i), Eig(X.getRotation()), Eig(X.getOrigin()),
                 Eig(rigid->getAngularVelocity()), Eig(rigid->getLinearVelocity()), first);
    }
  }

  int BodyOf(const btCollisionObject* object) const { return object->getUserIndex(); }

  static btCollisionObject* ColliderOf(const Body& body) {
    if (body.rigid) return body.rigid;
    return body.link < 0 ? body.multibody->getBaseCollider() : body.multibody->getLink(body.link).m_collider;
  }

  // Bullet's frame C of a body (its CoM, principal axes), from the body's state
  Eigen::Isometry3d X_WC(int body) const {
    const BodyState& state = states[body];
    return Eigen::Translation3d(state.p_WB_m) * state.q_WB * bodies[body].X_CB.inverse();
  }

  // Sleeping is ours, not Bullet's (whose test sums squared velocities of mixed units and ignores loads):
  // Bullet may not sleep or wake a multibody by itself (canSleep with canWakeup off, a threshold it never
  // meets); we put it to sleep, and Bullet's islands then skip it until we wake it or a moving body touching
  // it keeps its island awake.
  static void AllowSleepByUsOnly(btMultiBody* multibody) {
    multibody->setCanSleep(true);
    multibody->setCanWakeup(false);
    multibody->setSleepThreshold(-1.0);
  }

  // a force at the body's CoM and a torque, for the next step only
  void ApplyToBullet(int body, const Load& load) {
    const Body& b = bodies[body];
    if (b.rigid) {
      b.rigid->applyCentralForce(Bt(load.force_W_N));
      b.rigid->applyTorque(Bt(load.torque_W_Nm));
    } else if (b.link < 0) {
      b.multibody->addBaseForce(Bt(load.force_W_N));
      b.multibody->addBaseTorque(Bt(load.torque_W_Nm));
    } else {
      b.multibody->addLinkForce(b.link, Bt(load.force_W_N));
      b.multibody->addLinkTorque(b.link, Bt(load.torque_W_Nm));
    }
  }

  void ResizeLoads() {
    loads.resize(bodies.size());
    last_loads.resize(bodies.size());
    sleep_loads.resize(bodies.size());
  }

  void Wake(int body) {
    const int m = bodies[body].multibody_index;
    if (m < 0) return;
    sleep[m] = Sleep();
    btMultiBody* multibody = multibodies[m].get();
    multibody->wakeUp();
    for (const int b : multibody_bodies[m]) {
      if (btCollisionObject* collider = ColliderOf(bodies[b])) collider->activate(true);
    }
  }

  // before a step: a sleeping multibody whose loads changed wakes with this step's loads only (Bullet clears
  // a multibody's forces after stepping it, so while it slept they piled up)
  void WakeOnChangedLoads() {
    for (size_t m = 0; m < multibodies.size(); ++m) {
      if (!sleep[m].asleep) continue;
      const std::vector<int>& members = multibody_bodies[m];
      const bool changed = std::any_of(members.begin(), members.end(),
                                       [&](int b) { return !loads[b].SameAs(sleep_loads[b]); });
      if (sleep[m].settled) multibodies[m]->clearForcesAndTorques();
      if (!changed) continue;
      Wake(members[0]);
      for (const int b : members) ApplyToBullet(b, loads[b]);
    }
  }

  void UpdateSleep() {
    for (size_t m = 0; m < multibodies.size(); ++m) {
      btMultiBody* multibody = multibodies[m].get();
      Sleep& state = sleep[m];
      const std::vector<int>& members = multibody_bodies[m];
      if (state.asleep) {
        // Bullet's island sleeps two steps after goToSleep, unless a moving body in it keeps it awake; once
        // it slept, a stepped island means such a body woke it
        const btCollisionObject* collider = ColliderOf(bodies[members[0]]);
        const bool island_sleeps = collider && collider->getActivationState() == ISLAND_SLEEPING;
        state.still_s += step_s;
        if (island_sleeps) {
          state.settled = true;
        } else if (state.settled || state.still_s > settings.sleep_after_s + 10.0 * step_s) {
          Wake(members[0]);
        }
        continue;
      }
      // only a vehicle that touches something: contacts hold it where loads and gravity balance, whatever
      // is left over; a free body would drift, however slowly
      bool still = settings.sleep_after_s > 0.0 && touching[m];
      for (const int b : members) {
        const BodyState& body = states[b];
        still = still &&
                body.v_WBcom_W.norm() + body.w_WB_W.norm() * bodies[b].radius_m < settings.sleep_speed_mps &&
                loads[b].SameAs(last_loads[b]);
      }
      state.still_s = still ? state.still_s + step_s : 0.0;
      if (!still || state.still_s < settings.sleep_after_s) continue;
      // at rest: it sleeps with zero velocities (below the threshold anyway) and these loads
      multibody->setBaseVel(btVector3(0.0, 0.0, 0.0));
      multibody->setBaseOmega(btVector3(0.0, 0.0, 0.0));
      const double zero[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
      for (int link = 0; link < multibody->getNumLinks(); ++link) {
        if (multibody->getLink(link).m_dofCount > 0) multibody->setJointVelMultiDof(link, zero);
      }
      multibody->goToSleep();
      state.asleep = true;
      for (const int b : members) {
        sleep_loads[b] = loads[b];
        states[b].v_WB_W.setZero();
        states[b].w_WB_W.setZero();
        states[b].v_WBcom_W.setZero();
      }
    }
    last_loads.swap(loads);
    for (Load& load : loads) load = Load();
  }

  void CollectContacts() {
    contacts.clear();
    std::fill(touching.begin(), touching.end(), 0);
    const int manifolds = dispatcher.getNumManifolds();
    for (int m = 0; m < manifolds; ++m) {
      const btPersistentManifold* manifold = dispatcher.getManifoldByIndexInternal(m);
      const int a = BodyOf(manifold->getBody0());
      const int b = BodyOf(manifold->getBody1());
      for (int p = 0; p < manifold->getNumContacts(); ++p) {
        const btManifoldPoint& point = manifold->getContactPoint(p);
        if (point.getDistance() <= manifold->getContactProcessingThreshold()) ++solver_stats.contact_points;
        if (point.getDistance() > 0.0 && point.getAppliedImpulse() == 0.0) continue;  // not touching
        Contact contact;
        contact.body_a = a;
        contact.body_b = b;
        contact.point_W_m = Eig(point.getPositionWorldOnA());
        contact.normal_W = Eig(point.m_normalWorldOnB);
        const btVector3 impulse = point.m_normalWorldOnB * point.m_appliedImpulse +
                                  point.m_lateralFrictionDir1 * point.m_appliedImpulseLateral1 +
                                  point.m_lateralFrictionDir2 * point.m_appliedImpulseLateral2;
        contact.force_on_a_W_N = Eig(impulse) / step_s;
        contact.depth_m = point.getDistance();
        contacts.push_back(contact);
        for (const int body : {a, b}) {
          if (body >= 0 && bodies[body].multibody_index >= 0) touching[bodies[body].multibody_index] = 1;
        }
      }
    }
  }
};

MultibodyWorld::MultibodyWorld(const WorldConfig& config, double step_s)
    : impl_(std::make_unique<Impl>(config, step_s)) {
  if (!(step_s > 0.0)) throw std::invalid_argument("physics step must be positive");
  if (config.ground) impl_->AddGround(config);
  for (const auto& object : config.objects) impl_->AddObject(object);
  impl_->UpdateStates(true);
}

MultibodyWorld::~MultibodyWorld() = default;

int MultibodyWorld::AddMultibody(const std::string& name, const model::MultibodyDescription& description,
                                 const Eigen::Vector3d& p_WR_m, const Eigen::Quaterniond& q_WR,
                                 const Material& material, const CollisionFilter& filter,
                                 const Eigen::Vector3d& v_WR_W_mps, const Eigen::Vector3d& w_WR_W_radps) {
  Impl& impl = *impl_;
  const int links = static_cast<int>(description.links.size());
  if (links < 1 || description.joints.size() + 1 != description.links.size()) {
    throw std::invalid_argument(description.name +
                                ": a multibody is a tree: one joint per link but the root");
  }
  std::vector<PrincipalFrame> frames;
  for (const auto& link : description.links) frames.push_back(PrincipalFrameOf(link.mass));

  // Bullet numbers links by joint (a parent before its children): joint j makes Bullet link j
  std::vector<int> bullet_link(links, -1);
  for (size_t j = 0; j < description.joints.size(); ++j) {
    const auto& joint = description.joints[j];
    if (joint.child <= 0 || joint.child >= links || bullet_link[joint.child] != -1 ||
        (joint.parent != 0 && bullet_link[joint.parent] == -1)) {
      throw std::invalid_argument(description.name + ": joint '" + joint.name + "' is not in tree order");
    }
    bullet_link[joint.child] = static_cast<int>(j);
  }

  const auto& root = description.links[0];
  auto multibody = std::make_unique<btMultiBody>(links - 1, root.mass.mass_kg, Bt(frames[0].inertia_C),
                                                 /*fixedBase=*/false, /*canSleep=*/false);
  btMultiBody* mb = multibody.get();
  std::vector<Impl::JointFriction> frictions;  // kept once the multibody is in the world
  std::vector<std::unique_ptr<internal::ConeLimit>> cones;
  for (size_t j = 0; j < description.joints.size(); ++j) {
    const auto& joint = description.joints[j];
    const PrincipalFrame& parent = frames[joint.parent];
    const PrincipalFrame& child = frames[joint.child];
    const Eigen::Matrix3d R_PpC = parent.X_BC.linear();  // parent body frame -> parent principal frame
    const Eigen::Matrix3d R_CcC = child.X_BC.linear();
    const Eigen::Matrix3d R_PpCc = model::RotationFromRpy(joint.rpy_parent_rad);
    // rotates vectors from the parent's principal frame into the child's, at the zero joint position
    const Eigen::Matrix3d R_parent_to_child = (R_PpC.transpose() * R_PpCc * R_CcC).transpose();
    const Eigen::Vector3d parent_com_to_pivot =
        R_PpC.transpose() * (joint.origin_parent_m - parent.X_BC.translation());
    const Eigen::Vector3d pivot_to_child_com = R_CcC.transpose() * child.X_BC.translation();
    const double mass = description.links[joint.child].mass.mass_kg;
    const int parent_link = bullet_link[joint.parent];
    const btQuaternion rotation = Bt(Eigen::Quaterniond(R_parent_to_child));
    if (joint.type == model::JointType::kSpherical) {
      mb->setupSpherical(static_cast<int>(j), mass, Bt(child.inertia_C), parent_link, rotation,
                         Bt(parent_com_to_pivot), Bt(pivot_to_child_com), /*disableParentCollision=*/true);
      const model::JointResistance& resistance = joint.resistance;
      if (resistance.viscous_Nms_per_rad > 0.0 || resistance.coulomb_Nm > 0.0) {
        // applied explicitly, so the torque's slope over the relative speed, times the step over the
        // child's smallest inertia (the relative motion's inertia is at most that), must stay below 1 for the
        // speed to decay without overshoot: the Coulomb part's linear range widens to keep its half of that
        // (a regularised Coulomb friction, as Drake's stiction tolerance)
        const double inertia_kgm2 = child.inertia_C.minCoeff();
        if (resistance.viscous_Nms_per_rad * impl.step_s >= 0.5 * inertia_kgm2) {
          throw std::invalid_argument(description.name + ": joint '" + joint.name + "': viscous friction " +
                                      std::to_string(resistance.viscous_Nms_per_rad) +
                                      " N·m·s/rad is too large for a " + std::to_string(impl.step_s) +
                                      " s step (at most half the child's inertia over the step)");
        }
        constexpr double kStictionSpeed_rad_s = 0.01;
        frictions.push_back(
            {mb, static_cast<int>(j), resistance.viscous_Nms_per_rad, resistance.coulomb_Nm,
             std::max(kStictionSpeed_rad_s, 2.0 * resistance.coulomb_Nm * impl.step_s / inertia_kgm2)});
      }
      if (resistance.max_tilt_rad > 0.0) {
        if (description.links[joint.child].collision.empty()) {  // Bullet islands a constraint by colliders
          throw std::invalid_argument(description.name + ": joint '" + joint.name +
                                      "' has a cone limit, so its child needs a collision shape");
        }
        // the child's z axis, and where it points at the zero joint position, in Bullet's frames
        const Eigen::Vector3d axis_C = R_CcC.transpose() * Eigen::Vector3d::UnitZ();
        const Eigen::Vector3d rest_parent_C = R_PpC.transpose() * R_PpCc * Eigen::Vector3d::UnitZ();
        cones.push_back(std::make_unique<internal::ConeLimit>(mb, static_cast<int>(j), Bt(axis_C),
                                                              Bt(rest_parent_C), resistance.max_tilt_rad));
      }
    } else {
      mb->setupFixed(static_cast<int>(j), mass, Bt(child.inertia_C), parent_link, rotation,
                     Bt(parent_com_to_pivot), Bt(pivot_to_child_com));
    }
  }
  mb->finalizeMultiDof();
  const Eigen::Isometry3d X_WR = Eigen::Translation3d(p_WR_m) * q_WR.normalized();
  const Eigen::Isometry3d X_WC = X_WR * frames[0].X_BC;
  mb->setBasePos(Bt(Eigen::Vector3d(X_WC.translation())));
  mb->setWorldToBaseRot(Bt(Eigen::Quaterniond(X_WC.linear())).inverse());
  // Bullet's base velocity is its CoM's: v_WC = v_WR + w × (p_WC − p_WR)
  mb->setBaseVel(Bt(Eigen::Vector3d(v_WR_W_mps + w_WR_W_radps.cross(X_WC.translation() - p_WR_m))));
  mb->setBaseOmega(Bt(w_WR_W_radps));
  // fidelity over Bullet's game defaults (NOTES): no damping, no clamps, sleeping only by our own test
  mb->setLinearDamping(0.0);
  mb->setAngularDamping(0.0);
  mb->setMaxCoordinateVelocity(1e30);
  mb->setMaxAppliedImpulse(1e30);
  mb->setUseGyroTerm(true);
  Impl::AllowSleepByUsOnly(mb);
  mb->setHasSelfCollision(true);
  impl.world.addMultiBody(mb, filter.group, filter.mask);

  const int root_id = static_cast<int>(impl.bodies.size());
  for (int k = 0; k < links; ++k) {
    const auto& link = description.links[k];
    Impl::Body body;
    body.name = name + "/" + link.name;
    body.multibody = mb;
    body.link = k == 0 ? -1 : bullet_link[k];
    body.X_CB = frames[k].X_BC.inverse();
    body.mass_kg = link.mass.mass_kg;
    body.inertia_B_kgm2 = link.mass.inertia_B_kgm2;
    body.multibody_index = static_cast<int>(impl.multibodies.size());
    if (k > 0) {
      for (const auto& joint : description.joints) {
        if (joint.child == k) body.parent_body = root_id + joint.parent;
      }
    }
    impl.bodies.push_back(body);
    impl.states.emplace_back();
    if (link.collision.empty()) continue;
    auto collider = std::make_unique<btMultiBodyLinkCollider>(mb, body.link);
    collider->setCollisionShape(
        impl.MakeShape(link.collision, body.X_CB, model::BodyMotion::kMoving, body.name));
    btVector3 center_C;  // the shapes are in Bullet's frame C, centred on the CoM
    btScalar radius_m;
    collider->getCollisionShape()->getBoundingSphere(center_C, radius_m);
    impl.bodies.back().radius_m = center_C.length() + radius_m;
    Impl::ApplyMaterial(collider.get(), material);
    collider->setUserIndex(root_id + k);
    impl.SetContactProcessingThreshold(collider.get());
    impl.world.addCollisionObject(collider.get(), filter.group, filter.mask);
    if (k == 0) {
      mb->setBaseCollider(collider.get());
    } else {
      mb->getLink(body.link).m_collider = collider.get();
    }
    impl.colliders.push_back(std::move(collider));
  }
  std::vector<int> body_of_link(links);
  for (int k = 0; k < links; ++k) body_of_link[bullet_link[k] + 1] = root_id + k;
  impl.multibodies.push_back(std::move(multibody));
  impl.multibody_bodies.push_back(body_of_link);
  impl.sleep.emplace_back();
  impl.touching.push_back(0);
  impl.ResizeLoads();
  impl.world_to_local.resize(links);
  impl.local_origin.resize(links);
  mb->updateCollisionObjectWorldTransforms(impl.world_to_local, impl.local_origin);
  impl.UpdateStates(true);
  impl.joint_frictions.insert(impl.joint_frictions.end(), frictions.begin(), frictions.end());
  for (auto& cone : cones) {
    impl.world.addMultiBodyConstraint(cone.get());
    impl.cone_limits.push_back(std::move(cone));
  }
  return root_id;
}

int MultibodyWorld::body_count() const { return static_cast<int>(impl_->bodies.size()); }
const std::string& MultibodyWorld::body_name(int body) const { return impl_->bodies.at(body).name; }

int MultibodyWorld::FindBody(const std::string& name) const {
  for (size_t i = 0; i < impl_->bodies.size(); ++i) {
    if (impl_->bodies[i].name == name) return static_cast<int>(i);
  }
  return -2;
}

double MultibodyWorld::mass_kg(int body) const { return impl_->bodies.at(body).mass_kg; }
Eigen::Matrix3d MultibodyWorld::inertia_B_kgm2(int body) const {
  return impl_->bodies.at(body).inertia_B_kgm2;
}

void MultibodyWorld::AddForce_W(int body, const Eigen::Vector3d& force_W_N) {
  Impl::Load load;
  load.force_W_N = force_W_N;
  impl_->loads[body].force_W_N += force_W_N;
  impl_->ApplyToBullet(body, load);
}

void MultibodyWorld::AddTorque_W(int body, const Eigen::Vector3d& torque_W_Nm) {
  Impl::Load load;
  load.torque_W_Nm = torque_W_Nm;
  impl_->loads[body].torque_W_Nm += torque_W_Nm;
  impl_->ApplyToBullet(body, load);
}

void MultibodyWorld::AddJointTorque_W(int body, const Eigen::Vector3d& torque_W_Nm) {
  const Impl::Body& b = impl_->bodies.at(body);
  if (b.parent_body < 0) throw std::invalid_argument(b.name + " has no joint to a parent");
  AddTorque_W(body, torque_W_Nm);
  AddTorque_W(b.parent_body, -torque_W_Nm);
}

int MultibodyWorld::AddLatch(int body_a, int body_b) {
  Impl& impl = *impl_;
  if (body_a == body_b) {
    throw std::invalid_argument("a latch needs two bodies, got '" + body_name(body_a) + "' twice");
  }
  Impl::Latch latch;
  latch.body_a = body_a;
  latch.body_b = body_b;
  if (!impl.bodies.at(body_a).multibody) std::swap(latch.body_a, latch.body_b);
  const Impl::Body& a = impl.bodies.at(latch.body_a);
  const Impl::Body& b = impl.bodies.at(latch.body_b);
  const std::string what = "latch between '" + a.name + "' and '" + b.name + "': ";
  if (!a.multibody) {
    throw std::invalid_argument(what + "one of them must be a multibody link (a vehicle's body)");
  }
  latch.collider_a = impl.ColliderOf(a);
  latch.collider_b = impl.ColliderOf(b);
  if (!latch.collider_a || !latch.collider_b) {
    throw std::invalid_argument(what +
                                "both need collision shapes (Bullet solves a latch only between colliders)");
  }
  // frames and pivots are set when it closes
  const btVector3 zero(0.0, 0.0, 0.0);
  const btMatrix3x3 identity = btMatrix3x3::getIdentity();
  if (b.rigid) {
    latch.constraint =
        std::make_unique<LatchConstraint>(a.multibody, a.link, b.rigid, zero, zero, identity, identity);
  } else {
    latch.constraint = std::make_unique<LatchConstraint>(a.multibody, a.link, b.multibody, b.link, zero, zero,
                                                         identity, identity);
  }
  latch.constraint->setMaxAppliedImpulse(1e30);  // Bullet's default caps it at 100 N·s a step
  impl.latches.push_back(std::move(latch));
  return static_cast<int>(impl.latches.size()) - 1;
}

void MultibodyWorld::CloseLatch(int latch) {
  Impl& impl = *impl_;
  Impl::Latch& l = impl.latches.at(latch);
  if (l.closed) return;
  // The constraint frame is B's frame C at closing, pivot halfway between the CoMs. frameInB = identity
  // because Bullet maps a rigid body's frameInB as frameInB^T R_WC but a link's as R_WC frameInB: the two
  // agree for the identity only.
  const Eigen::Isometry3d X_WCa = impl.X_WC(l.body_a);
  const Eigen::Isometry3d X_WCb = impl.X_WC(l.body_b);
  const Eigen::Vector3d p_W_pivot = 0.5 * (X_WCa.translation() + X_WCb.translation());
  l.constraint->setPivotInA(Bt(Eigen::Vector3d(X_WCa.inverse() * p_W_pivot)));
  l.constraint->setPivotInB(Bt(Eigen::Vector3d(X_WCb.inverse() * p_W_pivot)));
  l.constraint->setFrameInA(BtMatrix(X_WCa.linear().transpose() * X_WCb.linear()));
  l.constraint->setFrameInB(btMatrix3x3::getIdentity());
  impl.world.addMultiBodyConstraint(l.constraint.get());
  l.closed = true;
  impl.Wake(l.body_a);
  impl.Wake(l.body_b);
  // drop the pair's contacts now; the filter keeps the pair from coming back
  impl.world.getPairCache()->removeOverlappingPair(l.collider_a->getBroadphaseHandle(),
                                                   l.collider_b->getBroadphaseHandle(), &impl.dispatcher);
}

void MultibodyWorld::OpenLatch(int latch) {
  Impl& impl = *impl_;
  Impl::Latch& l = impl.latches.at(latch);
  if (!l.closed) return;
  impl.world.removeMultiBodyConstraint(l.constraint.get());
  l.closed = false;
  impl.Wake(l.body_a);
  impl.Wake(l.body_b);
  // The broadphase reports a pair only when a body leaves its fattened bounds, so bodies that overlap
  // already would not collide until one of them moved away: add their pair back now.
  btBroadphaseProxy* proxy_a = l.collider_a->getBroadphaseHandle();
  btBroadphaseProxy* proxy_b = l.collider_b->getBroadphaseHandle();
  if (TestAabbAgainstAabb2(proxy_a->m_aabbMin, proxy_a->m_aabbMax, proxy_b->m_aabbMin, proxy_b->m_aabbMax)) {
    impl.world.getPairCache()->addOverlappingPair(proxy_a, proxy_b);
  }
}

bool MultibodyWorld::latched(int latch) const { return impl_->latches.at(latch).closed; }

void MultibodyWorld::Step() {
  Impl& impl = *impl_;
  impl.WakeOnChangedLoads();
  impl.ApplyJointFriction();
  impl.world.stepSimulation(impl.step_s, 0);                   // exactly one step of step_s (no accumulator)
  for (auto& rigid : impl.rigid_bodies) rigid->clearForces();  // multibodies clear theirs in the step
  ++impl.step_count;
  impl.UpdateStates(false);
  impl.CollectContacts();
  impl.CollectSolverStats();
  impl.UpdateSleep();
}

double MultibodyWorld::step_s() const { return impl_->step_s; }
int64_t MultibodyWorld::step_count() const { return impl_->step_count; }
const BodyState& MultibodyWorld::body(int body) const { return impl_->states.at(body); }
const std::vector<Contact>& MultibodyWorld::contacts() const { return impl_->contacts; }
const SolverStats& MultibodyWorld::solver_stats() const { return impl_->solver_stats; }

double MultibodyWorld::StaticSurfaceDistance_m(const Eigen::Vector3d& from_W,
                                               const Eigen::Vector3d& direction_W, double max_m) const {
  const Impl& impl = *impl_;
  double distance_m = max_m;
  if (impl.settings.ground && direction_W.z() > 0.0) {  // the ground is below, at larger z
    distance_m = std::clamp((impl.settings.ground_z_m - from_W.z()) / direction_W.z(), 0.0, distance_m);
  }
  const btVector3 from = Bt(from_W);
  for (const Impl::StaticObject& object : impl.static_objects) {
    const btVector3 to = Bt(from_W + distance_m * direction_W);
    btVector3 ray_min = from, ray_max = from;
    ray_min.setMin(to);
    ray_max.setMax(to);
    if (!TestAabbAgainstAabb2(ray_min, ray_max, object.aabb_min, object.aabb_max)) continue;
    btCollisionWorld::ClosestRayResultCallback hit(from, to);
    btTransform from_pose(btQuaternion::getIdentity(), from), to_pose(btQuaternion::getIdentity(), to);
    btCollisionWorld::rayTestSingle(from_pose, to_pose, object.rigid, object.rigid->getCollisionShape(),
                                    object.rigid->getWorldTransform(), hit);
    if (hit.hasHit()) distance_m *= hit.m_closestHitFraction;
  }
  return distance_m;
}

bool MultibodyWorld::movable(int body) const {
  const Impl::Body& b = impl_->bodies.at(body);
  return b.multibody != nullptr || !b.rigid->isStaticObject();
}

double MultibodyWorld::bounding_radius_m(int body) const { return impl_->bodies.at(body).radius_m; }

double MultibodyWorld::BodyRayFraction(int body, const Eigen::Vector3d& from_W,
                                       const Eigen::Vector3d& to_W) const {
  btCollisionObject* collider = Impl::ColliderOf(impl_->bodies.at(body));
  if (!collider) return 1.0;
  const btVector3 from = Bt(from_W), to = Bt(to_W);
  btVector3 ray_min = from, ray_max = from;
  ray_min.setMin(to);
  ray_max.setMax(to);
  // from the shapes: the broadphase's boxes of a new multibody are stale until its first step
  btVector3 aabb_min, aabb_max;
  collider->getCollisionShape()->getAabb(collider->getWorldTransform(), aabb_min, aabb_max);
  if (!TestAabbAgainstAabb2(ray_min, ray_max, aabb_min, aabb_max)) return 1.0;
  btCollisionWorld::ClosestRayResultCallback hit(from, to);
  const btTransform from_pose(btQuaternion::getIdentity(), from), to_pose(btQuaternion::getIdentity(), to);
  btCollisionWorld::rayTestSingle(from_pose, to_pose, collider, collider->getCollisionShape(),
                                  collider->getWorldTransform(), hit);
  return hit.hasHit() ? hit.m_closestHitFraction : 1.0;
}

bool MultibodyWorld::asleep(int body) const {
  const int m = impl_->bodies.at(body).multibody_index;
  return m >= 0 && impl_->sleep[m].asleep;
}

Eigen::Vector3d MultibodyWorld::ContactForce_W(int body) const {
  Eigen::Vector3d force_W_N = Eigen::Vector3d::Zero();
  for (const Contact& c : impl_->contacts) {
    if (c.body_a == body) force_W_N += c.force_on_a_W_N;
    if (c.body_b == body) force_W_N -= c.force_on_a_W_N;
  }
  return force_W_N;
}

}  // namespace iapsim::physics
