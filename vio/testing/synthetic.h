#pragma once
// What vio/'s tests share: a smooth known motion with its exact IMU readings, and the seed's stereo camera.

#include <cmath>

#include "render/camera_rig.h"
#include "sensors/imu.h"
#include "vio/imu_preintegration.h"
#include "vio/so3.h"
#include "vio/stereo_rig.h"

namespace iapsim::vio::testing {

constexpr double kGravity_mps2 = 9.81;
inline Eigen::Vector3d GravityW() { return {0.0, 0.0, kGravity_mps2}; }

/// R(t) = Exp(θ(t)) (so ω_B = J_r(θ) θ̇) and p(t) of sines: every derivative is exact.
struct KnownMotion {
  static Eigen::Vector3d Theta(double t) {
    return {0.3 * std::sin(1.1 * t), 0.2 * std::sin(0.7 * t + 0.5), 0.8 * std::sin(0.5 * t)};
  }
  static Eigen::Vector3d ThetaDot(double t) {
    return {0.33 * std::cos(1.1 * t), 0.14 * std::cos(0.7 * t + 0.5), 0.4 * std::cos(0.5 * t)};
  }
  static Eigen::Vector3d Position(double t) {
    return {2.0 * std::sin(0.9 * t), 1.5 * std::cos(0.6 * t), -2.0 + 0.5 * std::sin(1.3 * t)};
  }
  static Eigen::Vector3d Velocity(double t) {
    return {1.8 * std::cos(0.9 * t), -0.9 * std::sin(0.6 * t), 0.65 * std::cos(1.3 * t)};
  }
  static Eigen::Vector3d Acceleration(double t) {
    return {-1.62 * std::sin(0.9 * t), -0.54 * std::cos(0.6 * t), -0.845 * std::sin(1.3 * t)};
  }
  static sensors::BodyKinematics Kinematics(double t) {
    sensors::BodyKinematics k;
    k.q_WB = ExpQuaternion(Theta(t));
    k.w_WB_B_radps = RightJacobian(Theta(t)) * ThetaDot(t);
    k.a_WB_W_mps2 = Acceleration(t);
    return k;
  }
  static NavState State(double t) { return {Position(t), ExpQuaternion(Theta(t)), Velocity(t)}; }
  static Eigen::Isometry3d Pose(double t) {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = Exp(Theta(t));
    X.translation() = Position(t);
    return X;
  }
  /// The IMU at the body's origin, through the sensors library's own model of a reading.
  static sensors::ImuSample Sample(double t) {
    return sensors::IdealImuSample(Kinematics(t), Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(),
                                   kGravity_mps2);
  }
};

/// The seed's stereo camera (§VI-G) on sub-aircraft 1: 640×480, 90° horizontal field of view, 12 cm
/// baseline, 19.8 cm ahead of the IMU, no distortion.
inline render::CameraConfig SeedStereoCamera() {
  render::CameraConfig camera;
  camera.name = "stereo";
  camera.mount.kind = render::CameraMount::Kind::kBody;
  camera.mount.body = "iap/sub1";
  camera.mount.X_PF.translation() = Eigen::Vector3d(0.198, 0.0, 0.0);
  camera.camera.intrinsics = render::CameraIntrinsics::FromHorizontalFov(640, 480, M_PI / 2.0);
  camera.baseline_m = 0.12;
  return camera;
}

/// That camera's rig for an IMU at the body's origin.
inline StereoRig SeedRig() {
  return StereoRig::FromCamera(SeedStereoCamera(), Eigen::Isometry3d::Identity());
}

/// The right eye in the IMU frame.
inline Eigen::Isometry3d RightEye(const StereoRig& rig) {
  return rig.X_IL * Eigen::Translation3d(rig.baseline_m, 0.0, 0.0);
}

}  // namespace iapsim::vio::testing
