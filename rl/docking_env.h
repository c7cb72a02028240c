#pragma once
// The air-docking environment (seed §IV-E, §VI-H, eq. (23)): two quadrotors in the project's physics, in
// process and without the bus. Quadrotor A carries the cylinder and should hold its start; B carries the
// cone and should dock into it; the latch (physics/simulation.h) closes when the cone's apex reaches the
// cylinder's face within tolerance, and the pair then hovers as one body.
//
// Gymnasium's API in C++: Reset(seed) gives the first observation, Step(action) the next one with the reward
// and whether the episode terminated (success, crash, separation) or was truncated (time). A step is one
// control period (200 Hz): the action becomes each quadrotor's flight-controller setpoint, held for the
// physics substeps in between.
//
// Observation (kObservationSize, all in W = NED unless named): for A then B, the position error to its
// target p − p̄ (3), velocity (3), attitude R_WP row by row (9), body rate in P (3), acceleration (3); then
// the contact wrench on B from A in B's frame P, force (3, N) and moment about P's origin (3, N·m), averaged
// over the control period. B's target is where its port meets A's port with A at its target; y of P is the
// docking axis, so the wrench's f_y is the paper's contact force along y. Noise as DockingTaskConfig says,
// drawn from the environment's own stream.
//
// Action (kActionSize, each in [−1, 1], clipped): for A then B, a linear acceleration in W (3) and an
// angular acceleration in P (3), scaled by the task's limits. A flight controller (PX4's cascade,
// physics/flight_controller.h) realises them: the thrust m (a − g) sets its collective thrust and, through
// equation (18), its roll and pitch at the target's yaw; the angular acceleration is fed forward into its
// rate loop. A zero action hovers level at the target's yaw.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <random>
#include <string>

#include "physics/simulation.h"
#include "rl/docking_task.h"

namespace iapsim::rl {

constexpr int kObservationPerQuadrotor = 21;
constexpr int kContactWrenchSize = 6;
constexpr int kObservationSize = 2 * kObservationPerQuadrotor + kContactWrenchSize;
constexpr int kActionPerQuadrotor = 6;
constexpr int kActionSize = 2 * kActionPerQuadrotor;

using Observation = Eigen::Matrix<double, kObservationSize, 1>;
using Action = Eigen::Matrix<double, kActionSize, 1>;

/// How an episode ended (or that it goes on).
enum class Outcome { kRunning, kSuccess, kCrash, kSeparation, kTimeout };
const char* OutcomeName(Outcome outcome);

/// What a step did, beyond the reward.
struct StepInfo {
  Outcome outcome = Outcome::kRunning;
  bool latched = false;
  int step = 0;                    // control steps into the episode, this one included
  int docked_step = -1;            // the step at which the latch closed, or −1
  double axial_error_m = 0.0;      // d_y of the latch (the cone's apex short of the face), noise-free
  double radial_error_m = 0.0;     // d_xz
  double contact_force_y_N = 0.0;  // f_y of the observation, noise-free
  bool in_guiding_region = false;
};

struct StepResult {
  double reward = 0.0;
  bool terminated = false;  // success, crash or separation: the episode's own end
  bool truncated = false;   // out of time
  StepInfo info;
};

/// What the environment (or a process flying its task) knows of one quadrotor's platform, noise-free.
struct QuadrotorState {
  Eigen::Vector3d p_WP_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_WP = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_WP_W_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_WP_W_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_WP_W_mps2 = Eigen::Vector3d::Zero();
};
using ContactWrench = Eigen::Matrix<double, kContactWrenchSize, 1>;

/// Where an episode stands after a control step (DockingEnv::Judge).
struct EpisodeProgress {
  int step = 0;              // control steps into the episode
  int docked_step = -1;      // the step at which the latch closed, or −1
  int hover_steps = 0;       // consecutive latched steps hovering
  bool just_docked = false;  // the latch closed at this step
};

/// The reward's terms of one step (DockingReward), each already weighted and signed.
struct RewardTerms {
  double position = 0.0;
  double attitude = 0.0;
  double guide = 0.0;
  double relative = 0.0;
  double force = 0.0;
  double bonus = 0.0;    // latch, success, failure
  double shaping = 0.0;  // γ Φ(s′) − Φ(s) under potential shaping, which pays the four terms above as Φ
  /// Φ: what the state terms sum to.
  double potential() const { return position + attitude + guide + relative; }
  double total() const { return potential() + force + bonus + shaping; }
};

class DockingEnv {
 public:
  /// Reads the task's scenario physics once; throws bridge::ConfigError when the scenario lacks the task's
  /// vehicles or latch, or when they do not make a docking pair (ports facing each other, level).
  explicit DockingEnv(const DockingTaskConfig& config);
  ~DockingEnv();

  /// Seeds the environment's stream and starts an episode.
  Observation Reset(uint64_t seed);
  /// Starts the next episode on the environment's stream.
  Observation Reset();
  /// One control step. After the episode ended, Reset() must come first (std::logic_error otherwise).
  StepResult Step(const Action& action, Observation* observation);

  const DockingTaskConfig& config() const { return config_; }
  int physics_substeps() const { return substeps_; }
  /// The simulation of the current episode.
  const physics::Simulation& simulation() const { return *simulation_; }
  /// Quadrotor i's start in the current episode (0: A, 1: B), as a scenario's vehicle entry writes it, and
  /// its index among the scenario's vehicles: what a run of the scenario needs to start the same episode.
  const physics::VehicleSpec& start(int quadrotor) const {
    return episode_world_.vehicles[vehicle_[quadrotor]];
  }
  int vehicle_index(int quadrotor) const { return vehicle_[quadrotor]; }
  /// The last step's reward, term by term.
  const RewardTerms& reward_terms() const { return terms_; }
  /// Targets of A's and B's platform frames, in W.
  const Eigen::Vector3d& target_a_m() const { return target_m_[0]; }
  const Eigen::Vector3d& target_b_m() const { return target_m_[1]; }
  /// Both quadrotors' target attitude (level, at A's yaw in the scenario).
  const Eigen::Quaterniond& target_q_WP() const { return target_q_WP_; }
  /// The flight-controller setpoint that realises quadrotor i's part of `action` (0: A, 1: B), as Step sends
  /// it; a process that flies a policy outside the environment sends the same.
  physics::SubAircraftSetpoint Setpoint(int quadrotor, const Action& action) const;
  /// The observation of A's and B's states and the contact wrench on B (in B's frame, averaged over the
  /// control period), with the task's noise drawn from `random`: what Step observes, and what a process
  /// flying the task observes from the bus.
  Observation Observe(const QuadrotorState (&states)[2], const ContactWrench& contact_wrench,
                      std::mt19937_64& random) const;
  /// Advances `progress` by one control step of A's and B's noise-free states with the latch closed or not,
  /// and returns how the episode stands by the task's termination rules (kRunning while it goes on).
  Outcome Judge(const QuadrotorState (&states)[2], bool latched, EpisodeProgress* progress) const;

  /// The reward of one step from noise-free quantities (for tests and for relabelling data).
  static RewardTerms Reward(const DockingTaskConfig& config, const Eigen::Vector3d position_error_m[2],
                            const double attitude_error_rad[2], bool in_guiding_region, double axial_error_m,
                            double radial_error_m, double contact_force_y_N);
  /// Whether a port at (axial, radial) from A's port is in the task's guiding region.
  static bool InGuidingRegion(const GuidingRegion& guide, double axial_error_m, double radial_error_m);

 private:
  void StartEpisode();
  void CurrentStates(QuadrotorState (&states)[2]) const;
  /// The reward's terms (no bonus yet) of the current state, the contact force along y given.
  RewardTerms StateReward(const QuadrotorState (&states)[2], double contact_force_y_N) const;

  DockingTaskConfig config_;
  physics::SimulationConfig world_;  // the scenario's, with A and B where it put them
  physics::SimulationConfig episode_world_;  // the current episode's: A and B where it starts them
  int vehicle_[2] = {0, 0};          // A's and B's index in world_.vehicles
  int latch_ = 0;
  int substeps_ = 1;
  Eigen::Vector3d target_m_[2];
  Eigen::Quaterniond target_q_WP_ = Eigen::Quaterniond::Identity();
  double target_yaw_rad_ = 0.0;
  double mass_kg_[2] = {0.0, 0.0};
  // each quadrotor's frame S in its platform frame P (level: a yaw only)
  Eigen::Quaterniond q_PS_[2] = {Eigen::Quaterniond::Identity(), Eigen::Quaterniond::Identity()};
  double sub_yaw_rad_[2] = {0.0, 0.0};
  double ground_z_m_ = 0.0;
  bool has_ground_ = false;

  std::mt19937_64 random_;
  std::unique_ptr<physics::Simulation> simulation_;
  EpisodeProgress progress_;
  bool done_ = true;
  ContactWrench contact_wrench_ = ContactWrench::Zero();
  RewardTerms terms_;
  double potential_ = 0.0;  // Φ of the current state, under potential shaping
};

}  // namespace iapsim::rl
