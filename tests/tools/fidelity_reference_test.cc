// Issue 19's reference checks of the simulated closed loop (tools/fidelity_reference.h), bounded: what
// `iapsim bench fidelity` prints must agree with the linear models of the same loops and with PX4's
// published figures, on the paper's actuation and on the realistic one.
#include "tools/fidelity_reference.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace iapsim::tools {
namespace {

constexpr double kDeg = M_PI / 180.0;

model::Vehicle ThreeStar() {
  return model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
}

TEST(FidelityReference, StepForceModelPeaksBelowTheProportionalDeflection) {
  // the integral pulls the peak below F / k_P and a damped loop peaks once, within a few seconds
  const control::TrackerGains gains;
  const PeakResponse p = PredictStepForce(5.9, gains.kp[0], gains.ki[0], gains.kd[0], 1.0);
  EXPECT_LT(p.peak, 1.0 / gains.kp[0]);
  EXPECT_GT(p.peak, 0.8 / gains.kp[0]);
  EXPECT_GT(p.peak_time_s, 1.0);
  EXPECT_LT(p.peak_time_s, 5.0);
}

TEST(FidelityReference, StepForceOnTheHoveringIapPeaksAsTheLinearLoopPredicts) {
  const model::Vehicle vehicle = ThreeStar();
  const control::TrackerGains gains;
  for (int axis = 0; axis < 3; ++axis) {
    const PeakResponse model =
        PredictStepForce(vehicle.TotalMass_kg(), gains.kp[axis], gains.ki[axis], gains.kd[axis], 1.0);
    for (const Actuation actuation : {Actuation::kIdeal, Actuation::kRealistic}) {
      const PeakResponse measured = MeasureStepForce(vehicle, gains, axis, 1.0, actuation);
      EXPECT_NEAR(measured.peak, model.peak, 0.05 * model.peak)
          << "axis " << axis << (actuation == Actuation::kIdeal ? " ideal" : " realistic");
      EXPECT_NEAR(measured.peak_time_s, model.peak_time_s, 0.5) << "axis " << axis;
    }
  }
}

TEST(FidelityReference, AttitudeStepRisesAsTheLinearCascadeWithoutOvershoot) {
  const model::Vehicle quadrotor = SingleSubAircraft(ThreeStar());
  const model::SubAircraft& sub = quadrotor.sub_aircraft.front();
  const StepFigures model =
      PredictAttitudeStep(sub.flight_controller, sub.rotors.motor_time_constant_s, 10.0 * kDeg);
  for (const Actuation actuation : {Actuation::kIdeal, Actuation::kRealistic}) {
    const StepFigures measured = MeasureAttitudeStep(quadrotor, 10.0 * kDeg, actuation);
    EXPECT_NEAR(measured.rise_time_s, model.rise_time_s, 0.05 * model.rise_time_s);
    EXPECT_LT(measured.overshoot, 0.05);
    EXPECT_NEAR(measured.settling_time_s, model.settling_time_s, 0.1 * model.settling_time_s);
  }
}

TEST(FidelityReference, RateLoopCrossesOverWhereTheModelDoesAndInsidePx4sRange) {
  const model::Vehicle quadrotor = SingleSubAircraft(ThreeStar());
  const model::SubAircraft& sub = quadrotor.sub_aircraft.front();
  const std::vector<double> frequencies_hz = {0.7, 1.0, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0};
  const Crossover model =
      CrossoverOf(PredictRateLoop(sub.flight_controller, sub.rotors.motor_time_constant_s, frequencies_hz));
  const Crossover measured = CrossoverOf(SweepRateLoop(quadrotor, frequencies_hz, Actuation::kIdeal));
  ASSERT_GT(model.frequency_hz, 0.0);
  EXPECT_NEAR(measured.frequency_hz, model.frequency_hz, 0.03 * model.frequency_hz);
  EXPECT_NEAR(measured.phase_margin_deg, model.phase_margin_deg, 3.0);
  // PX4 autotune's MC_AT_RISE_TIME range, 0.01-0.5 s, as a first-order crossover 2.2 / (2 pi t_r)
  EXPECT_GT(measured.frequency_hz, 2.2 / (2.0 * M_PI * 0.5));
  EXPECT_LT(measured.frequency_hz, 2.2 / (2.0 * M_PI * 0.01));
  EXPECT_GT(measured.phase_margin_deg, 45.0);
}

TEST(FidelityReference, HoverDischargeHoldsPx4sLoadedCellVoltages) {
  const std::vector<DischargePoint> points = HoverDischarge(ThreeStar(), 0.05);
  ASSERT_GE(points.size(), 3u);
  EXPECT_NEAR(points.front().state_of_charge, 1.0, 1e-9);
  // PX4: BAT1_V_CHARGED 4.05 V a full cell under load; BAT1_V_EMPTY 3.5-3.6 V near 10 % charge
  EXPECT_NEAR(points.front().cell_voltage_V, 4.05, 0.1);
  bool saw_ten_percent = false;
  for (size_t i = 1; i < points.size(); ++i) {
    EXPECT_LT(points[i].state_of_charge, points[i - 1].state_of_charge);
    EXPECT_GT(points[i].time_s, points[i - 1].time_s);
    EXPECT_LE(points[i].cell_voltage_V, points[i - 1].cell_voltage_V);
    EXPECT_GE(points[i].current_A, points[i - 1].current_A);  // constant power, falling voltage
    if (std::abs(points[i].state_of_charge - 0.1) < 0.01) {
      saw_ten_percent = true;
      EXPECT_GT(points[i].cell_voltage_V, 3.45);
      EXPECT_LT(points[i].cell_voltage_V, 3.65);
    }
  }
  EXPECT_TRUE(saw_ten_percent);
}

}  // namespace
}  // namespace iapsim::tools
