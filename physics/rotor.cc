#include "physics/rotor.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iapsim::physics {

double CheesemanBennettThrustRatio(double height_over_radius) {
  const double z_over_r = std::max(height_over_radius, 0.5);
  const double image = 1.0 / (4.0 * z_over_r);
  return 1.0 / (1.0 - image * image);
}

double WakeMomentumFlux_N(double thrust_N, double distance_m, double radius_m) {
  return 0.5 * thrust_N * (1.0 + distance_m / std::hypot(distance_m, radius_m));
}

const std::array<Eigen::Vector2d, kWakeCells>& WakeCells() {
  static const std::array<Eigen::Vector2d, kWakeCells> cells = [] {
    std::array<Eigen::Vector2d, kWakeCells> c;
    c[0].setZero();
    // ring edges at √(1/19), √(7/19) and 1 enclose 1, 7 and 19 cells' area; each cell's centre sits on the
    // radius that splits its ring's area in two
    const double inner = std::sqrt(4.0 / kWakeCells), outer = std::sqrt(13.0 / kWakeCells);
    for (int k = 0; k < 6; ++k) {
      const double angle = k * M_PI / 3.0;
      c[1 + k] = inner * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    for (int k = 0; k < 12; ++k) {
      const double angle = (k + 0.5) * M_PI / 6.0;
      c[7 + k] = outer * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    return c;
  }();
  return cells;
}

Rotors::Rotors(const model::RotorSet& rotors, const Eigen::Vector3d& com_S_m)
    : set_(rotors),
      com_S_m_(com_S_m),
      min_thrust_N_(rotors.MinThrust_N()),
      max_thrust_N_(rotors.MaxThrust_N()),
      speed_decay_per_s_(1.0 / rotors.motor_time_constant_s) {
  const int n = static_cast<int>(rotors.hub_S_m.size());
  if (n < 4 || n > kMaxRotors || rotors.spin.size() != rotors.hub_S_m.size()) {
    throw std::invalid_argument("a sub-aircraft needs 4 to " + std::to_string(kMaxRotors) +
                                " rotors, each with a spin direction");
  }
  effect_.resize(4, n);
  const double drag_per_thrust_m = rotors.torque_coefficient / rotors.thrust_coefficient;
  for (int j = 0; j < n; ++j) {
    const Eigen::Vector3d unit_force_S(0.0, 0.0, -1.0);
    const Eigen::Vector3d torque = (rotors.hub_S_m[j] - com_S_m).cross(unit_force_S) +
                                   rotors.spin[j] * drag_per_thrust_m * Eigen::Vector3d::UnitZ();
    effect_.col(j) << 1.0, torque;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(effect_, Eigen::ComputeThinU | Eigen::ComputeThinV);
  if (svd.singularValues().minCoeff() < 1e-9 * svd.singularValues().maxCoeff()) {
    throw std::invalid_argument("the rotor layout cannot produce every body torque (its mixer is singular)");
  }
  mixer_ = svd.solve(Eigen::Matrix4d::Identity());
  speeds_rad_s_ = RotorVector::Constant(n, rotors.min_speed_rad_s);
}

void Rotors::SetSpeeds(const RotorVector& speeds_rad_s) {
  speeds_rad_s_ = speeds_rad_s.cwiseMax(set_.min_speed_rad_s).cwiseMin(set_.max_speed_rad_s);
}

void Rotors::Step(const RotorVector& commanded_rad_s, double dt_s) {
  const double keep = std::exp(-dt_s * speed_decay_per_s_);
  for (int j = 0; j < count(); ++j) {
    const double target = std::clamp(commanded_rad_s[j], set_.min_speed_rad_s, set_.max_speed_rad_s);
    speeds_rad_s_[j] = target + (speeds_rad_s_[j] - target) * keep;
  }
}

void Rotors::Wrench_S(Eigen::Vector3d* force_S_N, Eigen::Vector3d* torque_S_Nm) const {
  const RotorVector thrusts = set_.thrust_coefficient * speeds_rad_s_.cwiseAbs2();
  const Eigen::Vector4d wrench = effect_ * thrusts;
  *force_S_N = Eigen::Vector3d(0.0, 0.0, -wrench[0]);
  *torque_S_Nm = wrench.tail<3>();
}

void Rotors::Wrench_S(const RotorVector& thrust_ratio, Eigen::Vector3d* force_S_N,
                      Eigen::Vector3d* torque_S_Nm) const {
  const RotorVector thrusts = set_.thrust_coefficient * speeds_rad_s_.cwiseAbs2();
  const RotorVector extra = thrusts.cwiseProduct(thrust_ratio) - thrusts;
  Eigen::Vector4d wrench = effect_ * (thrusts + extra);
  // effect_'s yaw row is the drag torque per unit thrust, which ground effect does not change
  wrench[3] -= effect_.row(3).dot(extra);
  *force_S_N = Eigen::Vector3d(0.0, 0.0, -wrench[0]);
  *torque_S_Nm = wrench.tail<3>();
}

void Rotors::AirWrench_S(const Eigen::Vector3d& v_air_S_mps, const Eigen::Vector3d& w_WS_S,
                         Eigen::Vector3d* force_S_N, Eigen::Vector3d* torque_S_Nm) const {
  force_S_N->setZero();
  torque_S_Nm->setZero();
  if (set_.drag_N_per_radps_mps == 0.0 && set_.rolling_moment_Nm_per_radps_mps == 0.0) return;
  for (int j = 0; j < count(); ++j) {
    const Eigen::Vector3d r_S = set_.hub_S_m[j] - com_S_m_;
    Eigen::Vector3d v_perp_S = v_air_S_mps + w_WS_S.cross(r_S);
    v_perp_S.z() = 0.0;
    const double speed = std::abs(speeds_rad_s_[j]);
    const Eigen::Vector3d drag_S = -speed * set_.drag_N_per_radps_mps * v_perp_S;
    *force_S_N += drag_S;
    *torque_S_Nm +=
        r_S.cross(drag_S) - set_.spin[j] * speed * set_.rolling_moment_Nm_per_radps_mps * v_perp_S;
  }
}

void Rotors::SpeedsForThrusts(const RotorVector& thrusts_N, RotorVector* speeds_rad_s) const {
  *speeds_rad_s = (thrusts_N.cwiseMax(0.0) / set_.thrust_coefficient)
                      .cwiseSqrt()
                      .cwiseMax(set_.min_speed_rad_s)
                      .cwiseMin(set_.max_speed_rad_s);
}

MixerCut Rotors::Mix(double thrust_N, const Eigen::Vector3d& torque_S_Nm, RotorVector* thrusts_N) const {
  const double range = max_thrust_N_ - min_thrust_N_;
  MixerCut cut;
  const RotorVector collective = mixer_ * Eigen::Vector4d(thrust_N, 0.0, 0.0, 0.0);
  RotorVector roll_pitch = mixer_ * Eigen::Vector4d(0.0, torque_S_Nm.x(), torque_S_Nm.y(), 0.0);
  const RotorVector yaw = mixer_ * Eigen::Vector4d(0.0, 0.0, 0.0, torque_S_Nm.z());

  // 1. roll/pitch alone must fit in the motors' range
  const double spread = roll_pitch.maxCoeff() - roll_pitch.minCoeff();
  if (spread > range) {
    roll_pitch *= range / spread;
    cut.roll_pitch = true;
  }
  // 2. shift the collective thrust so roll/pitch fit (changes the thrust, keeps the attitude)
  RotorVector thrusts = collective + roll_pitch;
  const double over = thrusts.maxCoeff() - max_thrust_N_;
  const double under = min_thrust_N_ - thrusts.minCoeff();
  if (over > 1e-12) {
    thrusts.array() -= over;
    cut.thrust = true;
  } else if (under > 1e-12) {
    thrusts.array() += under;
    cut.thrust = true;
  }
  // 3. as much yaw as still fits
  double yaw_scale = 1.0;
  for (int j = 0; j < count(); ++j) {
    if (yaw[j] > 0.0) yaw_scale = std::min(yaw_scale, (max_thrust_N_ - thrusts[j]) / yaw[j]);
    if (yaw[j] < 0.0) yaw_scale = std::min(yaw_scale, (min_thrust_N_ - thrusts[j]) / yaw[j]);
  }
  yaw_scale = std::max(yaw_scale, 0.0);
  if (yaw_scale < 1.0) cut.yaw = true;
  *thrusts_N = (thrusts + yaw_scale * yaw).cwiseMax(min_thrust_N_).cwiseMin(max_thrust_N_);
  return cut;
}

}  // namespace iapsim::physics
