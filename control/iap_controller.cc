#include "control/iap_controller.h"

#include <algorithm>
#include <cmath>

namespace iapsim::control {
namespace {

bool AllFinite(const PoseReference& r) {
  return r.p_WP_m.allFinite() && r.v_WP_W_mps.allFinite() && r.a_WP_W_mps2.allFinite() &&
         r.q_WP.coeffs().allFinite() && r.q_WP.norm() > 0.5 && r.w_WP_P_radps.allFinite() &&
         r.dw_WP_P_radps2.allFinite();
}

bool AllFinite(const PlatformState& s) {
  return s.p_WP_m.allFinite() && s.q_WP.coeffs().allFinite() && s.q_WP.norm() > 0.5 &&
         s.v_WP_P_mps.allFinite() && s.w_WP_P_radps.allFinite();
}

}  // namespace

double YawOf(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

IapController::IapController(const model::Vehicle& vehicle, const IapControllerConfig& config)
    : vehicle_(vehicle), config_(config), tracker_(vehicle, config.gains, config.gravity_mps2) {
  for (const auto& sub : vehicle_.sub_aircraft) {
    const double count = static_cast<double>(sub.rotors.hub_S_m.size());
    limits_.push_back(ThrustLimits{count * sub.rotors.MinThrust_N(),
                                   config_.max_thrust_fraction * count * sub.rotors.MaxThrust_N(),
                                   config_.max_tilt_rad});
  }
  // Until the first valid update: the level hover at yaw 0.
  const Eigen::Quaterniond level = Eigen::Quaterniond::Identity();
  Command(level.toRotationMatrix(), 0.0,
          tracker_.allocation().Allocate(HoverWrench(vehicle_, level, config_.gravity_mps2)));
  output_.saturated = false;
}

bool IapController::Update(const PoseReference& reference, const PlatformState& state,
                           const Vector6d& external_wrench_P, double dt_s) {
  if (!AllFinite(reference) || !AllFinite(state) || !external_wrench_P.allFinite() || !std::isfinite(dt_s)) {
    ++rejected_;
    return false;
  }
  // Integrate only while the last output fitted the limits (conditional integration against windup).
  const Vector6d U = tracker_.Update(reference, state, external_wrench_P, dt_s, !output_.saturated);
  const Eigen::Matrix3d R_WP = state.q_WP.normalized().toRotationMatrix();
  const double yaw_rad = config_.sub_aircraft_yaw == SubAircraftYaw::kReference
                             ? YawOf(reference.q_WP.normalized().toRotationMatrix())
                             : YawOf(R_WP);
  std::array<double, kWrenchParts> kept;
  const Eigen::VectorXd thrusts_P_N =
      AllocateWithinLimits(tracker_.allocation(), U, R_WP, limits_, kept.data());
  Command(R_WP, yaw_rad, thrusts_P_N);
  output_.wrench_P = U;
  output_.kept = kept;
  for (int p = 0; p < kWrenchParts; ++p) {
    if (kept[p] < 1.0) {
      ++part_cuts_[p];
      output_.saturated = true;
    }
  }
  if (output_.saturated) ++saturated_;
  return true;
}

void IapController::Command(const Eigen::Matrix3d& R_WP, double platform_yaw_rad,
                            const Eigen::VectorXd& thrusts_P_N) {
  const int n = static_cast<int>(vehicle_.sub_aircraft.size());
  output_.sub_aircraft.resize(n);
  output_.thrusts_P_N = thrusts_P_N;
  output_.saturated = false;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d thrust_W_N = R_WP * thrusts_P_N.segment<3>(3 * i);
    output_.saturated = Limit(i, &thrust_W_N) || output_.saturated;
    output_.thrusts_P_N.segment<3>(3 * i) = R_WP.transpose() * thrust_W_N;
    const double yaw_rad = platform_yaw_rad + vehicle_.sub_aircraft[i].initial_yaw_rad;
    const Eigen::Vector2d roll_pitch = RollPitchForThrust(thrust_W_N, yaw_rad);
    output_.sub_aircraft[i].thrust_N = thrust_W_N.norm();
    output_.sub_aircraft[i].q_WS = AttitudeFromEuler(roll_pitch[0], roll_pitch[1], yaw_rad);
  }
}

bool IapController::Limit(int i, Eigen::Vector3d* thrust_W_N) const {
  const double max_N = limits_[i].max_N, min_N = limits_[i].min_N;
  const Eigen::Vector3d up_W = -Eigen::Vector3d::UnitZ();
  bool cut = false;
  double magnitude_N = thrust_W_N->norm();
  Eigen::Vector3d direction = magnitude_N > 0.0 ? Eigen::Vector3d(*thrust_W_N / magnitude_N) : up_W;
  if (std::acos(std::clamp(direction.dot(up_W), -1.0, 1.0)) > config_.max_tilt_rad + 1e-9) {
    // Onto the cone's edge, keeping the horizontal heading (straight down has none: then straight up).
    Eigen::Vector3d horizontal(direction.x(), direction.y(), 0.0);
    horizontal = horizontal.norm() > 1e-9 ? Eigen::Vector3d(horizontal.normalized()) : Eigen::Vector3d::Zero();
    direction = std::cos(config_.max_tilt_rad) * up_W + std::sin(config_.max_tilt_rad) * horizontal;
    direction.normalize();
    cut = true;
  }
  if (magnitude_N > max_N || magnitude_N < min_N) {
    magnitude_N = std::clamp(magnitude_N, min_N, max_N);
    cut = true;
  }
  *thrust_W_N = magnitude_N * direction;
  return cut;
}

}  // namespace iapsim::control
