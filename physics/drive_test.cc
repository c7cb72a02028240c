// The electric drive (physics/drive.h): the battery against the Thevenin model's closed form and published
// pack behaviour, the motor against its own equation and momentum theory, PX4's thrust curve against the
// motor it is fitted to, and the drive inside a simulated hover.
#include "physics/drive.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "bridge/config.h"
#include "model/urdf.h"
#include "model/vehicle.h"
#include "physics/physics_config.h"
#include "physics/simulation.h"
#include "tests/support/test_folder.h"

namespace iapsim::physics {
namespace {

const model::Vehicle& ThreeStar() {
  static const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  return vehicle;
}

const model::SubAircraft& F450() { return ThreeStar().sub_aircraft[0]; }

TEST(Battery, OpenCircuitVoltageHasThePublishedShapeOfALithiumPolymerCell) {
  // Holybro's Kakute F4 manual: a healthy 4S pack 80 % drawn rests at about 15.0 V
  EXPECT_NEAR(4.0 * LithiumPolymerCellVoltage_V(0.2), 15.0, 0.15);
  // flat in the middle, a steep knee below 10 % (PX4's BAT_V_EMPTY: "a typical lithium battery can only be
  // discharged down to 10% before it drops off"), monotonic throughout
  const double middle_V_per_unit =
      (LithiumPolymerCellVoltage_V(0.8) - LithiumPolymerCellVoltage_V(0.2)) / 0.6;
  const double knee_V_per_unit =
      (LithiumPolymerCellVoltage_V(0.1) - LithiumPolymerCellVoltage_V(0.05)) / 0.05;
  EXPECT_GT(knee_V_per_unit, 5.0 * middle_V_per_unit);
  for (int i = 0; i < 100; ++i) {
    EXPECT_LT(LithiumPolymerCellVoltage_V(i / 100.0), LithiumPolymerCellVoltage_V((i + 1) / 100.0));
  }
  // between the 3.0 V a cell must not go below and the 4.2 V it is charged to
  EXPECT_GT(LithiumPolymerCellVoltage_V(0.02), 3.0);
  EXPECT_LT(LithiumPolymerCellVoltage_V(1.0), 4.2);
  EXPECT_EQ(LithiumPolymerCellVoltage_V(1.5), LithiumPolymerCellVoltage_V(1.0));
}

TEST(Battery, ConstantCurrentFollowsTheTheveninClosedForm) {
  const model::Battery& battery = F450().battery;
  BatteryPack pack(battery, 0.9);
  const double current_A = 20.0, dt_s = 0.01, duration_s = 60.0;
  for (int k = 0; k < static_cast<int>(duration_s / dt_s); ++k) pack.Step(current_A, dt_s);
  // Coulomb counting, and v_p = R_p I (1 − e^(−t/τ)) from rest
  const double soc = 0.9 - current_A * duration_s / (3600.0 * battery.capacity_Ah);
  EXPECT_NEAR(pack.state_of_charge(), soc, 1e-9);
  const double polarization_V = battery.polarization_resistance_ohm * current_A *
                                (1.0 - std::exp(-duration_s / battery.polarization_time_constant_s));
  EXPECT_NEAR(pack.polarization_V(), polarization_V, 1e-9);
  EXPECT_NEAR(pack.Voltage_V(current_A),
              battery.cells * (LithiumPolymerCellVoltage_V(soc) - polarization_V -
                               battery.internal_resistance_ohm * current_A),
              1e-9);
  // resting recovers the polarisation: after 5 τ less than 1 % of it is left
  for (int k = 0; k < static_cast<int>(5.0 * battery.polarization_time_constant_s / dt_s); ++k)
    pack.Step(0.0, dt_s);
  EXPECT_LT(pack.polarization_V(), 0.01 * polarization_V);
  EXPECT_NEAR(pack.state_of_charge(), soc, 1e-12);
}

TEST(ElectricDrive, SteadySpeedBalancesTheMotorEquation) {
  const model::SubAircraft& f450 = F450();
  const ElectricDrive drive(f450.rotors, f450.battery, 1.0, true, false);
  const model::MotorElectrics& motor = f450.rotors.electric;
  const double k_e = 60.0 / (2.0 * M_PI * motor.kv_rpm_per_V);
  for (const double throttle : {0.2, 0.5, 0.8, 1.0}) {
    for (const double voltage_V : {13.0, 14.8, 16.8}) {
      const double speed = drive.SteadySpeed_rad_s(throttle, voltage_V);
      const double current_A = f450.rotors.torque_coefficient * speed * speed / k_e + motor.no_load_current_A;
      EXPECT_NEAR(throttle * voltage_V, k_e * speed + motor.resistance_ohm * current_A, 1e-9);
      EXPECT_NEAR(drive.MotorCurrent_A(speed), current_A, 1e-12);
    }
  }
  // the shipped numbers: full throttle on the pack's nominal voltage gives the rotor set's top speed
  EXPECT_NEAR(drive.SteadySpeed_rad_s(1.0, 14.8), f450.rotors.max_speed_rad_s, 1.0);
  EXPECT_EQ(drive.SteadySpeed_rad_s(0.0, 14.8), 0.0);  // below the no-load current's drop: standing
  EXPECT_EQ(drive.SteadySpeed_rad_s(1.5, 14.8), drive.SteadySpeed_rad_s(1.0, 14.8));  // the ESC saturates
}

TEST(ElectricDrive, HoverPowerAgreesWithMomentumTheory) {
  // one F450 rotor carrying a quarter of a three-star sub-aircraft's share of the weight
  const model::SubAircraft& f450 = F450();
  const ElectricDrive drive(f450.rotors, f450.battery, 1.0, true, false);
  const double thrust_N = ThreeStar().TotalMass_kg() * 9.81 / 12.0;
  const double speed = std::sqrt(thrust_N / f450.rotors.thrust_coefficient);
  const double shaft_W = f450.rotors.torque_coefficient * speed * speed * speed;
  const double disk_m2 = M_PI * f450.rotors.radius_m * f450.rotors.radius_m;
  const double ideal_W = std::pow(thrust_N, 1.5) / std::sqrt(2.0 * 1.225 * disk_m2);
  const double throttle = drive.ThrottleForThrust(thrust_N);
  // at steady speed the motor takes u V = k_e ω + R I
  const double current_A = drive.MotorCurrent_A(speed);
  const double electric_W = (60.0 / (2.0 * M_PI * f450.rotors.electric.kv_rpm_per_V) * speed +
                             f450.rotors.electric.resistance_ohm * current_A) *
                            current_A;
  std::printf(
      "hover per rotor: %.2f N at %.0f rad/s, throttle %.3f, figure of merit %.2f, motor efficiency %.2f, "
      "%.1f W from the pack\n",
      thrust_N, speed, throttle, ideal_W / shaft_W, shaft_W / electric_W, electric_W);
  // Leishman, Principles of Helicopter Aerodynamics (2006) §2.8: small rotors reach figures of merit of
  // 0.4 to 0.65; a small brushless motor near its design point converts 70 to 85 % of its input
  EXPECT_GT(ideal_W / shaft_W, 0.4);
  EXPECT_LT(ideal_W / shaft_W, 0.65);
  EXPECT_GT(shaft_W / electric_W, 0.7);
  EXPECT_LT(shaft_W / electric_W, 0.85);
}

TEST(ElectricDrive, PxFourThrustCurveFitsTheMotor) {
  const model::SubAircraft& f450 = F450();
  const ElectricDrive drive(f450.rotors, f450.battery, 1.0, true, false);
  const double f = drive.thrust_model_factor();
  std::printf("fitted THR_MDL_FAC %.3f, full-throttle thrust %.2f N\n", f, drive.full_throttle_thrust_N());
  EXPECT_GT(f, 0.0);
  EXPECT_LT(f, 1.0);
  // the thrust the flight controller gets is what it asked for, to 3 % of the full thrust, over the range
  for (double thrust_N = 0.5; thrust_N < drive.full_throttle_thrust_N(); thrust_N += 0.5) {
    const double speed =
        drive.SteadySpeed_rad_s(drive.ThrottleForThrust(thrust_N), drive.battery().charged_voltage_V());
    EXPECT_NEAR(f450.rotors.thrust_coefficient * speed * speed, thrust_N,
                0.03 * drive.full_throttle_thrust_N())
        << thrust_N;
  }
  // a factor from the vehicle file is used as given; 0 is PX4's default, a linear curve
  model::RotorSet linear = f450.rotors;
  linear.electric.thrust_model_factor = 0.0;
  const ElectricDrive linear_drive(linear, f450.battery, 1.0, true, false);
  EXPECT_EQ(linear_drive.thrust_model_factor(), 0.0);
  EXPECT_NEAR(linear_drive.ThrottleForThrust(0.5 * linear_drive.full_throttle_thrust_N()), 0.5, 1e-12);
  EXPECT_EQ(linear_drive.ThrottleForThrust(2.0 * linear_drive.full_throttle_thrust_N()), 1.0);
}

TEST(ElectricDrive, SpinsUpFasterThanItSpinsDown) {
  const model::SubAircraft& f450 = F450();
  ElectricDrive drive(f450.rotors, f450.battery, 1.0, false, false);
  Rotors rotors(f450.rotors, f450.mass.com_B_m);
  const double low_N = 2.0, high_N = 8.0, dt_s = 0.0005;
  const double low = drive.SteadySpeed_rad_s(drive.ThrottleForThrust(low_N), drive.voltage_V());
  const double high = drive.SteadySpeed_rad_s(drive.ThrottleForThrust(high_N), drive.voltage_V());
  // the 63 % point of each step comes one time constant after it
  const auto time_to_63_percent = [&](double from, double to, double thrust_N) {
    rotors.SetDrivenSpeeds(RotorVector::Constant(4, from));
    for (int k = 1;; ++k) {
      drive.Step(RotorVector::Constant(4, thrust_N), dt_s, &rotors);
      if ((rotors.speeds_rad_s()[0] - from) / (to - from) >= 1.0 - std::exp(-1.0)) return k * dt_s;
    }
  };
  EXPECT_NEAR(time_to_63_percent(low, high, high_N), f450.rotors.electric.time_constant_up_s, dt_s);
  EXPECT_NEAR(time_to_63_percent(high, low, low_N), f450.rotors.electric.time_constant_down_s, dt_s);
  EXPECT_EQ(drive.voltage_V(), 4 * kChargedCellVoltage_V);  // no sag: a charged pack's voltage throughout
}

TEST(ElectricDrive, ASaggingPackGivesLessThrustForTheSameCommand) {
  const model::SubAircraft& f450 = F450();
  const double thrust_N = 5.0, dt_s = 0.001;
  const auto settle = [&](double state_of_charge, bool sag, bool scale) {
    ElectricDrive drive(f450.rotors, f450.battery, state_of_charge, sag, scale);
    Rotors rotors(f450.rotors, f450.mass.com_B_m);
    for (int k = 0; k < 5000; ++k) drive.Step(RotorVector::Constant(4, thrust_N), dt_s, &rotors);
    const double speed = rotors.speeds_rad_s()[0];
    return f450.rotors.thrust_coefficient * speed * speed;
  };
  const double full_N = settle(1.0, true, false), low_N = settle(0.15, true, false);
  const double ideal_N = settle(0.15, false, false), scaled_N = settle(0.15, true, true);
  std::printf(
      "5 N asked: %.2f N on a full pack, %.2f N at 15 %%, %.2f N at 15 %% with PX4's battery scale, "
      "%.2f N from an ideal supply\n",
      full_N, low_N, scaled_N, ideal_N);
  // the thrust curve holds on a full pack's voltage and on an ideal supply's, to the accuracy of its fit;
  // a pack at 15 % gives 10 % less; PX4's battery scale, linear in the voltage, gives most of it back
  const double fit_N = 0.03 * f450.rotors.MaxThrust_N();
  EXPECT_NEAR(full_N, thrust_N, fit_N);
  EXPECT_NEAR(ideal_N, thrust_N, fit_N);
  EXPECT_LT(low_N, 0.9 * full_N);
  EXPECT_GT(scaled_N, low_N + 0.5 * (thrust_N - low_N));
  EXPECT_LT(scaled_N, thrust_N);
}

std::string ThreeStarParams() {
  return "vehicles:\n  - {name: iap, file: " + std::string(IAPSIM_SOURCE_DIR) +
         "/configs/vehicles/three_star.yaml}\n";
}

TEST(ElectricDrive, HoversTheThreeStarAndDrainsItsPacks) {
  bridge::YamlMap params(YAML::Load(ThreeStarParams() + "actuation: {state_of_charge: 0.8}\n"), "test.yaml");
  PhysicsConfig config = ReadPhysicsConfig(params, "test.yaml", 0.001);
  ASSERT_TRUE(config.simulation.actuation.enabled);
  config.simulation.vehicles[0].p_WP_m = Eigen::Vector3d(0.0, 0.0, -5.0);
  Simulation sim(config.simulation);
  const double duration_s = 2.0;
  while (sim.time_s() < duration_s) sim.Step();
  const VehicleOutput& out = sim.output(0);
  const double weight_N = sim.vehicle(0).vehicle.TotalMass_kg() * 9.81;
  double thrust_N = 0.0, charge_Ah = 0.0;
  for (const SubAircraftOutput& sub : out.sub_aircraft) {
    thrust_N -= sub.thrust_W_N.z();
    EXPECT_GT(sub.battery_current_A, 15.0);
    EXPECT_LT(sub.battery_current_A, 25.0);
    EXPECT_LT(sub.battery_voltage_V, 4.0 * LithiumPolymerCellVoltage_V(0.8));
    EXPECT_GT(sub.throttle.minCoeff(), 0.4);
    EXPECT_LT(sub.throttle.maxCoeff(), 0.8);
    charge_Ah += (0.8 - sub.state_of_charge) * 5.0;
  }
  // the hover setpoints ask for the weight; the battery scale and the thrust curve give it to a few percent
  EXPECT_NEAR(thrust_N, weight_N, 0.03 * weight_N);
  // about the hover current over the two seconds, per pack
  EXPECT_NEAR(charge_Ah / 3.0, out.sub_aircraft[0].battery_current_A * duration_s / 3600.0, 2e-4);
  std::printf("hover: thrust %.2f N for %.2f N weight, %.1f A per pack at %.2f V\n", thrust_N, weight_N,
              out.sub_aircraft[0].battery_current_A, out.sub_aircraft[0].battery_voltage_V);
}

TEST(ElectricDrive, IsReadFromThePhysicsParamsAndNeedsTheVehicleFilesParts) {
  bridge::YamlMap off(YAML::Load(ThreeStarParams()), "test.yaml");
  EXPECT_FALSE(ReadPhysicsConfig(off, "test.yaml", 0.001).simulation.actuation.enabled);
  bridge::YamlMap on(YAML::Load(ThreeStarParams() + "actuation: {battery_sag: false}\n"), "test.yaml");
  const ActuationConfig actuation = ReadPhysicsConfig(on, "test.yaml", 0.001).simulation.actuation;
  EXPECT_TRUE(actuation.enabled);
  EXPECT_FALSE(actuation.battery_sag);
  EXPECT_EQ(actuation.state_of_charge, 1.0);
  for (const std::string bad : {"{state_of_charge: 1.2}", "{state_of_charge: .nan}", "{sag: true}"}) {
    SCOPED_TRACE(bad);
    bridge::YamlMap wrong(YAML::Load(ThreeStarParams() + "actuation: " + bad + "\n"), "test.yaml");
    EXPECT_THROW(ReadPhysicsConfig(wrong, "test.yaml", 0.001), bridge::ConfigError);
  }
  // a vehicle without the motors' electrics
  const test_support::TestFolder folder("drive_test");
  const std::string path = (folder.path() / "no_electrics.yaml").string();
  {
    std::FILE* file = std::fopen(path.c_str(), "w");
    std::fprintf(
        file,
        "name: bare\nplatform: {mass_kg: 1, inertia_kgm2: [0.01, 0.01, 0.02]}\n"
        "sub_aircraft_defaults:\n  mass_kg: 1.6\n  inertia_kgm2: [0.0134, 0.0134, 0.0248]\n"
        "  rotors: {arm_m: 0.225, thrust_coefficient: 8.54858e-6, torque_coefficient: 1.36777e-7,\n"
        "           motor_time_constant_s: 0.02, speed_rad_s: [100, 1100]}\n"
        "sub_aircraft:\n  - {name: sub1, joint_m: [0.4, 0, 0]}\n  - {name: sub2, joint_m: [-0.4, 0, 0]}\n");
    std::fclose(file);
  }
  bridge::YamlMap bare(YAML::Load("vehicles:\n  - {name: iap, file: " + path + "}\nactuation: {}\n"),
                       "test.yaml");
  try {
    ReadPhysicsConfig(bare, "test.yaml", 0.001);
    ADD_FAILURE() << "accepted";
  } catch (const bridge::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("actuation"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no rotors.electric and no battery"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace iapsim::physics
