#include "control/allocation.h"

#include <gtest/gtest.h>

#include <array>
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
    const Eigen::Vector3d d_0 = vehicle.CenterOfMass_P_m();
    // the joints sit below the plate: at a tilt the weight has a moment about P's origin to hold
    ASSERT_GT(std::abs(d_0.z()), 1e-3);
    const Eigen::Quaterniond level = Eigen::Quaterniond::Identity();
    // a tilt about the joint line of an under-actuated IAP (rank 5) has a moment no thrust can hold
    std::vector<Eigen::Quaterniond> attitudes{level};
    if (a.fully_actuated()) attitudes.push_back(AttitudeFromEuler(0.17, -0.26, 0.7));
    for (const Eigen::Quaterniond& q_WP : attitudes) {
      const Eigen::VectorXd thrusts = a.Allocate(HoverWrench(vehicle, q_WP, 9.81));
      Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
      for (size_t i = 0; i < vehicle.sub_aircraft.size(); ++i) {
        const Eigen::Vector3d f = thrusts.segment<3>(3 * i);
        force += f;
        moment += (vehicle.sub_aircraft[i].joint_P_m - d_0).cross(f);
      }
      // in W: the thrusts' resultant is the weight's opposite, and their moment about the CoM zero
      EXPECT_LT((q_WP * force + vehicle.TotalMass_kg() * 9.81 * Eigen::Vector3d::UnitZ()).norm(), 1e-9);
      EXPECT_LT(moment.norm(), 1e-9);
    }
    const Eigen::VectorXd thrusts = a.Allocate(HoverWrench(vehicle, level, 9.81));
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

namespace iapsim::control {
namespace {

// Graceful allocation (issue 23) on the three-square at a tilted, yawed attitude: a demand beyond the limits
// in one part of U, alone or with another, is given up in that part only, and a lower part never takes
// authority from a higher one.
class GracefulAllocation : public ::testing::Test {
 protected:
  GracefulAllocation()
      : vehicle_(Shipped("three_square")),
        allocation_(vehicle_),
        R_WP_(AttitudeFromEuler(0.08, -0.05, 0.5).toRotationMatrix()) {
    for (const auto& sub : vehicle_.sub_aircraft) {
      const double count = static_cast<double>(sub.rotors.hub_S_m.size());
      limits_.push_back(ThrustLimits{count * sub.rotors.MinThrust_N(), 0.9 * count * sub.rotors.MaxThrust_N(),
                                     60.0 * M_PI / 180.0});
    }
    hover_ = HoverWrench(vehicle_, Eigen::Quaterniond(R_WP_), 9.81);
    // per part a demand that alone does not fit (the three-square lifts about 2.5 times its weight)
    const Eigen::Vector3d vertical_P = R_WP_.transpose() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d horizontal_P = R_WP_.transpose() * Eigen::Vector3d(0.6, -0.8, 0.0);
    excess_[0] << 3.0 * hover_.head<3>(), Eigen::Vector3d::Zero();
    excess_[1] << Eigen::Vector3d::Zero(), 60.0, -40.0, 0.0;
    excess_[2] << 400.0 * horizontal_P, Eigen::Vector3d::Zero();
    excess_[3] << Eigen::Vector3d::Zero(), 0.0, 0.0, 80.0;
    EXPECT_LT(std::abs(vertical_P.dot(horizontal_P)), 1e-12);
  }

  // Allocates U, checks the result is within every limit and realises kept[p] of each part exactly.
  std::array<double, kWrenchParts> Allocate(const Vector6d& U) {
    std::array<double, kWrenchParts> kept;
    const Eigen::VectorXd thrusts_P = AllocateWithinLimits(allocation_, U, R_WP_, limits_, kept.data());
    for (size_t i = 0; i < limits_.size(); ++i) {
      EXPECT_TRUE(limits_[i].Admits(R_WP_ * thrusts_P.segment<3>(3 * i))) << i;
    }
    const Vector6d realised = allocation_.B() * thrusts_P;  // fully actuated: B B⁺ = I
    for (int p = 0; p < kWrenchParts; ++p) {
      const auto part = static_cast<WrenchPart>(p);
      EXPECT_LT((PartOf(realised, R_WP_, part) - kept[p] * PartOf(U, R_WP_, part)).norm(), 1e-9 * U.norm())
          << p;
    }
    return kept;
  }

  model::Vehicle vehicle_;
  Allocation allocation_;
  Eigen::Matrix3d R_WP_;
  std::vector<ThrustLimits> limits_;
  Vector6d hover_;
  std::array<Vector6d, kWrenchParts> excess_;
};

TEST_F(GracefulAllocation, PartsSumToTheWrench) {
  const Vector6d U = hover_ + excess_[1] + excess_[2] + excess_[3];
  Vector6d sum = Vector6d::Zero();
  for (int p = 0; p < kWrenchParts; ++p) sum += PartOf(U, R_WP_, static_cast<WrenchPart>(p));
  EXPECT_LT((sum - U).norm(), 1e-12 * U.norm());
}

TEST_F(GracefulAllocation, HoverFitsWhole) {
  for (double kept : Allocate(hover_)) EXPECT_EQ(kept, 1.0);
}

TEST_F(GracefulAllocation, EachPartAloneIsCutAndTheHigherOnesKept) {
  for (int p = 0; p < kWrenchParts; ++p) {
    const std::array<double, kWrenchParts> kept = Allocate(hover_ + excess_[p]);
    EXPECT_LT(kept[p], 0.99) << p;  // it did not fit
    EXPECT_GT(kept[p], 0.0) << p;   // but some of it did
    for (int higher = 0; higher < p; ++higher) EXPECT_EQ(kept[higher], 1.0) << p << " over " << higher;
  }
  // the altitude survives a yaw demand the rotors cannot give: the IAP neither climbs nor sinks
  const std::array<double, kWrenchParts> kept = Allocate(hover_ + excess_[3]);
  EXPECT_EQ(kept[0], 1.0);
}

TEST_F(GracefulAllocation, InPairsTheLowerPartGivesWay) {
  for (int high = 0; high < kWrenchParts; ++high) {
    const double alone = Allocate(hover_ + excess_[high])[high];
    for (int low = high + 1; low < kWrenchParts; ++low) {
      const std::array<double, kWrenchParts> kept = Allocate(hover_ + excess_[high] + excess_[low]);
      // the higher part keeps what it kept alone (to the bisection's resolution); the lower gets the rest
      EXPECT_NEAR(kept[high], alone, 1e-9) << high << " with " << low;
      EXPECT_LT(kept[low], 1.0) << high << " with " << low;
      for (int higher = 0; higher < high; ++higher) EXPECT_EQ(kept[higher], 1.0);
    }
  }
}

}  // namespace
}  // namespace iapsim::control
