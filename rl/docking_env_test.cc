// The air-docking environment (seed §IV-E, §VI-H): its task file, its start distribution (eq. 23), its
// action and reward, the latch as the physics closes it, and a vector of environments that repeats itself
// for any thread count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "bridge/config.h"
#include "physics/physics_config.h"
#include "rl/docking_expert.h"
#include "rl/docking_task.h"
#include "rl/vector_env.h"
#include "tests/support/test_folder.h"

namespace iapsim::rl {
namespace {

const std::string kTaskFile = std::string(IAPSIM_SOURCE_DIR) + "/configs/rl/docking.yaml";

DockingTaskConfig Task(const std::vector<std::string>& overrides = {}) {
  return ReadDockingTask(kTaskFile, overrides);
}

// The task with every start at eq. (23)'s middle, level and at rest.
DockingTaskConfig StillTask() {
  return Task({"reset.b_offset_min_m=[0, -1.4, 0]", "reset.b_offset_max_m=[0, -1.4, 0]",
               "reset.tilt_max_deg=0", "reset.yaw_max_deg=0", "reset.speed_max_mps=0",
               "reset.rate_max_deg_s=0"});
}

const physics::BodyState& Platform(const DockingEnv& env, int quadrotor) {
  return env.simulation().world().body(env.simulation().output(quadrotor).platform_body);
}

double Tilt_deg(const Eigen::Quaterniond& q_WB) {
  return std::acos(std::clamp((q_WB * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0)) * 180.0 / M_PI;
}

TEST(DockingTask, TheShippedFileHoldsTheDefaults) {
  const DockingTaskConfig task = Task();
  const DockingTaskConfig defaults;
  EXPECT_EQ(task.control_rate_hz, defaults.control_rate_hz);
  EXPECT_EQ(task.reset.b_offset_min_m, defaults.reset.b_offset_min_m);
  EXPECT_EQ(task.reset.b_offset_max_m, defaults.reset.b_offset_max_m);
  EXPECT_EQ(task.reward.latch_bonus, defaults.reward.latch_bonus);
  EXPECT_EQ(task.reward.shaping, defaults.reward.shaping);
  EXPECT_EQ(task.reward.discount, defaults.reward.discount);
  EXPECT_EQ(task.termination.max_steps, defaults.termination.max_steps);
  EXPECT_EQ(task.noise.acceleration_mps2, defaults.noise.acceleration_mps2);
  EXPECT_NE(task.scenario.find("docking_approach.yaml"), std::string::npos) << task.scenario;
}

// A wrong key, value or world is an error that names the file and the key.
TEST(DockingTask, BadInputNamesTheFileAndTheKey) {
  const auto message = [](const std::vector<std::string>& overrides) -> std::string {
    try {
      DockingEnv env(Task(overrides));
    } catch (const bridge::ConfigError& error) {
      return error.what();
    }
    return "no error";
  };
  EXPECT_NE(message({"reward.bonus=1"}).find("reward.bonus"), std::string::npos);
  EXPECT_NE(message({"reward.shaping=linear"}).find("reward.shaping"), std::string::npos);
  EXPECT_NE(message({"reward.discount=1.5"}).find("reward.discount"), std::string::npos);
  EXPECT_NE(message({"reset.b_offset_max_m=[0, -1.6, 0]"}).find("b_offset_max_m"), std::string::npos);
  EXPECT_NE(message({"termination.max_steps=0"}).find("termination.max_steps"), std::string::npos);
  EXPECT_NE(message({"vehicle_b=c"}).find("no vehicle 'c'"), std::string::npos);
  EXPECT_NE(message({"latch=gripper"}).find("no latch 'gripper'"), std::string::npos);
  EXPECT_NE(message({"control_rate_hz=300"}).find("control_rate_hz"), std::string::npos);
  EXPECT_NE(message({"max_acceleration_mps2=0"}).find("max_acceleration_mps2"), std::string::npos);
  // A and B swapped: the latch's cylinder is not on the vehicle that should carry it
  EXPECT_NE(message({"vehicle_a=b", "vehicle_b=a"}).find("body_a must be on vehicle 'b'"), std::string::npos);
  EXPECT_NE(message({}).find("no error"), std::string::npos);

  test_support::TestFolder folder("docking_task");
  const std::string bad = folder.Write("task.yaml", "scenario: missing.yaml\n");
  try {
    DockingEnv env(ReadDockingTask(bad));
    FAIL() << "a missing scenario was accepted";
  } catch (const bridge::ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("missing.yaml"), std::string::npos) << error.what();
  }
}

// eq. (23): B starts uniformly in [-0.15, 0.15] x [-1.5, -1.3] x [-0.15, 0.15] m from A, which starts at its
// target; both within the start's tilt, yaw, speed and rate.
TEST(DockingEnv, StartsAsEquation23Says) {
  const DockingTaskConfig task = Task();
  DockingEnv env(task);
  const Eigen::Vector3d lo = task.reset.b_offset_min_m, hi = task.reset.b_offset_max_m;
  Eigen::Vector3d smallest = Eigen::Vector3d::Constant(1e9), largest = -smallest,
                  sum = Eigen::Vector3d::Zero();
  constexpr int kStarts = 300;
  for (int n = 0; n < kStarts; ++n) {
    env.Reset(1000 + n);
    ASSERT_LT((Platform(env, 0).p_WB_m - env.target_a_m()).norm(), 1e-9);
    const Eigen::Vector3d offset_m =
        env.target_q_WP().conjugate() * (Platform(env, 1).p_WB_m - env.target_a_m());
    smallest = smallest.cwiseMin(offset_m);
    largest = largest.cwiseMax(offset_m);
    sum += offset_m;
    for (int i = 0; i < 2; ++i) {
      const physics::BodyState& state = Platform(env, i);
      EXPECT_LT(Tilt_deg(state.q_WB), std::sqrt(2.0) * task.reset.tilt_max_deg + 1e-9);
      EXPECT_LE(state.v_WB_W.cwiseAbs().maxCoeff(), task.reset.speed_max_mps + 1e-9);
      EXPECT_LE(state.w_WB_W.cwiseAbs().maxCoeff(), task.reset.rate_max_deg_s * M_PI / 180.0 + 1e-9);
    }
  }
  for (int axis = 0; axis < 3; ++axis) {
    const double range = hi[axis] - lo[axis];
    EXPECT_GE(smallest[axis], lo[axis] - 1e-9);
    EXPECT_LE(largest[axis], hi[axis] + 1e-9);
    // 300 uniform draws reach within 3 % of both ends (each end missed with probability 0.97^300 ≈ 1e-4)
    EXPECT_LT(smallest[axis] - lo[axis], 0.03 * range);
    EXPECT_LT(hi[axis] - largest[axis], 0.03 * range);
    // the mean within 4 standard errors of the middle (σ = range / √12)
    EXPECT_NEAR(sum[axis] / kStarts, 0.5 * (lo[axis] + hi[axis]), 4.0 * range / std::sqrt(12.0 * kStarts));
  }
  // the same seed, the same start; another seed, another
  const Observation first = env.Reset(5);
  EXPECT_EQ(env.Reset(5), first);
  EXPECT_NE(env.Reset(6), first);
}

// A zero action hovers level where the quadrotors are; a linear acceleration command is flown.
TEST(DockingEnv, AZeroActionHoversAndAnAccelerationIsFlown) {
  DockingEnv env(StillTask());
  Observation observation = env.Reset(1);
  for (int k = 0; k < 200; ++k) env.Step(Action::Zero(), &observation);
  for (int i = 0; i < 2; ++i) {
    EXPECT_LT(Platform(env, i).v_WB_W.norm(), 0.01) << i;
    EXPECT_LT(Tilt_deg(Platform(env, i).q_WB), 0.1) << i;
  }
  EXPECT_LT((Platform(env, 0).p_WB_m - env.target_a_m()).norm(), 0.005);

  // A asked for 1 m/s² along x for 1 s (action 0.25 of 4 m/s²): the flight controller tilts it within
  // two tenths of a second, so it gains 1 m/s and 0.5 m less what that lag costs
  Action action = Action::Zero();
  action[0] = 1.0 / env.config().max_acceleration_mps2;
  const double start_x_m = Platform(env, 0).p_WB_m.x();
  for (int k = 0; k < 200; ++k) env.Step(action, &observation);
  const physics::BodyState& a = Platform(env, 0);
  EXPECT_GT(a.v_WB_W.x(), 0.8);
  EXPECT_LT(a.v_WB_W.x(), 1.0);
  EXPECT_LT(std::abs(a.v_WB_W.z()), 0.05);  // the thrust kept its height
  EXPECT_GT(a.p_WB_m.x() - start_x_m, 0.5 * 0.8 * 0.8);
  // what A observes: its velocity (noise 2 cm/s) and its acceleration along x (noise 0.06 m/s²)
  EXPECT_NEAR(observation[3], a.v_WB_W.x(), 0.1);
  EXPECT_NEAR(observation[18], 1.0, 0.3);
}

TEST(DockingEnv, RewardTermsAreTheWeightedDistancesAndForces) {
  const DockingTaskConfig task = Task();
  const Eigen::Vector3d errors_m[2] = {Eigen::Vector3d(0.3, 0.4, 0.0), Eigen::Vector3d(0.0, 0.0, -1.0)};
  const double attitude_rad[2] = {0.1, 0.2};
  const RewardTerms guided = DockingEnv::Reward(task, errors_m, attitude_rad, true, 0.02, 0.003, -5.0);
  EXPECT_DOUBLE_EQ(guided.position, -1.0 * (0.5 + 1.0));
  EXPECT_DOUBLE_EQ(guided.attitude, -0.5 * 0.3);
  EXPECT_DOUBLE_EQ(guided.guide, 0.5);
  EXPECT_DOUBLE_EQ(guided.relative, -2.0 * (0.003 + 0.02));
  EXPECT_DOUBLE_EQ(guided.force, -0.05 * (5.0 - 2.0));
  EXPECT_DOUBLE_EQ(guided.bonus, 0.0);
  EXPECT_DOUBLE_EQ(guided.total(), -1.5 - 0.15 + 0.5 - 0.046 - 0.15);
  // outside the guiding region nothing is given for it; a push within the free force costs nothing
  const RewardTerms outside = DockingEnv::Reward(task, errors_m, attitude_rad, false, 0.5, 0.2, 1.5);
  EXPECT_EQ(outside.guide, 0.0);
  EXPECT_EQ(outside.relative, 0.0);
  EXPECT_EQ(outside.force, 0.0);
}

// Potential shaping (Ng et al. 1999) pays γ Φ(s′) − Φ(s) for the state terms that direct shaping pays as
// they are, Φ = 0 once the episode has ended: the same expert episode flown both ways, step by step.
TEST(DockingEnv, PotentialShapingPaysTheChangeOfTheStateTerms) {
  constexpr double kDiscount = 0.9;
  struct Step {
    double potential, force, bonus, reward;
    bool terminated;
  };
  const auto fly = [](const DockingTaskConfig& task) {
    DockingEnv env(task);
    DockingExpert expert(env);
    Observation observation = env.Reset(3);
    expert.Reset();
    std::vector<Step> steps;
    StepResult result;
    while (!result.terminated && !result.truncated) {
      result = env.Step(expert.Act(observation), &observation);
      const RewardTerms& terms = env.reward_terms();
      steps.push_back({terms.potential(), terms.force, terms.bonus, result.reward, result.terminated});
    }
    return steps;
  };
  const std::vector<Step> direct = fly(Task({"reward.shaping=direct"}));
  const std::vector<Step> shaped =
      fly(Task({"reward.shaping=potential", "reward.discount=" + std::to_string(kDiscount)}));
  ASSERT_EQ(shaped.size(), direct.size());  // the reward changes nothing the episode does
  ASSERT_TRUE(direct.back().terminated);
  EXPECT_GT(direct.back().bonus, 0.0);  // the expert docks
  for (size_t k = 1; k < direct.size(); ++k) {
    const double next_potential = direct[k].terminated ? 0.0 : direct[k].potential;
    EXPECT_NEAR(shaped[k].reward,
                direct[k].bonus + direct[k].force + kDiscount * next_potential - direct[k - 1].potential,
                1e-9)
        << "step " << k + 1;
    EXPECT_EQ(shaped[k].potential, 0.0);  // paid as shaping, not as terms
  }
}

TEST(DockingEnv, TheGuidingRegionIsAConeAheadOfTheFace) {
  const GuidingRegion guide;  // 0.3 m long, 1 cm at the face, widening at 15°
  const double at_10cm_m = guide.radius_m + 0.1 * std::tan(guide.half_angle_deg * M_PI / 180.0);
  EXPECT_TRUE(DockingEnv::InGuidingRegion(guide, 0.1, at_10cm_m - 1e-6));
  EXPECT_FALSE(DockingEnv::InGuidingRegion(guide, 0.1, at_10cm_m + 1e-6));
  EXPECT_TRUE(DockingEnv::InGuidingRegion(guide, 0.0, 0.009));
  EXPECT_FALSE(DockingEnv::InGuidingRegion(guide, 0.0, 0.011));
  EXPECT_FALSE(DockingEnv::InGuidingRegion(guide, 0.31, 0.0));   // too far ahead
  EXPECT_TRUE(DockingEnv::InGuidingRegion(guide, -0.005, 0.0));  // pressed a little past the face
  EXPECT_FALSE(DockingEnv::InGuidingRegion(guide, -0.02, 0.0));  // through it
}

// The expert from one random start, and the same setpoints on a simulation built from the scenario alone
// (as the physics process builds it): the latch closes at the same physics step and the pair ends in the
// same state, so the environment adds nothing to the world but its control period.
TEST(DockingEnv, TheLatchClosesWhenItDoesInThePhysicsAlone) {
  const DockingTaskConfig task = Task();
  DockingEnv env(task);
  DockingExpert expert(env);
  Observation observation = env.Reset(3);
  expert.Reset();

  physics::SimulationConfig world = physics::LoadScenarioPhysics(task.scenario).simulation;
  for (int v = 0; v < 2; ++v) world.vehicles[v] = env.simulation().vehicle(v);
  physics::Simulation physics_alone(world);
  const int latch = physics_alone.FindLatch(task.latch);
  ASSERT_GE(latch, 0);

  int latched_physics_step = -1;
  StepResult result;
  while (!result.terminated && !result.truncated) {
    const Action action = expert.Act(observation);
    for (int i = 0; i < 2; ++i) physics_alone.SetCommand(i, 0, env.Setpoint(i, action));
    for (int k = 0; k < env.physics_substeps(); ++k) {
      physics_alone.Step();
      if (latched_physics_step < 0 && physics_alone.latch_output(latch).latched) {
        latched_physics_step = static_cast<int>(physics_alone.step_count());
      }
    }
    result = env.Step(action, &observation);
  }
  EXPECT_EQ(result.info.outcome, Outcome::kSuccess) << OutcomeName(result.info.outcome);
  ASSERT_GT(latched_physics_step, 0);
  EXPECT_EQ(result.info.docked_step, (latched_physics_step - 1) / env.physics_substeps() + 1);
  for (int i = 0; i < 2; ++i) {
    const physics::BodyState& alone = physics_alone.world().body(physics_alone.output(i).platform_body);
    EXPECT_EQ(alone.p_WB_m, Platform(env, i).p_WB_m);
    EXPECT_EQ(alone.q_WB.coeffs(), Platform(env, i).q_WB.coeffs());
  }
}

// Random actions from a seeded stream on four environments with short episodes (so that some reset on
// their own): every observation, reward and flag the same on 1, 2 and 4 threads.
TEST(VectorEnv, RepeatsItselfForAnyThreadCount) {
  const DockingTaskConfig task = Task({"termination.max_steps=40"});
  const auto roll_out = [&](int threads) {
    VectorEnv envs(task, 4, threads);
    std::mt19937_64 random(11);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    const RowMatrix& first = envs.Reset(7);
    std::vector<double> trace(first.data(), first.data() + first.size());
    int ends = 0;
    for (int k = 0; k < 100; ++k) {
      RowMatrix actions(envs.count(), kActionSize);
      for (int r = 0; r < actions.rows(); ++r) {
        for (int c = 0; c < actions.cols(); ++c) actions(r, c) = 0.3 * uniform(random);
      }
      envs.Step(actions);
      trace.insert(trace.end(), envs.observations().data(),
                   envs.observations().data() + envs.observations().size());
      for (int i = 0; i < envs.count(); ++i) {
        trace.insert(trace.end(),
                     {envs.rewards()[i], double(envs.terminated()[i]), double(envs.truncated()[i])});
        ends += envs.terminated()[i] + envs.truncated()[i];
      }
    }
    EXPECT_GE(ends, 8);  // every environment ended at least twice and went on
    return trace;
  };
  const std::vector<double> one = roll_out(1);
  EXPECT_EQ(roll_out(2), one);
  EXPECT_EQ(roll_out(4), one);
  EXPECT_THROW(VectorEnv(Task(), 2, 0), std::invalid_argument);
}

TEST(DockingEnv, StepAfterTheEndOrWithANonFiniteActionIsAnError) {
  DockingEnv env(Task({"termination.max_steps=1"}));
  Observation observation = env.Reset(1);
  Action action = Action::Zero();
  action[2] = std::nan("");
  EXPECT_THROW(env.Step(action, &observation), std::invalid_argument);
  const StepResult result = env.Step(Action::Zero(), &observation);
  EXPECT_TRUE(result.truncated);
  EXPECT_EQ(result.info.outcome, Outcome::kTimeout);
  EXPECT_THROW(env.Step(Action::Zero(), &observation), std::logic_error);
  env.Reset();
  EXPECT_NO_THROW(env.Step(Action::Zero(), &observation));
}

}  // namespace
}  // namespace iapsim::rl
