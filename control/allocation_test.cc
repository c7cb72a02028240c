#include "control/allocation.h"

#include <gtest/gtest.h>

#include <cmath>

namespace iapsim::control {
namespace {

model::Vehicle Shipped(const std::string& name) {
  return model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/" + name + ".yaml");
}

TEST(Allocation, RankTellsFullyFromUnderActuated) {
  EXPECT_TRUE(Allocation(Shipped("three_star")).fully_actuated());
  EXPECT_TRUE(Allocation(Shipped("three_square")).fully_actuated());
  const Allocation two_line(Shipped("two_line"));  // collinear joints, equation (8)
  EXPECT_EQ(two_line.rank(), 5);
  EXPECT_EQ(Allocation(Shipped("three_line")).rank(), 5);
}

TEST(Allocation, PseudoInverseIsMoorePenrose) {
  for (const std::string name : {"three_star", "two_line"}) {
    const Allocation a(Shipped(name));
    const Eigen::MatrixXd& B = a.B();
    const Eigen::MatrixXd& P = a.B_pinv();
    EXPECT_LT((B * P * B - B).norm(), 1e-10) << name;
    EXPECT_LT((P * B * P - P).norm(), 1e-10) << name;
    EXPECT_LT((B * P - (B * P).transpose()).norm(), 1e-10) << name;
    EXPECT_LT((P * B - (P * B).transpose()).norm(), 1e-10) << name;
  }
}

TEST(Allocation, MatchesHandComputedCases) {
  // two-line: d_1,2 = (±0.5, 0, −0.05); the torque rows are d_i^ (equation (6))
  const Allocation two_line(Shipped("two_line"));
  Eigen::Matrix3d hat_1;
  hat_1 << 0, 0.05, 0, -0.05, 0, -0.5, 0, 0.5, 0;
  EXPECT_LT((two_line.B().block<3, 3>(3, 0) - hat_1).norm(), 1e-12);
  EXPECT_LT((two_line.B().block<3, 3>(0, 3) - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  // a vertical force is shared equally; the roll moment about the joint line cannot be made at all
  const Eigen::VectorXd lift = two_line.Allocate((Vector6d() << 0, 0, -40, 0, 0, 0).finished());
  EXPECT_LT((lift - (Eigen::VectorXd(6) << 0, 0, -20, 0, 0, -20).finished()).norm(), 1e-12);

  // three-star: a yaw moment τ becomes equal tangential forces τ / (3 d_h) at the joints (their radial
  // d_v terms cancel around the triangle), a vertical force an equal split
  const model::Vehicle star = Shipped("three_star");
  const Allocation three_star(star);
  const double tau_Nm = 3.0;
  const Eigen::VectorXd yaw = three_star.Allocate((Vector6d() << 0, 0, 0, 0, 0, tau_Nm).finished());
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d& d = star.sub_aircraft[i].joint_P_m;
    const Eigen::Vector3d tangential = Eigen::Vector3d(-d.y(), d.x(), 0.0).normalized();
    EXPECT_LT((yaw.segment<3>(3 * i) - tau_Nm / (3 * 0.48) * tangential).norm(), 1e-9) << i;
  }
  const Eigen::VectorXd up = three_star.Allocate((Vector6d() << 0, 0, -30, 0, 0, 0).finished());
  for (int i = 0; i < 3; ++i) EXPECT_LT((up.segment<3>(3 * i) - Eigen::Vector3d(0, 0, -10)).norm(), 1e-9) << i;
}

TEST(Allocation, HoverThrustsCarryTheWeightWithNoMoment) {
  for (const std::string name : {"three_star", "three_square", "two_line", "three_line"}) {
    SCOPED_TRACE(name);
    const model::Vehicle vehicle = Shipped(name);
    const Allocation a(vehicle);
    const Eigen::Quaterniond level = Eigen::Quaterniond::Identity();
    const Eigen::VectorXd thrusts = a.Allocate(HoverWrench(vehicle, level, 9.81));
    Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
    const Eigen::Vector3d d_0 = vehicle.CenterOfMass_P_m();
    for (size_t i = 0; i < vehicle.sub_aircraft.size(); ++i) {
      const Eigen::Vector3d f = thrusts.segment<3>(3 * i);
      force += f;
      moment += (vehicle.sub_aircraft[i].joint_P_m - d_0).cross(f);
    }
    EXPECT_LT((force + vehicle.TotalMass_kg() * 9.81 * Eigen::Vector3d::UnitZ()).norm(), 1e-9);
    EXPECT_LT(moment.norm(), 1e-9);
    // the same split as the level trim the physics starts vehicles in
    const Eigen::VectorXd trim = vehicle.LevelHoverThrusts_N(9.81);
    for (size_t i = 0; i < vehicle.sub_aircraft.size(); ++i) EXPECT_NEAR(-thrusts[3 * i + 2], trim[i], 1e-9);
  }
}

TEST(Allocation, RollPitchOfEquation18PointTheThrust) {
  for (const double yaw : {0.0, 0.7, -2.5, M_PI}) {
    const Eigen::Vector3d thrust_W(3.0, -4.0, -18.0);
    const Eigen::Vector2d rp = RollPitchForThrust(thrust_W, yaw);
    const Eigen::Quaterniond q = AttitudeFromEuler(rp[0], rp[1], yaw);
    // FRD: thrust acts along −z of the sub-aircraft
    EXPECT_LT((q * Eigen::Vector3d(0.0, 0.0, -1.0) - thrust_W.normalized()).norm(), 1e-12) << yaw;
  }
}

}  // namespace
}  // namespace iapsim::control
