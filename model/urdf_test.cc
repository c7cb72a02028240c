#include "model/urdf.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "bridge/config.h"
#include "model/vehicle.h"
#include "tests/support/test_folder.h"

namespace iapsim::model {
namespace {

namespace fs = std::filesystem;

std::string VehiclePath(const std::string& name) {
  return std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/" + name + ".yaml";
}

std::string F450() { return std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/parts/f450.yaml"; }

std::string WriteTemp(const std::string& name, const std::string& text) {
  static const test_support::TestFolder folder("urdf_test");
  return folder.Write(name + ".yaml", text);
}

TEST(Vehicle, EveryShippedConfigurationLoadsAndRoundTripsThroughUrdf) {
  for (const auto& entry : fs::directory_iterator(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles")) {
    if (entry.path().extension() != ".yaml") continue;  // parts/ holds pieces, not vehicles
    SCOPED_TRACE(entry.path().string());
    const Vehicle vehicle = LoadVehicle(entry.path().string());
    const MultibodyDescription model = ParseUrdf(GenerateUrdf(vehicle), vehicle.name + ".urdf");
    ASSERT_EQ(model.links.size(), 1 + vehicle.tools.size() + vehicle.sub_aircraft.size());
    EXPECT_EQ(model.links[0].name, "platform");
    double total = 0.0;
    for (const auto& link : model.links) total += link.mass.mass_kg;
    EXPECT_DOUBLE_EQ(total, vehicle.TotalMass_kg());
    for (const SubAircraft& sub : vehicle.sub_aircraft) {
      // urdfdom orders a link's child joints by name, not as written
      const auto joint_it =
          std::find_if(model.joints.begin(), model.joints.end(),
                       [&](const JointDescription& j) { return model.links[j.child].name == sub.name; });
      ASSERT_NE(joint_it, model.joints.end()) << sub.name;
      const JointDescription& joint = *joint_it;
      EXPECT_EQ(joint.parent, 0);
      EXPECT_EQ(joint.type, sub.joint);
      EXPECT_EQ(joint.origin_parent_m, sub.joint_P_m);  // exact: numbers are written with 17 digits
      EXPECT_NEAR(std::remainder(joint.rpy_parent_rad.z() - sub.initial_yaw_rad, 2 * M_PI), 0.0, 1e-12);
      EXPECT_EQ(model.links[joint.child].mass.inertia_B_kgm2, sub.mass.inertia_B_kgm2);
    }
  }
}

// `iapsim urdf --ros`: every shipped vehicle's display URDF, and that of one whose joints have friction and
// a cone limit, passes check_urdf (liburdfdom-tools), and urdfdom reads it as a tree rooted at base_link with
// the whole mass, each spherical joint as roll (x), pitch (y) and yaw (z) joints from the joint's place to
// the sub-aircraft (roll and pitch limited to the cone, each with the joint's friction), and a visual for
// every part.
TEST(Urdf, TheRosFlavourOfEveryShippedVehiclePassesCheckUrdf) {
  ASSERT_EQ(access("/usr/bin/check_urdf", X_OK), 0)
      << "no check_urdf (liburdfdom-tools, tools/install-deps.sh)";
  const test_support::TestFolder folder("urdf_ros");
  std::vector<std::string> vehicles;
  for (const auto& entry : fs::directory_iterator(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles")) {
    if (entry.path().extension() == ".yaml") vehicles.push_back(entry.path().string());
  }
  vehicles.push_back(
      WriteTemp("resisting",
                "name: resisting\n"
                "platform: {mass_kg: 2.0, inertia_kgm2: [0.05, 0.05, 0.1]}\n"
                "sub_aircraft_defaults: {base: " +
                    F450() +
                    ", joint_friction: {viscous_Nms_per_rad: 0.02, coulomb_Nm: 0.01}, "
                    "joint_max_tilt_deg: 30}\n"
                    "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n"));
  for (const std::string& path : vehicles) {
    SCOPED_TRACE(path);
    const Vehicle vehicle = LoadVehicle(path);
    const std::string xml = GenerateRosUrdf(vehicle);
    const fs::path file = folder.path() / (vehicle.name + ".urdf"), log = folder.path() / "check_urdf.log";
    std::ofstream(file) << xml;
    EXPECT_EQ(std::system(("/usr/bin/check_urdf " + file.string() + " > " + log.string() + " 2>&1").c_str()),
              0)
        << std::ifstream(log).rdbuf();
    const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(xml);
    ASSERT_TRUE(model);
    EXPECT_EQ(model->getRoot()->name, "base_link");
    double total = 0.0;
    std::vector<urdf::LinkSharedPtr> links;
    model->getLinks(links);
    for (const auto& link : links) total += link->inertial ? link->inertial->mass : 0.0;
    EXPECT_NEAR(total, vehicle.TotalMass_kg(), 1e-12);
    for (const SubAircraft& sub : vehicle.sub_aircraft) {
      SCOPED_TRACE(sub.name);
      const urdf::LinkConstSharedPtr link = model->getLink(sub.name);
      ASSERT_TRUE(link);
      EXPECT_FALSE(link->visual_array.empty());
      if (sub.joint != JointType::kSpherical) continue;
      // from the sub-aircraft up: yaw, pitch, roll, then the platform
      urdf::LinkConstSharedPtr at = link;
      for (const auto& [name, axis] :
           {std::pair{"yaw", urdf::Vector3(0, 0, 1)}, std::pair{"pitch", urdf::Vector3(0, 1, 0)},
            std::pair{"roll", urdf::Vector3(1, 0, 0)}}) {
        const urdf::JointConstSharedPtr joint = at->parent_joint;
        ASSERT_TRUE(joint);
        EXPECT_EQ(joint->name, sub.name + "_" + name);
        EXPECT_EQ(joint->type, sub.joint_resistance.max_tilt_rad > 0.0 && std::string(name) != "yaw"
                                   ? urdf::Joint::REVOLUTE
                                   : urdf::Joint::CONTINUOUS);
        EXPECT_EQ(joint->axis.x, axis.x);
        EXPECT_EQ(joint->axis.y, axis.y);
        EXPECT_EQ(joint->axis.z, axis.z);
        if (joint->type == urdf::Joint::REVOLUTE) {
          EXPECT_DOUBLE_EQ(joint->limits->upper, sub.joint_resistance.max_tilt_rad);
          EXPECT_DOUBLE_EQ(joint->limits->lower, -sub.joint_resistance.max_tilt_rad);
        }
        if (sub.joint_resistance.viscous_Nms_per_rad > 0.0) {
          ASSERT_TRUE(joint->dynamics);
          EXPECT_DOUBLE_EQ(joint->dynamics->damping, sub.joint_resistance.viscous_Nms_per_rad);
          EXPECT_DOUBLE_EQ(joint->dynamics->friction, sub.joint_resistance.coulomb_Nm);
        }
        at = model->getLink(joint->parent_link_name);
        ASSERT_TRUE(at);
      }
      EXPECT_EQ(at->name, "platform");
      const urdf::Vector3& origin =
          model->getJoint(sub.name + "_roll")->parent_to_joint_origin_transform.position;
      EXPECT_EQ(Eigen::Vector3d(origin.x, origin.y, origin.z), sub.joint_P_m);
    }
  }
}

TEST(Vehicle, ThreeStarMatchesTableI) {
  const Vehicle v = LoadVehicle(VehiclePath("three_star"));
  EXPECT_DOUBLE_EQ(v.platform.mass_kg, 1.1);
  ASSERT_EQ(v.sub_aircraft.size(), 3u);
  for (const auto& sub : v.sub_aircraft) {
    EXPECT_DOUBLE_EQ(sub.mass.mass_kg, 1.6);
    EXPECT_NEAR(sub.joint_P_m.head<2>().norm(), 0.48, 1e-12);  // d_h
    EXPECT_DOUBLE_EQ(sub.joint_P_m.z(), 0.07);                 // d_v
    EXPECT_EQ(sub.joint, JointType::kSpherical);
    // parts/f450.yaml: X layout, spins cancel, 2.6x the sub-aircraft's weight at full speed
    ASSERT_EQ(sub.rotors.hub_S_m.size(), 4u);
    EXPECT_EQ(sub.rotors.spin[0] + sub.rotors.spin[1] + sub.rotors.spin[2] + sub.rotors.spin[3], 0);
    EXPECT_NEAR(sub.rotors.hub_S_m[0].norm(), 0.225, 1e-12);
    EXPECT_NEAR(4 * sub.rotors.MaxThrust_N() / (1.6 * 9.81), 2.6, 0.05);
    EXPECT_DOUBLE_EQ(sub.rotors.radius_m, 0.127);
    EXPECT_DOUBLE_EQ(sub.rotors.drag_N_per_radps_mps, 8.06428e-5);
    EXPECT_DOUBLE_EQ(sub.rotors.rolling_moment_Nm_per_radps_mps, 1e-6);
  }
  EXPECT_DOUBLE_EQ(v.TotalMass_kg(), 5.9);
  // equilateral: the joints' centroid is the platform origin
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& sub : v.sub_aircraft) centroid += sub.joint_P_m / 3.0;
  EXPECT_LT(centroid.head<2>().norm(), 1e-12);
}

TEST(Vehicle, AnyNumberOfSubAircraftFromYamlAlone) {
  std::string text =
      "name: hexa\n"
      "platform: {mass_kg: 2.0, inertia_kgm2: [0.05, 0.05, 0.1], collision: [{box: [0.3, 0.3, 0.05]}]}\n"
      "sub_aircraft_defaults: {base: " +
      F450() +
      "}\n"
      "sub_aircraft:\n";
  for (int i = 0; i < 6; ++i) {
    const double a = i * M_PI / 3.0;
    text += "  - {joint_m: [" + std::to_string(0.6 * std::cos(a)) + ", " + std::to_string(0.6 * std::sin(a)) +
            ", 0.05]}\n";
  }
  const Vehicle v = LoadVehicle(WriteTemp("hexa", text));
  ASSERT_EQ(v.sub_aircraft.size(), 6u);
  EXPECT_EQ(v.sub_aircraft[5].name, "sub6");
  EXPECT_TRUE(v.platform_drag_area_B_m2.isZero());  // no drag unless a vehicle says
  // drag areas: per part, a sub-aircraft's from its defaults unless it says otherwise
  const std::string with_drag =
      "name: hexa\n"
      "platform: {mass_kg: 2.0, inertia_kgm2: [0.05, 0.05, 0.1], drag_area_m2: [0.01, 0.02, 0.03]}\n"
      "sub_aircraft_defaults: {base: " +
      F450() +
      ", drag_area_m2: [0.004, 0.004, 0.02]}\n"
      "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0], drag_area_m2: [0, 0, 0.05]}\n";
  const Vehicle d = LoadVehicle(WriteTemp("drag", with_drag));
  EXPECT_EQ(d.platform_drag_area_B_m2, Eigen::Vector3d(0.01, 0.02, 0.03));
  EXPECT_EQ(d.sub_aircraft[0].drag_area_B_m2, Eigen::Vector3d(0.004, 0.004, 0.02));
  EXPECT_EQ(d.sub_aircraft[1].drag_area_B_m2, Eigen::Vector3d(0.0, 0.0, 0.05));
  EXPECT_EQ(ParseUrdf(GenerateUrdf(v), "hexa").joints.size(), 6u);
}

// A free quadrotor carrying a cone: one sub-aircraft on a fixed joint; the cone survives the URDF round trip
// (URDF has no cone: the pre-parse restores it).
TEST(Vehicle, ASingleQuadrotorCarriesAConeThroughUrdf) {
  const std::string text =
      "name: probe\n"
      "platform: {mass_kg: 0.2, inertia_kgm2: [0.001, 0.001, 0.001]}\n"
      "tools:\n"
      "  - {name: cone, mass_kg: 0.1, inertia_kgm2: [0.0001, 0.0001, 0.0001], origin_m: [0, 0.3, 0],\n"
      "     collision: [{cone: {radius_m: 0.04, length_m: 0.08}, rpy_deg: [-90, 0, 0]}]}\n"
      "sub_aircraft_defaults: {base: " +
      F450() +
      ", joint: fixed}\n"
      "sub_aircraft:\n  - {name: quad, joint_m: [0, 0, 0]}\n";
  const Vehicle v = LoadVehicle(WriteTemp("probe", text));
  ASSERT_EQ(v.sub_aircraft.size(), 1u);
  const std::string urdf = GenerateUrdf(v);
  EXPECT_NE(urdf.find("<cone radius=\"0.04\" length=\"0.08\"/>"), std::string::npos) << urdf;
  const MultibodyDescription model = ParseUrdf(urdf, "probe.urdf");
  ASSERT_EQ(model.links.size(), 3u);
  for (const JointDescription& joint : model.joints) EXPECT_EQ(joint.type, JointType::kFixed);
  for (const LinkDescription& link : model.links) {
    if (link.name == "platform") continue;
    ASSERT_EQ(link.collision.size(), 1u);
    const Shape& shape = link.collision[0];
    if (link.name == "quad") {
      EXPECT_EQ(shape.kind, Shape::Kind::kBox);  // the quadrotor's own box stays a box
      continue;
    }
    EXPECT_EQ(link.name, "cone");
    EXPECT_EQ(shape.kind, Shape::Kind::kCone);
    EXPECT_EQ(shape.radius_m, 0.04);
    EXPECT_EQ(shape.length_m, 0.08);
    EXPECT_NEAR(shape.rpy_B_rad.x(), -M_PI / 2, 1e-12);
  }
}

struct BadVehicle {
  std::string what;
  std::string text;
  std::string expect;
};

TEST(Vehicle, BadYamlGivesTheFileLineAndKey) {
  const std::string good_platform = "platform: {mass_kg: 1.1, inertia_kgm2: [0.02, 0.02, 0.04]}\n";
  const std::string subs = "sub_aircraft_defaults: {base: " + F450() +
                           "}\n"
                           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n";
  const std::vector<BadVehicle> cases = {
      {"typo", "name: x\n" + good_platform + subs + "extra_key: 1\n", "extra_key: unknown key"},
      {"triangle", "name: x\nplatform: {mass_kg: 1, inertia_kgm2: [0.01, 0.01, 0.05]}\n" + subs,
       "platform.inertia_kgm2: violates the triangle inequality"},
      {"negative", "name: x\nplatform: {mass_kg: 1, inertia_kgm2: [-0.01, 0.01, 0.01]}\n" + subs,
       "not positive definite"},
      {"no sub",
       "name: x\n" + good_platform + "sub_aircraft_defaults: {base: " + F450() + "}\nsub_aircraft: []\n",
       "sub_aircraft: expected a list of sub-aircraft"},
      {"one spherical sub",
       "name: x\n" + good_platform + "sub_aircraft_defaults: {base: " + F450() +
           "}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n",
       "sub_aircraft[0].joint: a single sub-aircraft must be on a fixed joint"},
      {"no joint",
       "name: x\n" + good_platform + "sub_aircraft_defaults: {base: " + F450() +
           "}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {yaw_deg: 5}\n",
       "sub_aircraft[1].joint_m: is required"},
      {"shape",
       "name: x\nplatform: {mass_kg: 1.1, inertia_kgm2: [0.02, 0.02, 0.04], collision: [{torus: 1}]}\n" +
           subs,
       "a shape is exactly one of"},
      {"no rotors",
       "name: x\n" + good_platform +
           "sub_aircraft_defaults: {mass_kg: 1.6, inertia_kgm2: [0.01, 0.01, 0.02]}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n",
       "sub_aircraft[0].rotors: is required"},
      {"rotor speeds",
       "name: x\n" + good_platform + "sub_aircraft_defaults:\n  base: " + F450() +
           "\n  rotors: {arm_m: 0.2, thrust_coefficient: 1e-5, torque_coefficient: 1e-7,"
           " motor_time_constant_s: 0.02, speed_rad_s: [900, 100]}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n",
       "sub_aircraft_defaults.rotors.speed_rad_s: expected 0 <= min < max"},
      {"propellers that overlap",
       "name: x\n" + good_platform + "sub_aircraft_defaults:\n  base: " + F450() +
           "\n  rotors: {arm_m: 0.2, thrust_coefficient: 1e-5, torque_coefficient: 1e-7,"
           " motor_time_constant_s: 0.02, speed_rad_s: [100, 900], radius_m: 0.15}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n",
       "sub_aircraft_defaults.rotors.radius_m: must be in [0, 0.14"},
      {"cone",
       "name: x\nplatform: {mass_kg: 1.1, inertia_kgm2: [0.02, 0.02, 0.04], collision: [{cone: {radius_m: "
       "0.1}}]}\n" +
           subs,
       "platform.collision[0].cone.length_m: is required"},
      {"drag",
       "name: x\nplatform: {mass_kg: 1.1, inertia_kgm2: [0.02, 0.02, 0.04], drag_area_m2: [0.01, -0.01, "
       "0]}\n" +
           subs,
       "platform.drag_area_m2: expected C_d·A per body axis"},
      {"motor",
       "name: x\n" + good_platform + "sub_aircraft_defaults:\n  base: " + F450() +
           "\n  rotors: {arm_m: 0.2, thrust_coefficient: 1e-5, torque_coefficient: 1e-7,"
           " motor_time_constant_s: 0.02, speed_rad_s: [100, 900], electric: {kv_rpm_per_V: 920,"
           " resistance_ohm: .nan, no_load_current_A: 0.5, time_constant_up_s: 0.01, time_constant_down_s: "
           "0.02}}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n",
       "sub_aircraft_defaults.rotors.electric.resistance_ohm: expected a finite number, got '.nan'"},
      {"thrust curve",
       "name: x\n" + good_platform + "sub_aircraft_defaults:\n  base: " + F450() +
           "\n  rotors: {arm_m: 0.2, thrust_coefficient: 1e-5, torque_coefficient: 1e-7,"
           " motor_time_constant_s: 0.02, speed_rad_s: [100, 900], electric: {kv_rpm_per_V: 920,"
           " resistance_ohm: 0.2, no_load_current_A: 0.5, time_constant_up_s: 0.01, time_constant_down_s: "
           "0.02,"
           " thrust_model_factor: 1.5}}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n",
       "thrust_model_factor: must be in [0, 1]"},
      {"battery",
       "name: x\n" + good_platform + "sub_aircraft_defaults:\n  base: " + F450() +
           "\n  battery: {cells: 0, capacity_mAh: 5000, internal_resistance_ohm: 0.005,"
           " polarization_resistance_ohm: 0.003, polarization_time_constant_s: 30}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n",
       "sub_aircraft_defaults.battery.cells: must be 1 to 24 cells in series"},
      {"gyro filter",
       "name: x\n" + good_platform + "sub_aircraft_defaults:\n  base: " + F450() +
           "\n  flight_controller: {gyro_cutoff_hz: 0}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n",
       "sub_aircraft_defaults.flight_controller.gyro_cutoff_hz: must be in (0, 10000) Hz"},
      {"vector",
       "name: x\n" + good_platform + "sub_aircraft_defaults: {base: " + F450() +
           "}\n"
           "sub_aircraft:\n  - {joint_m: [0.5, 0]}\n  - {joint_m: [-0.5, 0, 0]}\n",
       "expected 3 numbers, got 2"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    const std::string path = WriteTemp("bad", c.text);
    try {
      LoadVehicle(path);
      ADD_FAILURE() << "accepted";
    } catch (const bridge::ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path + ":"), std::string::npos) << what;
      EXPECT_NE(what.find(c.expect), std::string::npos) << what;
    }
  }
}

constexpr char kHandWritten[] = R"(<?xml version="1.0"?>
<robot name="pair">
  <link name="base">
    <inertial><origin xyz="0 0 0.01" rpy="0 0 0"/><mass value="1.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.02"/></inertial>
    <collision><origin xyz="0 0 0" rpy="0 0 0"/><geometry><cylinder radius="0.1" length="0.05"/></geometry></collision>
  </link>
  <link name="arm">
    <inertial><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
  </link>
  <joint name="ball" type="spherical">
    <parent link="base"/><child link="arm"/><origin xyz="0.3 0 0" rpy="0 0 0.5"/>
  </joint>
</robot>
)";

TEST(Urdf, AcceptsSphericalJointsThroughThePreParse) {
  const MultibodyDescription model = ParseUrdf(kHandWritten, "pair.urdf");
  ASSERT_EQ(model.links.size(), 2u);
  ASSERT_EQ(model.joints.size(), 1u);
  EXPECT_EQ(model.joints[0].type, JointType::kSpherical);
  EXPECT_EQ(model.joints[0].origin_parent_m, Eigen::Vector3d(0.3, 0, 0));
  EXPECT_NEAR(model.joints[0].rpy_parent_rad.z(), 0.5, 1e-12);
  EXPECT_EQ(model.links[0].mass.com_B_m, Eigen::Vector3d(0, 0, 0.01));
  ASSERT_EQ(model.links[0].collision.size(), 1u);
  EXPECT_EQ(model.links[0].collision[0].kind, Shape::Kind::kCylinder);
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  return text.replace(text.find(from), from.size(), to);
}

TEST(Urdf, RejectsWhatItCannotSimulateNamingTheFile) {
  const std::string base = kHandWritten;
  // what each broken document below must be rejected with
  const std::vector<std::string> expected = {"not well-formed", "floating", "spherical and fixed joints only",
                                             "positive mass"};
  const std::vector<std::string> documents = {
      base.substr(0, base.find("<link name=\"arm\">")),  // cut short
      Replace(base, "type=\"spherical\"", "type=\"floating\""),
      Replace(Replace(base, "type=\"spherical\"", "type=\"revolute\""), "</joint>",
              "<axis xyz=\"0 0 1\"/><limit lower=\"0\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>"),
      Replace(base, "<mass value=\"0.5\"/>", "<mass value=\"0\"/>"),
  };
  for (size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE(expected[i]);
    try {
      ParseUrdf(documents[i], "bad.urdf");
      ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("bad.urdf"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(expected[i]), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(LoadUrdfFile("/no/such.urdf"), std::invalid_argument);
}

// A solid cylinder's inertia by hand: 2 kg, r = 0.1 m, L = 0.6 m gives m (3 r^2 + L^2) / 12 = 0.065 across
// and m r^2 / 2 = 0.01 kg m^2 about its axis.
TEST(Urdf, ASolidCylinderHasItsTextbookInertiaAndCollidesAsItself) {
  const MultibodyDescription pole = SolidCylinder("pole", 2.0, 0.1, 0.6);
  ASSERT_EQ(pole.links.size(), 1u);
  EXPECT_TRUE(pole.joints.empty());
  const LinkDescription& link = pole.links[0];
  EXPECT_DOUBLE_EQ(link.mass.mass_kg, 2.0);
  EXPECT_NEAR(link.mass.inertia_B_kgm2(0, 0), 0.065, 1e-15);
  EXPECT_NEAR(link.mass.inertia_B_kgm2(1, 1), 0.065, 1e-15);
  EXPECT_NEAR(link.mass.inertia_B_kgm2(2, 2), 0.01, 1e-15);
  EXPECT_TRUE(link.mass.inertia_B_kgm2.isDiagonal(0.0));
  ASSERT_EQ(link.collision.size(), 1u);
  EXPECT_EQ(link.collision[0].kind, Shape::Kind::kCylinder);
  EXPECT_EQ(link.collision[0].radius_m, 0.1);
  EXPECT_EQ(link.collision[0].length_m, 0.6);
}

}  // namespace
}  // namespace iapsim::model
