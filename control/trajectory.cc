#include "control/trajectory.h"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include "bridge/pose_file.h"
#include "control/allocation.h"
#include "model/vehicle.h"

namespace iapsim::control {

using bridge::ConfigError;
using bridge::YamlMap;
using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

namespace {

constexpr double kDegToRad = M_PI / 180.0;

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

// ---- smooth scalar pieces ----

// A value and its first two derivatives.
struct Jet {
  double value = 0.0;
  double d1 = 0.0;
  double d2 = 0.0;
};

// Σ c_k·s^k and its first two derivatives in s.
template <size_t N>
Jet Polynomial(const std::array<double, N>& c, double s) {
  Jet out;
  for (size_t k = N; k-- > 0;) {  // Horner's rule, differentiated alongside
    out.d2 = out.d2 * s + 2.0 * out.d1;
    out.d1 = out.d1 * s + out.value;
    out.value = out.value * s + c[k];
  }
  return out;
}

// Quintic Hermite basis on s ∈ [0, 1] with zero curvature at both ends: the minimum-jerk step σ(s) (0 to 1,
// flat at both ends) and the shapes that add a start slope and an end slope.
constexpr std::array<double, 6> kMinimumJerkStep{0, 0, 0, 10, -15, 6};
constexpr std::array<double, 6> kStartSlope{0, 1, 0, -6, 8, -3};
constexpr std::array<double, 6> kEndSlope{0, 0, 0, -4, 7, -3};
// ∫σ: the distance covered while the speed follows σ
constexpr std::array<double, 7> kMinimumJerkStepIntegral{0, 0, 0, 0, 2.5, -3, 1};

// Speed profile of the path sources: the speed rises from rest along a minimum-jerk step over ramp_s,
// cruises, and falls back to rest over the last ramp_s. Position, velocity, acceleration and jerk are
// continuous, and the flight starts and ends at rest.
class SpeedRamp {
 public:
  SpeedRamp(double duration_s, double ramp_s) : duration_s_(duration_s), ramp_s_(ramp_s) {}

  double duration_s() const { return duration_s_; }
  // the progress at the end, in seconds at full speed: each ramp covers half of what full speed would
  double cruise_s() const { return duration_s_ - ramp_s_; }

  // the speed as a fraction of full speed, 0 at both ends
  Jet SpeedFraction(double t_s) const {
    const Phase phase = PhaseAt(t_s);
    if (phase.side == 0) return {1.0, 0.0, 0.0};
    const Jet step = Polynomial(kMinimumJerkStep, phase.u);
    return {step.value, phase.side * step.d1 / ramp_s_, step.d2 / (ramp_s_ * ramp_s_)};
  }

  // progress as seconds flown at full speed: 0 at the start, cruise_s() at the end
  Jet Progress_s(double t_s) const {
    const Phase phase = PhaseAt(t_s);
    if (phase.side == 0) return {phase.t_s - 0.5 * ramp_s_, 1.0, 0.0};
    const Jet area = Polynomial(kMinimumJerkStepIntegral, phase.u);
    const double value = phase.side > 0 ? ramp_s_ * area.value : cruise_s() - ramp_s_ * area.value;
    return {value, area.d1, phase.side * area.d2 / ramp_s_};
  }

 private:
  // side +1: in the first ramp, u = t/ramp; −1: in the last, u = (duration − t)/ramp; 0: cruising
  struct Phase {
    int side;
    double u;
    double t_s;
  };
  Phase PhaseAt(double t_s) const {
    const double t = std::clamp(t_s, 0.0, duration_s_);
    if (t < ramp_s_) return {+1, t / ramp_s_, t};
    if (t > duration_s_ - ramp_s_) return {-1, (duration_s_ - t) / ramp_s_, t};
    return {0, 0.0, t};
  }

  double duration_s_;
  double ramp_s_;
};

// ---- SO(3) on rotation vectors ----

Quaterniond ExpQuaternion(const Vector3d& r) {
  const double theta = r.norm();
  // sin(θ/2)/θ, which tends to 1/2
  const double k = theta < 1e-6 ? 0.5 - theta * theta / 48.0 : std::sin(0.5 * theta) / theta;
  return Quaterniond(std::cos(0.5 * theta), k * r.x(), k * r.y(), k * r.z());
}

// The rotation vector of q, of angle in [0, π].
Vector3d LogQuaternion(const Quaterniond& q) {
  const Eigen::AngleAxisd angle_axis(q);
  return angle_axis.angle() * angle_axis.axis();
}

// The right Jacobian of SO(3) at r, J(r) = I − a(θ)·r^ + b(θ)·r^² with θ = |r|, so that R0·Exp(r(t)) turns
// at J(r)·ṙ in its own frame and J(r)·r̈ + (dJ/dt)·ṙ is the derivative of that rate.
class RightJacobian {
 public:
  explicit RightJacobian(const Vector3d& r) : r_(r) {
    const double theta = r.norm();
    const double t2 = theta * theta;
    if (theta < 0.02) {  // series: the closed forms lose digits to cancellation near 0
      a_ = 0.5 - t2 / 24.0 + t2 * t2 / 720.0;
      b_ = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0;
      da_over_theta_ = -1.0 / 12.0 + t2 / 180.0 - t2 * t2 / 6720.0;
      db_over_theta_ = -1.0 / 60.0 + t2 / 1260.0 - t2 * t2 / 60480.0;
    } else {
      const double s = std::sin(theta), c = std::cos(theta);
      a_ = (1.0 - c) / t2;
      b_ = (theta - s) / (t2 * theta);
      da_over_theta_ = (theta * s - 2.0 * (1.0 - c)) / (t2 * t2);
      db_over_theta_ = ((1.0 - c) * theta - 3.0 * (theta - s)) / (t2 * t2 * theta);
    }
  }

  Vector3d Times(const Vector3d& x) const {
    const Vector3d r_x = r_.cross(x);
    return x - a_ * r_x + b_ * r_.cross(r_x);
  }

  Vector3d Solve(const Vector3d& y) const {
    Matrix3d J;
    for (int i = 0; i < 3; ++i) J.col(i) = Times(Vector3d::Unit(i));
    return J.partialPivLu().solve(y);
  }

  // (dJ/dt)·ṙ for r moving at ṙ
  Vector3d RateTimesRate(const Vector3d& r_rate) const {
    const Vector3d r_x_rate = r_.cross(r_rate);
    const double along = r_.dot(r_rate);  // θ·dθ/dt
    return -da_over_theta_ * along * r_x_rate + db_over_theta_ * along * r_.cross(r_x_rate) +
           b_ * r_rate.cross(r_x_rate);
  }

 private:
  Vector3d r_;
  double a_, b_;
  double da_over_theta_, db_over_theta_;  // da/dθ / θ and db/dθ / θ
};

// ---- waypoints and 5-DOF poses ----

// A knot of the waypoint and pose sources: y = [position (m, W); roll, pitch, yaw (rad)] and its rate.
struct Knot {
  double t_s = 0.0;
  Vector6d y = Vector6d::Zero();
  Vector6d rate = Vector6d::Zero();
};

PoseReference EulerReference(const Vector6d& y, const Vector6d& rate, const Vector6d& accel) {
  return ReferenceFromEuler(y.head<3>(), rate.head<3>(), accel.head<3>(), y.tail<3>(), rate.tail<3>(),
                            accel.tail<3>());
}

// Quintic segments between knots, with the knots' rates and zero acceleration at every knot.
class WaypointTrajectory final : public Trajectory {
 public:
  WaypointTrajectory(std::vector<Knot> knots, bool five_dof)
      : knots_(std::move(knots)), five_dof_(five_dof) {}

  PoseReference Sample(double t_s) const override {
    PoseReference reference;
    if (t_s <= knots_.front().t_s || t_s >= knots_.back().t_s) {
      const Vector6d& y = t_s <= knots_.front().t_s ? knots_.front().y : knots_.back().y;
      reference = EulerReference(y, Vector6d::Zero(), Vector6d::Zero());
    } else {
      const auto next = std::upper_bound(knots_.begin(), knots_.end(), t_s,
                                         [](double t, const Knot& knot) { return t < knot.t_s; });
      const Knot& k0 = *(next - 1);
      const Knot& k1 = *next;
      const double h = k1.t_s - k0.t_s;
      const double s = (t_s - k0.t_s) / h;
      const Jet step = Polynomial(kMinimumJerkStep, s);
      const Jet start = Polynomial(kStartSlope, s);
      const Jet end = Polynomial(kEndSlope, s);
      // the same blend for the value and, divided by h and h², its derivatives
      const auto blend = [&](double Jet::*order) -> Vector6d {
        return (k1.y - k0.y) * (step.*order) + h * (k0.rate * (start.*order) + k1.rate * (end.*order));
      };
      reference = EulerReference(k0.y + blend(&Jet::value), blend(&Jet::d1) / h, blend(&Jet::d2) / (h * h));
    }
    reference.five_dof = five_dof_;
    return reference;
  }

  double duration_s() const override { return knots_.back().t_s; }

 private:
  std::vector<Knot> knots_;
  bool five_dof_;
};

// Knot rates: rest at the ends (and everywhere when `stop`); elsewhere, per coordinate, the mean of the
// neighbouring segments' slopes, or zero where the coordinate turns back (no overshoot past a waypoint that
// is an extremum).
std::vector<Knot> KnotsThrough(const std::vector<double>& times_s, const std::vector<Vector6d>& values,
                               bool stop) {
  std::vector<Knot> knots(times_s.size());
  for (size_t i = 0; i < knots.size(); ++i) {
    knots[i].t_s = times_s[i];
    knots[i].y = values[i];
  }
  for (size_t i = 1; !stop && i + 1 < knots.size(); ++i) {
    const Vector6d before = (values[i] - values[i - 1]) / (times_s[i] - times_s[i - 1]);
    const Vector6d after = (values[i + 1] - values[i]) / (times_s[i + 1] - times_s[i]);
    for (int j = 0; j < 6; ++j) {
      knots[i].rate[j] = before[j] * after[j] > 0.0 ? 0.5 * (before[j] + after[j]) : 0.0;
    }
  }
  return knots;
}

Vector3d RequiredVector3(YamlMap& map, const std::string& key, const std::string& expected) {
  if (!map.Has(key)) map.Fail(key, "is required: " + expected);
  Vector3d value = Vector3d::Zero();
  model::OptionalVector3(map, key, &value);
  return value;
}

double RequiredPositive(YamlMap& map, const std::string& key, const std::string& unit) {
  double value = 0.0;
  map.Required(key, &value);
  if (!(value > 0.0 && std::isfinite(value))) {
    map.Fail(key, "must be positive (" + unit + "), got " + Number(value));
  }
  return value;
}

// `waypoints:` and `poses:`: a list of {t_s, ...} with t_s 0 first and increasing, each item's pose read by
// `read_pose` as [position (m); roll, pitch, yaw (rad)].
std::unique_ptr<Trajectory> ReadPoseList(YamlMap& params, const std::string& key, bool five_dof,
                                         const std::function<Vector6d(YamlMap&)>& read_pose) {
  const YAML::Node list = params.Raw(key);
  if (!list || !list.IsSequence() || list.size() == 0) {
    params.Fail(key, "expected a list of {t_s, position_m, ...}, the first at t_s 0");
  }
  std::vector<double> times_s;
  std::vector<Vector6d> values;
  YAML::Node resolved;
  for (size_t i = 0; i < list.size(); ++i) {
    YamlMap item(list[i], params.file(), params.PathOf(key) + "[" + std::to_string(i) + "]");
    double t_s = 0.0;
    item.Required("t_s", &t_s);
    if (i == 0 && t_s != 0.0) item.Fail("t_s", "the first item must be at t_s 0, got " + Number(t_s));
    if (i > 0 && !(t_s > times_s.back())) {
      item.Fail("t_s",
                "must be after the previous item's " + Number(times_s.back()) + " s, got " + Number(t_s));
    }
    times_s.push_back(t_s);
    values.push_back(read_pose(item));
    // the shorter way round between consecutive yaws: 170° to −170° turns through 180°
    if (i > 0) values[i][5] = values[i - 1][5] + std::remainder(values[i][5] - values[i - 1][5], 2.0 * M_PI);
    item.Finish();
    resolved.push_back(item.Resolved());
  }
  params.SetResolved(key, resolved);
  bool stop = false;
  params.Optional("stop_at_waypoints", &stop);
  return std::make_unique<WaypointTrajectory>(KnotsThrough(times_s, values, stop), five_dof);
}

std::unique_ptr<Trajectory> ReadWaypoints(YamlMap& params) {
  return ReadPoseList(params, "waypoints", false, [](YamlMap& item) {
    Vector6d y = Vector6d::Zero();
    y.head<3>() = RequiredVector3(item, "position_m", "[x, y, z] in m (NED)");
    Vector3d rpy_rad = Vector3d::Zero();
    model::OptionalVector3(item, "rpy_deg", &rpy_rad, kDegToRad);
    y.tail<3>() = rpy_rad;
    return y;
  });
}

std::unique_ptr<Trajectory> ReadPoses(YamlMap& params) {
  return ReadPoseList(params, "poses", true, [](YamlMap& item) {
    Vector6d y = Vector6d::Zero();
    y.head<3>() = RequiredVector3(item, "position_m", "[x, y, z] in m (NED)");
    double pitch_deg = 0.0, yaw_deg = 0.0;
    item.Optional("pitch_deg", &pitch_deg);
    item.Optional("yaw_deg", &yaw_deg);
    y[4] = pitch_deg * kDegToRad;
    y[5] = yaw_deg * kDegToRad;
    return y;
  });
}

// ---- path sources: spiral, circle, figure-eight ----

// A point of a curve p(s), s from 0 at the start to 1 at the end, and its first three derivatives in s.
struct CurvePoint {
  Vector3d p, d1, d2, d3;
};
using Curve = std::function<CurvePoint(double s)>;

// Radius and height change linearly with s while the angle turns through `angle_rad` (increasing angles turn
// from x to y: clockwise seen from above in NED). Ends at end_radius from the centre, at the centre's height.
Curve Helix(const Vector3d& center_m, double start_radius_m, double end_radius_m, double start_angle_rad,
            double angle_rad, double climb_m) {
  const double dr = end_radius_m - start_radius_m, w = angle_rad;  // dr/ds, dangle/ds
  return [=](double s) {
    const double r = start_radius_m + dr * s;
    const double cs = std::cos(start_angle_rad + w * s), sn = std::sin(start_angle_rad + w * s);
    return CurvePoint{center_m + Vector3d(r * cs, r * sn, climb_m * (s - 1.0)),
                      Vector3d(dr * cs - r * w * sn, dr * sn + r * w * cs, climb_m),
                      Vector3d(-2.0 * dr * w * sn - r * w * w * cs, 2.0 * dr * w * cs - r * w * w * sn, 0.0),
                      Vector3d(-3.0 * dr * w * w * cs + r * w * w * w * sn,
                               -3.0 * dr * w * w * sn - r * w * w * w * cs, 0.0)};
  };
}

// Lemniscate of Gerono, x = ax·sin φ, y = ay·sin 2φ, with z = −h·sin²φ (NED: h higher at the lobes' tips,
// level at the crossing), φ = 2π·laps·s. Starts and ends at the centre.
Curve FigureEight(const Vector3d& center_m, double ax_m, double ay_m, double height_m, double laps) {
  const double phase_rad = 2.0 * M_PI * laps;
  return [=](double s) {
    const double phi = phase_rad * s;
    const double s1 = std::sin(phi), c1 = std::cos(phi), s2 = std::sin(2.0 * phi), c2 = std::cos(2.0 * phi);
    return CurvePoint{center_m + Vector3d(ax_m * s1, ay_m * s2, 0.5 * height_m * (c2 - 1.0)),
                      phase_rad * Vector3d(ax_m * c1, 2.0 * ay_m * c2, -height_m * s2),
                      std::pow(phase_rad, 2) * Vector3d(-ax_m * s1, -4.0 * ay_m * s2, -2.0 * height_m * c2),
                      std::pow(phase_rad, 3) * Vector3d(-ax_m * c1, -8.0 * ay_m * c2, 4.0 * height_m * s2)};
  };
}

// Attitude along a path: fixed angles, plus a sinusoid of time in every angle scaled by the speed fraction
// (so it fades in from level at the start and out at the end), plus optionally the heading of the path.
struct PathAttitude {
  Vector3d rpy_rad = Vector3d::Zero();
  Vector3d amplitude_rad = Vector3d::Zero();
  double period_s = 0.0;          // of the sinusoid, when amplitude_rad is not zero
  bool yaw_follows_path = false;  // yaw = heading of the path's horizontal tangent + rpy_rad's yaw
};

class PathTrajectory final : public Trajectory {
 public:
  PathTrajectory(Curve curve, SpeedRamp ramp, PathAttitude attitude)
      : curve_(std::move(curve)), ramp_(ramp), attitude_(attitude) {}

  PoseReference Sample(double t_s) const override {
    // the curve parameter s and its time derivatives
    const Jet progress = ramp_.Progress_s(t_s);
    const double s = progress.value / ramp_.cruise_s();
    const double ds = progress.d1 / ramp_.cruise_s(), dds = progress.d2 / ramp_.cruise_s();
    const CurvePoint c = curve_(s);
    const Vector3d v = c.d1 * ds;
    const Vector3d a = c.d2 * ds * ds + c.d1 * dds;

    Vector3d rpy = attitude_.rpy_rad, rpy_rate = Vector3d::Zero(), rpy_accel = Vector3d::Zero();
    if (!attitude_.amplitude_rad.isZero()) {
      const Jet envelope = ramp_.SpeedFraction(t_s);
      const double w = 2.0 * M_PI / attitude_.period_s;
      const double t = std::clamp(t_s, 0.0, ramp_.duration_s());
      const double sn = std::sin(w * t), cs = std::cos(w * t);
      rpy += attitude_.amplitude_rad * (envelope.value * sn);
      rpy_rate += attitude_.amplitude_rad * (envelope.d1 * sn + envelope.value * w * cs);
      rpy_accel += attitude_.amplitude_rad *
                   (envelope.d2 * sn + 2.0 * envelope.d1 * w * cs - envelope.value * w * w * sn);
    }
    if (attitude_.yaw_follows_path) {
      // ψ = atan2(y', x') of the tangent, differentiated in s, then in t
      const double tx = c.d1.x(), ty = c.d1.y(), dtx = c.d2.x(), dty = c.d2.y();
      const double norm2 = tx * tx + ty * ty;  // > 0: circle and figure-eight tangents are never vertical
      const double cross = tx * dty - ty * dtx;
      const double dpsi = cross / norm2;
      const double ddpsi =
          (tx * c.d3.y() - ty * c.d3.x()) / norm2 - cross * 2.0 * (tx * dtx + ty * dty) / (norm2 * norm2);
      rpy.z() += std::atan2(ty, tx);
      rpy_rate.z() += dpsi * ds;
      rpy_accel.z() += ddpsi * ds * ds + dpsi * dds;
    }
    return ReferenceFromEuler(c.p, v, a, rpy, rpy_rate, rpy_accel);
  }

  double duration_s() const override { return ramp_.duration_s(); }

 private:
  Curve curve_;
  SpeedRamp ramp_;
  PathAttitude attitude_;
};

// ramp_s: the time to speed up from rest, and again to slow down to rest at the end
double ReadRamp(YamlMap& params, double default_s) {
  double ramp_s = default_s;
  params.Optional("ramp_s", &ramp_s);
  if (!(ramp_s > 0.0)) params.Fail("ramp_s", "must be positive (s): the flight starts and ends at rest");
  return ramp_s;
}

SpeedRamp CheckedRamp(YamlMap& params, double duration_s, double ramp_s) {
  if (ramp_s > 0.5 * duration_s) {
    params.Fail("ramp_s", "must be at most half the flight (" + Number(duration_s) + " s), got " +
                              Number(ramp_s) + " s");
  }
  return SpeedRamp(duration_s, ramp_s);
}

// the fixed attitude of the circle and the figure-eight
PathAttitude ReadFixedAttitude(YamlMap& params) {
  PathAttitude attitude;
  model::OptionalVector3(params, "rpy_deg", &attitude.rpy_rad, kDegToRad);
  params.Optional("yaw_follows_path", &attitude.yaw_follows_path);
  return attitude;
}

std::unique_ptr<Trajectory> ReadSpiral(YamlMap& params) {
  const Vector3d center_m =
      RequiredVector3(params, "center_m", "[x, y, z] in m (NED), the point spiralled to");
  double start_radius_m = 0.0, end_radius_m = 0.0, turns = 0.0, climb_m = 0.0, start_angle_deg = 0.0;
  params.Required("start_radius_m", &start_radius_m);
  params.Required("end_radius_m", &end_radius_m);
  if (!(start_radius_m >= 0.0)) params.Fail("start_radius_m", "must be >= 0 (m)");
  if (!(end_radius_m >= 0.0)) params.Fail("end_radius_m", "must be >= 0 (m)");
  params.Required("turns", &turns);
  params.Optional("climb_m", &climb_m);
  params.Optional("start_angle_deg", &start_angle_deg);
  const double duration_s = RequiredPositive(params, "duration_s", "s");
  PathAttitude attitude;
  model::OptionalVector3(params, "attitude_amplitude_deg", &attitude.amplitude_rad, kDegToRad);
  params.Optional("attitude_period_s", &attitude.period_s);
  if (!attitude.amplitude_rad.isZero() && !(attitude.period_s > 0.0)) {
    params.Fail("attitude_period_s", "must be positive (s) when attitude_amplitude_deg is set");
  }
  double yaw0_deg = 0.0;
  params.Optional("yaw0_deg", &yaw0_deg);
  attitude.rpy_rad.z() = yaw0_deg * kDegToRad;
  const SpeedRamp ramp = CheckedRamp(params, duration_s, ReadRamp(params, 3.0));
  return std::make_unique<PathTrajectory>(
      Helix(center_m, start_radius_m, end_radius_m, start_angle_deg * kDegToRad, 2.0 * M_PI * turns, climb_m),
      ramp, attitude);
}

std::unique_ptr<Trajectory> ReadCircle(YamlMap& params) {
  const Vector3d center_m = RequiredVector3(params, "center_m", "[x, y, z] in m (NED)");
  const double radius_m = RequiredPositive(params, "radius_m", "m");
  const double speed_mps = RequiredPositive(params, "speed_mps", "m/s");
  double start_angle_deg = 0.0;
  params.Optional("start_angle_deg", &start_angle_deg);
  const PathAttitude attitude = ReadFixedAttitude(params);
  const double ramp_s = ReadRamp(params, 2.0);
  if (params.Has("laps") == params.Has("duration_s")) {
    params.Fail("laps", "give either laps or duration_s (the flight's length, ramps included)");
  }
  // the ramps together cover as much as ramp_s at full speed, so laps are whole
  const double cruise_s = params.Has("laps")
                              ? RequiredPositive(params, "laps", "turns") * 2.0 * M_PI * radius_m / speed_mps
                              : RequiredPositive(params, "duration_s", "s") - ramp_s;
  const SpeedRamp ramp = CheckedRamp(params, cruise_s + ramp_s, ramp_s);
  return std::make_unique<PathTrajectory>(Helix(center_m, radius_m, radius_m, start_angle_deg * kDegToRad,
                                                speed_mps * ramp.cruise_s() / radius_m, 0.0),
                                          ramp, attitude);
}

std::unique_ptr<Trajectory> ReadFigureEight(YamlMap& params) {
  const Vector3d center_m = RequiredVector3(params, "center_m", "[x, y, z] in m (NED)");
  const std::vector<double> size = bridge::ReadNumberList(params, "size_m", {2});
  const double ax_m = size[0], ay_m = size[1];
  if (!(ax_m > 0.0) || !(ay_m > 0.0)) {
    params.Fail("size_m", "expected [ax, ay]: the positive half-extents (m) along x and y");
  }
  double height_m = 0.0;
  params.Optional("height_amplitude_m", &height_m);
  const double period_s = RequiredPositive(params, "period_s", "s per lap at full speed");
  int laps = 1;
  params.OptionalInRange("laps", &laps, 1, 100000);
  const PathAttitude attitude = ReadFixedAttitude(params);
  const double ramp_s = ReadRamp(params, 2.0);
  const SpeedRamp ramp = CheckedRamp(params, laps * period_s + ramp_s, ramp_s);
  return std::make_unique<PathTrajectory>(FigureEight(center_m, ax_m, ay_m, height_m, laps), ramp, attitude);
}

// ---- recorded trajectories ----

struct PoseSample {
  double t_s = 0.0;
  Vector3d p_WP_m = Vector3d::Zero();
  Quaterniond q_WP = Quaterniond::Identity();
};

// Position on a natural cubic spline (C2: acceleration continuous, zero at the first and last samples).
// Attitude per segment R_i·Exp(r(t)), r a cubic in the rotation vector from sample i to sample i+1 whose end
// rates give ω̄ at each sample as the mean of the neighbouring segments' mean rates (one-sided at the ends):
// ω̄ is continuous, dω̄/dt steps at the samples.
class RecordedTrajectory final : public Trajectory {
 public:
  explicit RecordedTrajectory(std::vector<PoseSample> samples) {
    const size_t n = samples.size();
    for (size_t i = 1; i < n; ++i) {  // one sign throughout, for consumers that compare quaternions
      if (samples[i].q_WP.dot(samples[i - 1].q_WP) < 0.0) samples[i].q_WP.coeffs() *= -1.0;
    }
    first_ = samples.front();
    last_ = samples.back();
    const std::vector<Vector3d> accel_mps2 = NaturalSplineAccelerations(samples);
    std::vector<Vector3d> rotation(n - 1), rate(n);
    for (size_t i = 0; i + 1 < n; ++i) {
      rotation[i] = LogQuaternion(samples[i].q_WP.conjugate() * samples[i + 1].q_WP);
    }
    // the rotation vector has the same coordinates in the frames of both its ends
    const auto mean_rate = [&](size_t i) { return rotation[i] / (samples[i + 1].t_s - samples[i].t_s); };
    rate[0] = mean_rate(0);
    rate[n - 1] = mean_rate(n - 2);
    for (size_t i = 1; i + 1 < n; ++i) rate[i] = 0.5 * (mean_rate(i - 1) + mean_rate(i));
    for (size_t i = 0; i + 1 < n; ++i) {
      Segment segment;
      segment.t0_s = samples[i].t_s;
      segment.h_s = samples[i + 1].t_s - samples[i].t_s;
      segment.p0_m = samples[i].p_WP_m;
      segment.p1_m = samples[i + 1].p_WP_m;
      segment.a0_mps2 = accel_mps2[i];
      segment.a1_mps2 = accel_mps2[i + 1];
      segment.q0 = samples[i].q_WP;
      // Hermite cubic r(u) = c1·u + c2·u² + c3·u³ from 0 to the rotation, with ṙ(h) = J(rotation)⁻¹·ω̄_{i+1}
      const Vector3d& turn = rotation[i];
      const Vector3d r_rate_end = RightJacobian(turn).Solve(rate[i + 1]);
      const double h = segment.h_s;
      segment.c1 = rate[i];
      segment.c2 = (3.0 * turn - (2.0 * rate[i] + r_rate_end) * h) / (h * h);
      segment.c3 = (-2.0 * turn + (rate[i] + r_rate_end) * h) / (h * h * h);
      segments_.push_back(segment);
    }
  }

  PoseReference Sample(double t_s) const override {
    PoseReference reference;
    if (t_s <= first_.t_s || t_s >= last_.t_s) {
      const PoseSample& end = t_s <= first_.t_s ? first_ : last_;
      reference.p_WP_m = end.p_WP_m;
      reference.q_WP = end.q_WP;
      return reference;
    }
    const auto next = std::upper_bound(segments_.begin(), segments_.end(), t_s,
                                       [](double t, const Segment& segment) { return t < segment.t0_s; });
    const Segment& g = *(next - 1);
    const double h = g.h_s, u = t_s - g.t0_s, rest = h - u;
    reference.p_WP_m = (g.a0_mps2 * rest * rest * rest + g.a1_mps2 * u * u * u) / (6.0 * h) +
                       (g.p0_m / h - g.a0_mps2 * h / 6.0) * rest + (g.p1_m / h - g.a1_mps2 * h / 6.0) * u;
    reference.v_WP_W_mps = (g.a1_mps2 * u * u - g.a0_mps2 * rest * rest) / (2.0 * h) + (g.p1_m - g.p0_m) / h -
                           (g.a1_mps2 - g.a0_mps2) * h / 6.0;
    reference.a_WP_W_mps2 = (g.a0_mps2 * rest + g.a1_mps2 * u) / h;
    const Vector3d r = ((g.c3 * u + g.c2) * u + g.c1) * u;
    const Vector3d r_rate = (3.0 * g.c3 * u + 2.0 * g.c2) * u + g.c1;
    const Vector3d r_accel = 6.0 * g.c3 * u + 2.0 * g.c2;
    const RightJacobian J(r);
    reference.q_WP = g.q0 * ExpQuaternion(r);
    reference.w_WP_P_radps = J.Times(r_rate);
    reference.dw_WP_P_radps2 = J.Times(r_accel) + J.RateTimesRate(r_rate);
    return reference;
  }

  double duration_s() const override { return last_.t_s; }

 private:
  struct Segment {
    double t0_s, h_s;
    Vector3d p0_m, p1_m, a0_mps2, a1_mps2;
    Quaterniond q0;
    Vector3d c1, c2, c3;
  };

  // second derivatives at the samples: zero at the ends and C2 inside (tridiagonal, Thomas algorithm)
  static std::vector<Vector3d> NaturalSplineAccelerations(const std::vector<PoseSample>& samples) {
    const size_t n = samples.size();
    std::vector<Vector3d> accel(n, Vector3d::Zero()), rhs(n, Vector3d::Zero());
    std::vector<double> diagonal(n, 1.0), above(n, 0.0);
    const auto slope = [&](size_t i) {
      return (samples[i + 1].p_WP_m - samples[i].p_WP_m) / (samples[i + 1].t_s - samples[i].t_s);
    };
    for (size_t i = 1; i + 1 < n; ++i) {
      const double before = samples[i].t_s - samples[i - 1].t_s, after = samples[i + 1].t_s - samples[i].t_s;
      diagonal[i] = 2.0 * (before + after);
      above[i] = after;
      rhs[i] = 6.0 * (slope(i) - slope(i - 1));
      if (i > 1) {  // eliminate the term in accel[i − 1]
        const double w = before / diagonal[i - 1];
        diagonal[i] -= w * above[i - 1];
        rhs[i] -= w * rhs[i - 1];
      }
    }
    for (size_t i = n - 2; i >= 1; --i) accel[i] = (rhs[i] - above[i] * accel[i + 1]) / diagonal[i];
    return accel;
  }

  PoseSample first_, last_;
  std::vector<Segment> segments_;
};

std::unique_ptr<Trajectory> ReadFile(YamlMap& params, const std::string& scenario_file) {
  const std::string path = bridge::ReadFilePath(params, "path", scenario_file);
  if (!params.Has("format")) params.Fail("format", "is required: tum or csv");
  std::string format;
  params.OptionalChoice("format", &format, {"tum", "csv"});
  std::vector<PoseSample> samples;
  for (const bridge::TimedPose& pose : bridge::ReadPoseFile(path, format)) {
    samples.push_back(PoseSample{pose.t_s, pose.position_m, pose.orientation});
  }
  if (samples.size() < 2) {
    throw ConfigError(path + ": expected at least 2 samples, found " + std::to_string(samples.size()));
  }
  // stamps minus the offset are trajectory times
  double time_offset_s = samples.front().t_s;
  params.Optional("time_offset_s", &time_offset_s);
  if (!(time_offset_s <= samples.front().t_s)) {
    params.Fail("time_offset_s", "must be at most the first stamp (" + Number(samples.front().t_s) +
                                     " s) so the recording starts at t >= 0, got " + Number(time_offset_s));
  }
  for (PoseSample& sample : samples) sample.t_s -= time_offset_s;
  return std::make_unique<RecordedTrajectory>(std::move(samples));
}

}  // namespace

PoseReference ReferenceFromEuler(const Eigen::Vector3d& p_WP_m, const Eigen::Vector3d& v_WP_W_mps,
                                 const Eigen::Vector3d& a_WP_W_mps2, const Eigen::Vector3d& rpy_rad,
                                 const Eigen::Vector3d& rpy_rate_radps,
                                 const Eigen::Vector3d& rpy_accel_radps2) {
  const double sr = std::sin(rpy_rad.x()), cr = std::cos(rpy_rad.x());
  const double sp = std::sin(rpy_rad.y()), cp = std::cos(rpy_rad.y());
  const double droll = rpy_rate_radps.x(), dpitch = rpy_rate_radps.y();
  // ω̄ = E·γ̇ for R = Rz(ψ)Ry(θ)Rx(φ), and E's time derivative
  Matrix3d E;
  E << 1.0, 0.0, -sp,    //
      0.0, cr, sr * cp,  //
      0.0, -sr, cr * cp;
  Matrix3d dE;
  dE << 0.0, 0.0, -cp * dpitch,                              //
      0.0, -sr * droll, cr * cp * droll - sr * sp * dpitch,  //
      0.0, -cr * droll, -sr * cp * droll - cr * sp * dpitch;
  PoseReference reference;
  reference.p_WP_m = p_WP_m;
  reference.v_WP_W_mps = v_WP_W_mps;
  reference.a_WP_W_mps2 = a_WP_W_mps2;
  reference.q_WP = AttitudeFromEuler(rpy_rad.x(), rpy_rad.y(), rpy_rad.z());
  reference.w_WP_P_radps = E * rpy_rate_radps;
  reference.dw_WP_P_radps2 = E * rpy_accel_radps2 + dE * rpy_rate_radps;
  return reference;
}

std::unique_ptr<Trajectory> ReadTrajectory(YamlMap& params, const std::string& scenario_file) {
  if (!params.Has("type")) {
    params.Fail("type", "is required: waypoints, poses, spiral, circle, figure_eight or file");
  }
  std::string type;
  params.OptionalChoice("type", &type, {"waypoints", "poses", "spiral", "circle", "figure_eight", "file"});
  std::unique_ptr<Trajectory> trajectory;
  if (type == "waypoints") trajectory = ReadWaypoints(params);
  if (type == "poses") trajectory = ReadPoses(params);
  if (type == "spiral") trajectory = ReadSpiral(params);
  if (type == "circle") trajectory = ReadCircle(params);
  if (type == "figure_eight") trajectory = ReadFigureEight(params);
  if (type == "file") trajectory = ReadFile(params, scenario_file);
  params.Finish();
  return trajectory;
}

}  // namespace iapsim::control
