#pragma once
// The air-docking task of the seed's §IV-E and §VI-H, as a reinforcement-learning task: what an episode
// starts from, what the policy observes and commands, how it is rewarded and when it ends. The world (the two
// docking quadrotors, the latch, the ground) is a scenario's physics, read as the physics process reads it,
// so that the environment and the multi-process graph fly the same vehicles and the same latch.
//
// The paper names the reward's terms but not their weights or forms, the observation noise but not its
// sizes, and the action but not its limits; each value below is this project's choice, stated where it is
// declared.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace iapsim::bridge {
class YamlMap;
}

namespace iapsim::rl {

/// eq. (23): quadrotor B's start relative to A's (A flies from the scenario's position), uniform per axis,
/// in W (NED). The paper gives B's height as 4.85..5.15 m with A at 5 m: ±0.15 m in z.
struct DockingReset {
  Eigen::Vector3d b_offset_min_m{-0.15, -1.5, -0.15};
  Eigen::Vector3d b_offset_max_m{0.15, -1.3, 0.15};
  // "random attitudes and velocities" (§VI-H) for both quadrotors, uniform within ±: small enough that the
  // flight controllers catch them in a few tenths of a second
  double tilt_max_deg = 5.0;  // roll and pitch
  double yaw_max_deg = 5.0;
  double speed_max_mps = 0.2;  // per axis
  double rate_max_deg_s = 10.0;
};

/// Gaussian noise on what the policy observes (§VI-H: pose, velocity, angular velocity and acceleration;
/// the contact wrench is left clean, as the paper's RaiSim force spikes were), one sigma per axis. Sizes
/// of the sensors the project already models: a VIO pose (sensors/odometry.h's realistic profile, 2 cm/s),
/// PX4 Gazebo's ADIS16448 rate and acceleration noise at 200 Hz (0.0038 rad/s, 0.057 m/s²), rounded up.
struct ObservationNoise {
  double position_m = 0.005;
  double attitude_deg = 0.5;
  double velocity_mps = 0.02;
  double rate_radps = 0.005;
  double acceleration_mps2 = 0.06;
};

/// The reward's terms (§IV-E: pose tracking of both quadrotors, being in the guiding region, the relative
/// position while docking, the contact force along y), per control step, and the episode's bonuses. The
/// tracking terms are negative distances, so a policy that only hovers where it started collects about −0.8
/// a step; the bonuses outweigh a whole episode of that.
///
/// `shaping` says how the state terms (position, attitude, guide, relative) enter the reward:
///  - direct: paid every step, as the paper words them. Then a policy can earn more by staying in the
///    guiding region than by docking, which pays its bonuses and ends the episode (the README's PPO runs).
///  - potential (the default): as potential-based shaping (Ng, Harada & Russell 1999, "Policy invariance
///  under reward
///    transformations"): their sum Φ(s) pays γ Φ(s′) − Φ(s) per step, Φ = 0 after a crash, separation or
///    success (Grześ 2017, "Reward shaping in episodic RL"), so every return telescopes to the bonuses and
///    the force cost less Φ(start), and the optimal policy is that of the bonuses alone: docking, soon. It
///    holds for a learner discounting with the same γ, `discount`.
struct DockingReward {
  enum class Shaping { kDirect, kPotential };
  double position_per_m = 1.0;    // −Σ |p_i − p̄_i| over the two quadrotors
  double attitude_per_rad = 0.5;  // −Σ angle(R̄_iᵀ R_i)
  double guide = 0.5;             // + while B's port is in the guiding region of A's
  double relative_per_m = 2.0;    // −(d_xz + |d_y|) while in the guiding region
  double force_per_N = 0.05;      // −(|f_y| − force_free_N)⁺
  double force_free_N = 2.0;      // a push up to this is free (the latch needs contact)
  double latch_bonus = 50.0;      // once, when the latch closes
  double success_bonus = 100.0;   // once, at success
  double failure_penalty = 50.0;  // once, at a crash or separation
  Shaping shaping = Shaping::kPotential;
  double discount = 0.99;  // γ of the potential-based shaping: the learner's (PPO's default)
};

/// The guiding region: a cone ahead of A's port along its axis (the cylinder's face), in which B's port
/// (the cone's apex) is "in the guiding area" of §IV-E.
struct GuidingRegion {
  double length_m = 0.3;         // along the axis, from the face
  double radius_m = 0.01;        // at the face: about twice the latch's radial tolerance
  double half_angle_deg = 15.0;  // it widens with the distance
};

/// When an episode ends.
struct DockingTermination {
  int max_steps = 2000;          // truncated after 10 s at 200 Hz (the paper's PPO docks in 890 steps)
  double hover_s = 1.0;          // success: latched, then hovering this long as one body (§VI-H)
  double hover_speed_mps = 0.3;  // hovering: both quadrotors slower than this
  double hover_tilt_deg = 20.0;  // and tilted less than this
  double crash_tilt_deg = 60.0;  // a crash: a quadrotor tilted beyond this,
  double crash_height_m = 0.5;   // or lower than this above the ground
  double separation_m = 2.5;     // separation: a quadrotor this far from its target
};

struct DockingTaskConfig {
  std::string file;  // where it was read from, for messages
  // the world: this scenario's physics process (vehicles, latch, ground), with these overrides of its keys
  // (`scenario_set: [fidelity=realistic]` flies the task in the realistic profile: wind, latency, estimation)
  std::string scenario;
  std::vector<std::string> scenario_overrides;
  std::string vehicle_a = "a";  // carries the cylinder (A's port on it)
  std::string vehicle_b = "b";  // carries the cone
  std::string latch = "dock";
  double control_rate_hz = 200.0;  // §VI-H: 200 steps per second; physics substeps in between
  // the action in [−1, 1] scaled to these: a linear acceleration in W and an angular one in the body frame
  // (§IV-E's a = [v̇, ω̇]); 4 m/s² leaves margin under the F450's 2.6 thrust-to-weight ratio
  double max_acceleration_mps2 = 4.0;
  double max_angular_acceleration_radps2 = 10.0;
  DockingReset reset;
  ObservationNoise noise;
  DockingReward reward;
  GuidingRegion guide;
  DockingTermination termination;
};

/// Reads a task file (keys as the structs above, angles in degrees as named). Relative scenario paths
/// resolve against the task file's folder. Throws bridge::ConfigError naming the file, the key and what was
/// expected.
DockingTaskConfig ReadDockingTask(const std::string& file, const std::vector<std::string>& overrides = {});

/// The list of "KEY=VALUE" overrides under `key` of `map` (empty when absent); a value of another shape is a
/// ConfigError naming the key.
std::vector<std::string> ReadOverrides(bridge::YamlMap& map, const std::string& key);

}  // namespace iapsim::rl
