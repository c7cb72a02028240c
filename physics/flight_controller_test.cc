// The flight controller's measurement path (physics/flight_controller.h): PX4's two-pole low-pass against
// the analytic response of the bilinear-transformed Butterworth filter, the gyroscope pipeline against a
// ramp's closed form, and a hovering three-star whose flight controllers run on their own gyroscopes.
#include "physics/flight_controller.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "bridge/config.h"
#include "model/vehicle.h"
#include "physics/physics_config.h"
#include "physics/rotor.h"
#include "physics/simulation.h"

namespace iapsim::physics {
namespace {

// the steady amplitude of the filter's response to a unit sine at f_hz, from a whole number of periods
double MeasuredGain(double cutoff_hz, double sample_hz, double f_hz) {
  ButterworthLowPass filter(cutoff_hz, sample_hz);
  const int settle = static_cast<int>(sample_hz), window = static_cast<int>(sample_hz);  // 1 s each
  double in_phase = 0.0, quadrature = 0.0;
  for (int k = 0; k < settle + window; ++k) {
    const double phase = 2.0 * M_PI * f_hz * k / sample_hz;
    const double y = filter.Apply(Eigen::Vector3d::Constant(std::sin(phase))).x();
    if (k >= settle) {
      in_phase += y * std::sin(phase);
      quadrature += y * std::cos(phase);
    }
  }
  return 2.0 * std::hypot(in_phase, quadrature) / window;
}

TEST(ButterworthLowPass, FollowsTheBilinearButterworthResponse) {
  const double sample_hz = 1000.0, cutoff_hz = 40.0;
  for (const double f_hz : {5.0, 20.0, 40.0, 80.0, 200.0}) {
    // |H| = 1 / √(1 + (tan(π f / f_s) / tan(π f_c / f_s))⁴): the analog prototype at the warped frequency
    const double warped = std::tan(M_PI * f_hz / sample_hz) / std::tan(M_PI * cutoff_hz / sample_hz);
    EXPECT_NEAR(MeasuredGain(cutoff_hz, sample_hz, f_hz), 1.0 / std::sqrt(1.0 + std::pow(warped, 4)), 1e-3)
        << f_hz;
  }
  EXPECT_NEAR(MeasuredGain(cutoff_hz, sample_hz, cutoff_hz), std::sqrt(0.5), 1e-3);  // −3 dB at the cutoff
  ButterworthLowPass held(cutoff_hz, sample_hz);
  held.Reset(Eigen::Vector3d(1.0, -2.0, 3.0));
  EXPECT_LT((held.Apply(Eigen::Vector3d(1.0, -2.0, 3.0)) - Eigen::Vector3d(1.0, -2.0, 3.0)).norm(), 1e-12);
  EXPECT_THROW(ButterworthLowPass(600.0, sample_hz), std::invalid_argument);
}

TEST(GyroFilter, GivesARampsRateLateByTheFiltersDelayAndItsSlopeExactly) {
  model::FlightControllerGains gains;
  const double step_s = 0.001;
  GyroFilter gyro(gains, step_s);
  const Eigen::Vector3d slope_radps2(2.0, -1.0, 0.5);
  double t_s = 0.0;
  for (int k = 0; k < 1000; ++k, t_s += step_s) gyro.Update(slope_radps2 * t_s);
  t_s -= step_s;
  EXPECT_LT((gyro.acceleration_S_radps2() - slope_radps2).norm(), 1e-9);
  // a Butterworth pair lags a ramp by √2 / (2π f_c) (its group delay at DC)
  const double delay_s = std::sqrt(2.0) / (2.0 * M_PI * gains.gyro_cutoff_hz);
  EXPECT_LT((gyro.rate_S_radps() - slope_radps2 * (t_s - delay_s)).norm(),
            0.01 * slope_radps2.norm() * delay_s);
}

// PX4's D term acts on the measured angular acceleration: D α asks for the same torque as a rate error
// smaller by D α / P (no integral, no gyroscopic term at rest).
TEST(FlightController, TheDTermActsOnTheMeasuredAngularAcceleration) {
  const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  model::SubAircraft sub = vehicle.sub_aircraft[0];
  sub.flight_controller.rate_i_per_s2.setZero();
  ASSERT_GT(sub.flight_controller.rate_d.x(), 0.0);
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  SubAircraftSetpoint setpoint;
  setpoint.mode = SubAircraftSetpoint::Mode::kBodyRate;
  setpoint.thrust_N = 20.0;
  setpoint.w_WS_S = Eigen::Vector3d(0.5, -0.3, 0.0);
  const Eigen::Vector3d alpha(2.0, 1.0, 0.0);
  const model::FlightControllerGains& gains = sub.flight_controller;
  RotorVector with_d, equivalent, without;
  FlightController(gains, sub.mass.inertia_B_kgm2, rotors)
      .Update(setpoint, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), alpha, 0.001, &with_d);
  SubAircraftSetpoint smaller = setpoint;
  smaller.w_WS_S -= gains.rate_d.cwiseProduct(alpha).cwiseQuotient(gains.rate_p_per_s);
  FlightController(gains, sub.mass.inertia_B_kgm2, rotors)
      .Update(smaller, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
              0.001, &equivalent);
  FlightController(gains, sub.mass.inertia_B_kgm2, rotors)
      .Update(setpoint, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
              0.001, &without);
  EXPECT_LT((with_d - equivalent).norm(), 1e-12);
  EXPECT_GT((with_d - without).norm(), 0.01);
}

// An angular acceleration fed forward adds to the rate loop's: α_ff asks for the same torque as a rate
// error of α_ff / P (no integral, no D, at rest).
TEST(FlightController, AFedForwardAngularAccelerationActsAsARateErrorOfItOverP) {
  const model::Vehicle vehicle =
      model::LoadVehicle(std::string(IAPSIM_SOURCE_DIR) + "/configs/vehicles/three_star.yaml");
  model::SubAircraft sub = vehicle.sub_aircraft[0];
  sub.flight_controller.rate_i_per_s2.setZero();
  const model::FlightControllerGains& gains = sub.flight_controller;
  Rotors rotors(sub.rotors, Eigen::Vector3d::Zero());
  SubAircraftSetpoint setpoint;
  setpoint.mode = SubAircraftSetpoint::Mode::kBodyRate;
  setpoint.thrust_N = 20.0;
  setpoint.angular_acceleration_S_radps2 = Eigen::Vector3d(3.0, -2.0, 1.0);
  SubAircraftSetpoint equivalent = setpoint;
  equivalent.angular_acceleration_S_radps2.setZero();
  equivalent.w_WS_S = setpoint.angular_acceleration_S_radps2.cwiseQuotient(gains.rate_p_per_s);
  RotorVector fed_forward, as_rate_error;
  const auto update = [&](const SubAircraftSetpoint& command, RotorVector* thrusts_N) {
    FlightController(gains, sub.mass.inertia_B_kgm2, rotors)
        .Update(command, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                0.001, thrusts_N);
  };
  update(setpoint, &fed_forward);
  update(equivalent, &as_rate_error);
  EXPECT_LT((fed_forward - as_rate_error).norm(), 1e-12);
  SubAircraftSetpoint not_finite = setpoint;
  not_finite.angular_acceleration_S_radps2.x() = std::nan("");
  EXPECT_FALSE(not_finite.IsValid());
}

std::string ThreeStarParams() {
  return "vehicles:\n  - {name: iap, file: " + std::string(IAPSIM_SOURCE_DIR) +
         "/configs/vehicles/three_star.yaml, position_m: [0, 0, -5]}\n";
}

TEST(FlightControllerSensing, ANoisyGyroscopeShakesTheHoverALittleAndRepeatsWithItsSeed) {
  const auto hover = [](const std::string& sensing, uint64_t seed) {
    bridge::YamlMap params(YAML::Load(ThreeStarParams() + "flight_controller_sensing: " + sensing + "\n"),
                           "test.yaml");
    PhysicsConfig config = ReadPhysicsConfig(params, "test.yaml", 0.001);
    config.simulation.seed = seed;
    Simulation sim(config.simulation);
    double largest_rate_radps = 0.0;
    while (sim.time_s() < 2.0) {
      sim.Step();
      const int body = sim.output(0).sub_aircraft_bodies[0];
      largest_rate_radps = std::max(largest_rate_radps, sim.world().body(body).w_WB_W.norm());
    }
    return largest_rate_radps;
  };
  const double truth = hover("truth", 1), gyro = hover("gyro", 1);
  std::printf("largest sub-aircraft rate in a 2 s hover: truth %.2e rad/s, gyroscope %.2e rad/s\n", truth,
              gyro);
  EXPECT_LT(truth, 1e-6);  // level trim holds exactly
  EXPECT_GT(gyro, 1e-3);   // noise and turn-on bias move it ...
  EXPECT_LT(gyro, 0.05);   // ... by a few hundredths of a rad/s at most
  EXPECT_EQ(hover("gyro", 1), gyro);
  EXPECT_NE(hover("gyro", 2), gyro);

  bridge::YamlMap wrong(YAML::Load(ThreeStarParams() + "flight_controller_sensing: magic\n"), "test.yaml");
  EXPECT_THROW(ReadPhysicsConfig(wrong, "test.yaml", 0.001), bridge::ConfigError);
}

// The IAP holding its hover thrusts for 3 s while each flight controller flies on its estimated attitude:
// the largest errors of what they believe, after the first step.
struct EstimatedHover {
  double largest_tilt_error_rad = 0.0;  // between the believed and the true down direction
  double largest_error_rad = 0.0;       // of the whole rotation, yaw included
  Eigen::Quaterniond q_WS_estimate;     // sub-aircraft 0's at the end
};

EstimatedHover HoverOnEstimates(const std::string& extra_params, uint64_t seed) {
  bridge::YamlMap params(
      YAML::Load(ThreeStarParams() + "flight_controller_sensing: estimate\n" + extra_params), "test.yaml");
  PhysicsConfig config = ReadPhysicsConfig(params, "test.yaml", 0.001);
  config.simulation.seed = seed;
  Simulation sim(config.simulation);
  EstimatedHover out;
  sim.Step();
  while (sim.time_s() < 3.0) {
    // the estimate a step makes, against the truth it was made from
    std::vector<Eigen::Quaterniond> q_WS_true;
    for (const int body : sim.output(0).sub_aircraft_bodies) q_WS_true.push_back(sim.world().body(body).q_WB);
    sim.Step();
    for (size_t i = 0; i < q_WS_true.size(); ++i) {
      const Eigen::Quaterniond error =
          q_WS_true[i].conjugate() * sim.output(0).sub_aircraft[i].q_WS_flight_controller;
      out.largest_error_rad =
          std::max(out.largest_error_rad, error.angularDistance(Eigen::Quaterniond::Identity()));
      out.largest_tilt_error_rad = std::max(out.largest_tilt_error_rad,
                                            std::acos(std::min(1.0, (error * Eigen::Vector3d::UnitZ()).z())));
    }
  }
  out.q_WS_estimate = sim.output(0).sub_aircraft[0].q_WS_flight_controller;
  return out;
}

TEST(FlightControllerSensing, AFlightControllerOnItsEstimateBelievesTheTruthUpToItsImusBiases) {
  // calibrated (the default): the noise the filter averages, and the aiding's; the yaw is aligned on a
  // second of 2° headings (0.63° one sigma)
  const EstimatedHover calibrated = HoverOnEstimates("", 1);
  std::printf("hover on calibrated estimates: largest tilt error %.3f deg, largest error %.3f deg\n",
              calibrated.largest_tilt_error_rad * 180 / M_PI, calibrated.largest_error_rad * 180 / M_PI);
  EXPECT_LT(calibrated.largest_tilt_error_rad, 0.3 * M_PI / 180.0);
  EXPECT_LT(calibrated.largest_error_rad, 2.0 * M_PI / 180.0);
  EXPECT_TRUE(HoverOnEstimates("", 1).q_WS_estimate.isApprox(calibrated.q_WS_estimate, 0.0));
  EXPECT_FALSE(HoverOnEstimates("", 2).q_WS_estimate.isApprox(calibrated.q_WS_estimate, 1e-9));

  // uncalibrated: PX4 Gazebo's 0.196 m/s² accelerometer turn-on bias tilts the estimate by about b/g (1.1°
  // per axis, one sigma) for the whole flight
  const EstimatedHover uncalibrated =
      HoverOnEstimates("flight_controller_estimate: {calibrated: false}\n", 1);
  std::printf("hover on uncalibrated estimates: largest tilt error %.3f deg\n",
              uncalibrated.largest_tilt_error_rad * 180 / M_PI);
  EXPECT_GT(uncalibrated.largest_tilt_error_rad, 4.0 * calibrated.largest_tilt_error_rad);
  EXPECT_LT(uncalibrated.largest_tilt_error_rad, 4.0 * M_PI / 180.0);

  for (const std::string& wrong :
       {std::string("flight_controller_sensing: gyro\nflight_controller_estimate: {}\n"),
        std::string(
            "flight_controller_sensing: estimate\nflight_controller_estimate: {heading_rate_hz: 0}\n"),
        std::string("flight_controller_sensing: estimate\n"
                    "flight_controller_estimate: {imu_integration_rate_hz: 2000}\n")}) {
    bridge::YamlMap params(YAML::Load(ThreeStarParams() + wrong), "test.yaml");
    EXPECT_THROW(ReadPhysicsConfig(params, "test.yaml", 0.001), bridge::ConfigError) << wrong;
  }
}

}  // namespace
}  // namespace iapsim::physics
