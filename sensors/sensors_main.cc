// iapsim_sensors: the sensors of seed §V-D on the bus, a lockstep participant. From each vehicle state it
// samples, per sub-aircraft, an IMU, its attitude EKF (a flight controller's attitude estimate; fed a
// heading and a velocity when given `heading` and `velocity`) and a UWB tag ranging to the scenario's
// anchors and to the other tags; with `platform_imu`, an IMU on the platform and its own attitude EKF (the
// IAP computer's); it low-passes the platform's true contact
// wrench (§VI-E); and, when given `odometry`, it reports the platform's pose and twist as an onboard odometry
// would (sensors/odometry.h), for a controller that flies on an estimate. Every output is stamped with the
// physics time of the state it derives from.
//
//   subscribes  /<vehicle>/state                 iapsim_msgs/IapState
//   publishes   /<vehicle>/<sub>/imu             sensor_msgs/Imu (no orientation: covariance[0] = −1)
//               /<vehicle>/<sub>/attitude        sensor_msgs/Imu (EKF orientation R_WS, bias-corrected rate)
//               /<vehicle>/<sub>/uwb             iapsim_msgs/UwbRanges (received ranges only)
//               /<vehicle>/imu, /<vehicle>/attitude   the same for the platform (with `platform_imu`)
//               /<vehicle>/wrench/filtered       geometry_msgs/WrenchStamped (in P, about its origin)
//               /<vehicle>/odometry              nav_msgs/Odometry (pose in W, twist in P; with `odometry`; its
//                                                tilt and rate the platform EKF's with attitude_source: platform_imu)
//
// Each sensor runs at its own rate_hz, which must divide the process's rate_hz; the process's rate is the
// step of the wrench filter.

#include <geometry_msgs/WrenchStamped.h>
#include <iapsim_msgs/IapState.h>
#include <iapsim_msgs/UwbRanges.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>

#include <cmath>
#include <optional>

#include "bridge/eigen_msgs.h"
#include "bridge/process.h"
#include "model/vehicle.h"
#include "sensors/sensor_config.h"

namespace iapsim::sensors {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// Decorrelated seeds for the instances of one process (SplitMix64's increment keeps them apart).
uint64_t SeedFor(uint64_t process_seed, uint64_t instance, uint64_t kind) {
  return process_seed + 0x9E3779B97F4A7C15ULL * (instance * 8 + kind + 1);
}

BodyKinematics KinematicsOf(const iapsim_msgs::BodyState& body) {
  BodyKinematics truth;
  truth.q_WB = bridge::FromMsg(body.pose_W.orientation).normalized();
  truth.w_WB_B_radps = bridge::FromMsg(body.twist_B.angular);
  truth.alpha_WB_B_radps2 = truth.q_WB.conjugate() * bridge::FromMsg(body.accel_W.angular);
  truth.a_WB_W_mps2 = bridge::FromMsg(body.accel_W.linear);
  return truth;
}

// An IMU on one body of the vehicle and the attitude EKF that reads it, with the EKF's aiding sensors.
struct InertialSensors {
  std::string topic_prefix;  // /<vehicle>/<sub> or, on the platform, /<vehicle>
  std::string frame_id;      // the body's frame
  std::size_t body;          // in IapState::bodies
  Eigen::Vector3d p_BI_m;    // the IMU's mounting
  Eigen::Quaterniond q_BI;
  ImuModel imu;
  AttitudeEstimator estimator;
  std::optional<HeadingSensor> heading;
  std::optional<VelocitySensor> velocity;
  AttitudeErrorStatistics attitude_errors;
  uint64_t imu_samples = 0;
  Eigen::Vector3d rate_B_radps = Eigen::Vector3d::Zero();  // the last sample's, bias-corrected, in B
};

struct SubAircraftSensors {
  std::string name;
  InertialSensors inertial;
  UwbModel uwb;
  uint64_t uwb_ranges = 0;
  uint64_t uwb_dropped = 0;
};

class SensorsNode : public bridge::Process {
 public:
  SensorsNode(const bridge::ProcessContext& context, bridge::YamlMap& params)
      : process_step_s_(context.self.rate_hz > 0 ? 1.0 / context.self.rate_hz
                                                 : context.scenario.clock.step_s) {
    bridge::YamlMap vehicle = params.Map("vehicle");
    vehicle.Required("name", &vehicle_name_);
    const model::Vehicle model =
        model::LoadVehicle(bridge::ReadFilePath(vehicle, "file", context.scenario.file));
    vehicle.Finish();
    config_ = ReadSensorsConfig(params);
    imu_every_ = Divider(params, "imu", config_.imu.rate_hz);
    uwb_every_ = Divider(params, "uwb", config_.uwb.rate_hz);
    if (config_.heading) heading_every_ = Divider(params, "heading", config_.heading->rate_hz);
    if (config_.velocity) velocity_every_ = Divider(params, "velocity", config_.velocity->rate_hz);
    for (size_t i = 0; i < model.sub_aircraft.size(); ++i) {
      const std::string& name = model.sub_aircraft[i].name;
      subs_.push_back(SubAircraftSensors{
          name,
          MakeInertialSensors("/" + vehicle_name_ + "/" + name, vehicle_name_ + "/" + name, i + 1,
                              config_.imu, config_.attitude_estimator, context.seed, i),
          UwbModel(config_.uwb.noise, SeedFor(context.seed, i, 2))});
    }
    filter_.emplace(config_.wrench_filter, process_step_s_);
    if (config_.odometry) {
      odometry_every_ = Divider(params, "odometry", config_.odometry->rate_hz);
      odometry_.emplace(*config_.odometry, SeedFor(context.seed, model.sub_aircraft.size(), 0));
    }
    // the instance after the odometry's: adding the platform's IMU leaves every other stream as it was
    if (config_.platform_imu) {
      platform_.emplace(MakeInertialSensors("/" + vehicle_name_, vehicle_name_ + "/P", 0,
                                            *config_.platform_imu, *config_.platform_attitude_estimator,
                                            context.seed, model.sub_aircraft.size() + 1));
    }
  }

  void Setup(bridge::Bus& bus) override {
    bus_ = &bus;
    bus.Subscribe<iapsim_msgs::IapState>(
        "/" + vehicle_name_ + "/state",
        [this](const iapsim_msgs::IapState& state, const bridge::MessageInfo&) {
          state_ = state;
          have_state_ = true;
        });
  }

  void Step(const bridge::StepInfo&) override {
    if (!have_state_ || state_.bodies.size() != subs_.size() + 1) return;  // realtime: nothing yet
    const uint64_t k = steps_++;
    for (size_t i = 0; i < subs_.size(); ++i) {
      if (k % imu_every_ == 0) SampleImu(subs_[i].inertial, k);
      if (k % uwb_every_ == 0) SampleUwb(i);
    }
    if (platform_ && k % imu_every_ == 0) SampleImu(*platform_, k);
    FilterWrench();
    if (odometry_ && k % odometry_every_ == 0) SampleOdometry();
  }

  void Finish(nlohmann::json* report) override {
    for (const auto& sub : subs_) {
      nlohmann::json& out = (*report)["sub_aircraft"][sub.name];
      Report(sub.inertial, &out);
      out["uwb_ranges"] = sub.uwb_ranges;
      out["uwb_dropped"] = sub.uwb_dropped;
    }
    if (platform_) Report(*platform_, &(*report)["platform"]);
    if (odometry_) {
      nlohmann::json& out = (*report)["odometry"];
      const double n = static_cast<double>(std::max<uint64_t>(odometry_samples_, 1));
      const Eigen::Vector3d rms_m = (odometry_position_sum_of_squares_m2_ / n).cwiseSqrt();
      const Eigen::Vector3d rms_deg = odometry_attitude_errors_.RootMeanSquare_rad() * kRadToDeg;
      out["samples"] = odometry_samples_;
      out["position_error_rms_m"] = {rms_m.x(), rms_m.y(), rms_m.z()};
      out["attitude_error_rms_deg"] = {{"roll", rms_deg.x()}, {"pitch", rms_deg.y()}, {"yaw", rms_deg.z()}};
      const Eigen::Vector3d& drift_W_m = odometry_->position_drift_W_m();
      out["final_position_drift_W_m"] = {drift_W_m.x(), drift_W_m.y(), drift_W_m.z()};
      out["final_yaw_drift_deg"] = odometry_->yaw_drift_rad() * kRadToDeg;
    }
  }

 private:
  // How many process steps apart a sensor of `rate_hz` samples; it must be a whole number.
  uint64_t Divider(bridge::YamlMap& params, const std::string& section, double rate_hz) const {
    const uint64_t every = bridge::StepsPerPeriod(rate_hz, process_step_s_);
    if (every == 0) {
      params.Fail(section, "rate_hz " + std::to_string(rate_hz) + " must divide the process's rate_hz " +
                               std::to_string(1.0 / process_step_s_));
    }
    return every;
  }

  std::string Topic(const std::string& sub, const std::string& what) const {
    return "/" + vehicle_name_ + "/" + sub + "/" + what;
  }

  // `instance` seeds its IMU (kind 0), heading (1) and velocity (3) streams
  InertialSensors MakeInertialSensors(std::string topic_prefix, std::string frame_id, std::size_t body,
                                      const ImuConfig& imu, const AttitudeEstimatorConfig& estimator,
                                      uint64_t seed, uint64_t instance) const {
    return InertialSensors{
        std::move(topic_prefix),
        std::move(frame_id),
        body,
        imu.p_BI_m,
        estimator.q_BI,
        ImuModel(imu, SeedFor(seed, instance, 0)),
        AttitudeEstimator(estimator),
        config_.heading
            ? std::optional<HeadingSensor>(HeadingSensor(*config_.heading, SeedFor(seed, instance, 1)))
            : std::nullopt,
        config_.velocity
            ? std::optional<VelocitySensor>(VelocitySensor(*config_.velocity, SeedFor(seed, instance, 3)))
            : std::nullopt,
        AttitudeErrorStatistics(static_cast<double>(imu_every_) * process_step_s_)};
  }

  static void Report(const InertialSensors& sensors, nlohmann::json* out) {
    (*out)["imu_samples"] = sensors.imu_samples;
    const Eigen::Vector3d rms_deg = sensors.attitude_errors.RootMeanSquare_rad() * kRadToDeg;
    const Eigen::Vector3d max_deg = sensors.attitude_errors.MaxAbs_rad() * kRadToDeg;
    (*out)["attitude_error_rms_deg"] = {{"roll", rms_deg.x()}, {"pitch", rms_deg.y()}, {"yaw", rms_deg.z()}};
    (*out)["attitude_error_max_deg"] = {{"roll", max_deg.x()}, {"pitch", max_deg.y()}, {"yaw", max_deg.z()}};
    const Eigen::Vector3d tau_s = sensors.attitude_errors.CorrelationTime_s();  // NaN: null in the JSON
    (*out)["attitude_error_correlation_s"] = {{"roll", tau_s.x()}, {"pitch", tau_s.y()}, {"yaw", tau_s.z()}};
  }

  void SampleImu(InertialSensors& sub, uint64_t k) {
    const iapsim_msgs::BodyState& body = state_.bodies[sub.body];
    const double dt_s = static_cast<double>(imu_every_) * process_step_s_;
    const BodyKinematics truth = KinematicsOf(body);
    const ImuSample sample = sub.imu.Sample(truth, dt_s);
    ++sub.imu_samples;
    sensor_msgs::Imu imu;
    imu.header.stamp = state_.header.stamp;
    imu.header.frame_id = sub.frame_id + "/imu";
    imu.orientation_covariance[0] = -1.0;  // ROS: no orientation in this message
    imu.angular_velocity = bridge::ToVector3Msg(sample.w_I_radps);
    imu.linear_acceleration = bridge::ToVector3Msg(sample.f_I_mps2);
    bus_->Publish(sub.topic_prefix + "/imu", imu);

    // the flight controller's estimate: started level-aware from gravity with the true heading (no compass)
    if (!sub.estimator.initialized()) {
      sub.estimator.InitializeFromAccelerometer(sample, RollPitchYaw_rad(truth.q_WB).z());
    } else {
      sub.estimator.Update(sample, dt_s);
    }
    if (sub.heading && k % heading_every_ == 0) {
      sub.estimator.UpdateHeading(sub.heading->Measure(truth.q_WB), sub.heading->config().sigma_rad);
    }
    if (sub.velocity && k % velocity_every_ == 0) {
      // the IMU's velocity: the body origin's plus ω × p_BI
      const Eigen::Vector3d v_WI_W_mps =
          bridge::FromMsg(body.twist_W.linear) + truth.q_WB * truth.w_WB_B_radps.cross(sub.p_BI_m);
      sub.estimator.UpdateVelocity(sub.velocity->Measure(v_WI_W_mps), sub.velocity->config().sigma_mps);
    }
    sub.attitude_errors.Add(sub.estimator.q_WB(), truth.q_WB);
    sensor_msgs::Imu attitude = imu;
    attitude.header.frame_id = sub.frame_id;
    attitude.orientation = bridge::ToQuaternionMsg(sub.estimator.q_WB());
    const Eigen::Matrix3d attitude_covariance = sub.estimator.covariance().topLeftCorner<3, 3>();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) attitude.orientation_covariance[3 * r + c] = attitude_covariance(r, c);
    }
    sub.rate_B_radps = sub.q_BI * sample.w_I_radps - sub.estimator.gyroscope_bias_B_radps();
    attitude.angular_velocity = bridge::ToVector3Msg(sub.rate_B_radps);
    bus_->Publish(sub.topic_prefix + "/attitude", attitude);
  }

  void SampleUwb(size_t i) {
    SubAircraftSensors& sub = subs_[i];
    const Eigen::Vector3d p_WT_m = bridge::FromMsg(state_.bodies[i + 1].pose_W.position);
    iapsim_msgs::UwbRanges ranges;
    ranges.header.stamp = state_.header.stamp;
    ranges.header.frame_id = "W";
    ranges.tag = sub.name;
    const auto add = [&](const std::string& peer, const Eigen::Vector3d& p_WP_m) {
      const UwbRange range = sub.uwb.Measure(p_WT_m, p_WP_m);
      if (!range.received) {
        ++sub.uwb_dropped;
        return;
      }
      ranges.peers.push_back(peer);
      ranges.ranges_m.push_back(range.range_m);
      ++sub.uwb_ranges;
    };
    for (const UwbAnchor& anchor : config_.uwb.anchors) add(anchor.name, anchor.p_WA_m);
    if (config_.uwb.tag_to_tag) {
      for (size_t j = 0; j < subs_.size(); ++j) {
        if (j != i) add(subs_[j].name, bridge::FromMsg(state_.bodies[j + 1].pose_W.position));
      }
    }
    bus_->Publish(Topic(sub.name, "uwb"), ranges);
  }

  void FilterWrench() {
    const auto& w = state_.external_wrench_P;
    Vector6d wrench_P;
    wrench_P << bridge::FromMsg(w.force), bridge::FromMsg(w.torque);
    const Vector6d filtered_P = filter_->Update(wrench_P);
    geometry_msgs::WrenchStamped out;
    out.header.stamp = state_.header.stamp;
    out.header.frame_id = vehicle_name_ + "/P";
    out.wrench.force = bridge::ToVector3Msg(filtered_P.head<3>());
    out.wrench.torque = bridge::ToVector3Msg(filtered_P.tail<3>());
    bus_->Publish("/" + vehicle_name_ + "/wrench/filtered", out);
  }

  void SampleOdometry() {
    const iapsim_msgs::BodyState& platform = state_.bodies[0];
    OdometryState truth;
    truth.p_WB_m = bridge::FromMsg(platform.pose_W.position);
    truth.q_WB = bridge::FromMsg(platform.pose_W.orientation).normalized();
    truth.v_WB_B_mps = bridge::FromMsg(platform.twist_B.linear);
    truth.w_WB_B_radps = bridge::FromMsg(platform.twist_B.angular);
    OdometryState estimate = odometry_->Sample(truth, static_cast<double>(odometry_every_) * process_step_s_);
    const bool platform_attitude = odometry_->config().attitude_from_platform_imu;
    if (platform_attitude) {
      const Eigen::Vector3d tilt_rpy_rad = RollPitchYaw_rad(platform_->estimator.q_WB());
      estimate.q_WB =
          FromRollPitchYaw(tilt_rpy_rad.x(), tilt_rpy_rad.y(), RollPitchYaw_rad(estimate.q_WB).z());
      estimate.w_WB_B_radps = platform_->rate_B_radps;
    }
    ++odometry_samples_;
    odometry_position_sum_of_squares_m2_ += (estimate.p_WB_m - truth.p_WB_m).cwiseAbs2();
    odometry_attitude_errors_.Add(estimate.q_WB, truth.q_WB);

    nav_msgs::Odometry odometry;
    odometry.header.stamp = state_.header.stamp;
    odometry.header.frame_id = "W";
    odometry.child_frame_id = vehicle_name_ + "/P";
    odometry.pose.pose.position = bridge::ToPointMsg(estimate.p_WB_m);
    odometry.pose.pose.orientation = bridge::ToQuaternionMsg(estimate.q_WB);
    odometry.twist.twist.linear = bridge::ToVector3Msg(estimate.v_WB_B_mps);
    odometry.twist.twist.angular = bridge::ToVector3Msg(estimate.w_WB_B_radps);
    // the model's variances (row-major 6×6, x y z then rotations): the noise plus the drift grown so far
    const OdometryNoise& noise = odometry_->config().noise;
    const double t_s = static_cast<double>(odometry_samples_ - 1) * odometry_every_ * process_step_s_;
    const double position_variance =
        noise.position_sigma_m * noise.position_sigma_m +
        noise.position_drift_m_per_sqrt_s * noise.position_drift_m_per_sqrt_s * t_s;
    const double attitude_variance = noise.attitude_sigma_rad * noise.attitude_sigma_rad;
    const double yaw_variance =
        attitude_variance + noise.yaw_drift_rad_per_sqrt_s * noise.yaw_drift_rad_per_sqrt_s * t_s;
    double rate_variance = noise.angular_rate_noise_density * noise.angular_rate_noise_density /
                           (static_cast<double>(odometry_every_) * process_step_s_);
    Eigen::Vector2d tilt_variance(attitude_variance, attitude_variance);
    if (platform_attitude) {  // the EKF's own, and the platform gyroscope's white noise over its sample
      tilt_variance = platform_->estimator.covariance().diagonal().head<2>();
      const double density = config_.platform_imu->noise.gyroscope_noise_density;
      rate_variance = density * density / (static_cast<double>(imu_every_) * process_step_s_);
    }
    for (int i = 0; i < 3; ++i) {
      odometry.pose.covariance[7 * i] = position_variance;
      odometry.pose.covariance[7 * (i + 3)] = i == 2 ? yaw_variance : tilt_variance[i];
      odometry.twist.covariance[7 * i] = noise.velocity_sigma_mps * noise.velocity_sigma_mps;
      odometry.twist.covariance[7 * (i + 3)] = rate_variance;
    }
    bus_->Publish("/" + vehicle_name_ + "/odometry", odometry);
  }

  double process_step_s_;
  std::string vehicle_name_;
  SensorsConfig config_;
  uint64_t imu_every_ = 1, uwb_every_ = 1, heading_every_ = 1, velocity_every_ = 1, odometry_every_ = 1;
  std::vector<SubAircraftSensors> subs_;
  std::optional<InertialSensors> platform_;
  std::optional<WrenchFilter> filter_;
  std::optional<OdometryModel> odometry_;
  uint64_t odometry_samples_ = 0;
  Eigen::Vector3d odometry_position_sum_of_squares_m2_ = Eigen::Vector3d::Zero();
  AttitudeErrorStatistics odometry_attitude_errors_;
  bridge::Bus* bus_ = nullptr;
  iapsim_msgs::IapState state_;
  bool have_state_ = false;
  uint64_t steps_ = 0;
};

}  // namespace
}  // namespace iapsim::sensors

int main(int argc, char** argv) {
  return iapsim::bridge::ProcessMainFor<iapsim::sensors::SensorsNode>(
      argc, argv, "iapsim sensors: IMU, attitude estimate, UWB and filtered wrench from the vehicle state");
}
