#include "rl/docking_task.h"

#include "bridge/config.h"
#include "model/vehicle.h"

namespace iapsim::rl {
namespace {

using bridge::YamlMap;

void ReadReset(YamlMap map, DockingReset* reset) {
  model::OptionalVector3(map, "b_offset_min_m", &reset->b_offset_min_m);
  model::OptionalVector3(map, "b_offset_max_m", &reset->b_offset_max_m);
  for (int axis = 0; axis < 3; ++axis) {
    if (reset->b_offset_min_m[axis] > reset->b_offset_max_m[axis]) {
      map.Fail("b_offset_max_m", "must be at least b_offset_min_m on every axis");
    }
  }
  map.OptionalInRange("tilt_max_deg", &reset->tilt_max_deg, 0.0, 45.0);
  map.OptionalInRange("yaw_max_deg", &reset->yaw_max_deg, 0.0, 180.0);
  map.OptionalInRange("speed_max_mps", &reset->speed_max_mps, 0.0, 5.0);
  map.OptionalInRange("rate_max_deg_s", &reset->rate_max_deg_s, 0.0, 360.0);
  map.Finish();
}

void ReadNoise(YamlMap map, ObservationNoise* noise) {
  map.OptionalInRange("position_m", &noise->position_m, 0.0, 1.0);
  map.OptionalInRange("attitude_deg", &noise->attitude_deg, 0.0, 30.0);
  map.OptionalInRange("velocity_mps", &noise->velocity_mps, 0.0, 1.0);
  map.OptionalInRange("rate_radps", &noise->rate_radps, 0.0, 1.0);
  map.OptionalInRange("acceleration_mps2", &noise->acceleration_mps2, 0.0, 10.0);
  map.Finish();
}

void ReadReward(YamlMap map, DockingReward* reward) {
  constexpr double kMax = 1e6;
  map.OptionalInRange("position_per_m", &reward->position_per_m, 0.0, kMax);
  map.OptionalInRange("attitude_per_rad", &reward->attitude_per_rad, 0.0, kMax);
  map.OptionalInRange("guide", &reward->guide, 0.0, kMax);
  map.OptionalInRange("relative_per_m", &reward->relative_per_m, 0.0, kMax);
  map.OptionalInRange("force_per_N", &reward->force_per_N, 0.0, kMax);
  map.OptionalInRange("force_free_N", &reward->force_free_N, 0.0, kMax);
  map.OptionalInRange("latch_bonus", &reward->latch_bonus, 0.0, kMax);
  map.OptionalInRange("success_bonus", &reward->success_bonus, 0.0, kMax);
  map.OptionalInRange("failure_penalty", &reward->failure_penalty, 0.0, kMax);
  std::string shaping = reward->shaping == DockingReward::Shaping::kPotential ? "potential" : "direct";
  map.OptionalChoice("shaping", &shaping, {"direct", "potential"});
  reward->shaping =
      shaping == "potential" ? DockingReward::Shaping::kPotential : DockingReward::Shaping::kDirect;
  map.OptionalInRange("discount", &reward->discount, 0.0, 1.0);
  map.Finish();
}

void ReadGuide(YamlMap map, GuidingRegion* guide) {
  map.OptionalInRange("length_m", &guide->length_m, 0.0, 10.0);
  map.OptionalInRange("radius_m", &guide->radius_m, 0.0, 1.0);
  map.OptionalInRange("half_angle_deg", &guide->half_angle_deg, 0.0, 80.0);
  map.Finish();
}

void ReadTermination(YamlMap map, DockingTermination* termination) {
  map.OptionalInRange("max_steps", &termination->max_steps, 1, 1000000);
  map.OptionalInRange("hover_s", &termination->hover_s, 0.0, 60.0);
  map.OptionalInRange("hover_speed_mps", &termination->hover_speed_mps, 0.0, 10.0);
  map.OptionalInRange("hover_tilt_deg", &termination->hover_tilt_deg, 0.0, 90.0);
  map.OptionalInRange("crash_tilt_deg", &termination->crash_tilt_deg, 1.0, 180.0);
  map.OptionalInRange("crash_height_m", &termination->crash_height_m, 0.0, 100.0);
  map.OptionalInRange("separation_m", &termination->separation_m, 0.01, 1000.0);
  map.Finish();
}

}  // namespace

std::vector<std::string> ReadOverrides(bridge::YamlMap& map, const std::string& key) {
  std::vector<std::string> overrides;
  if (const YAML::Node set = map.Raw(key)) {
    if (!set.IsSequence()) map.Fail(key, "expected a list of KEY=VALUE strings");
    for (const YAML::Node& entry : set) {
      if (!entry.IsScalar() || entry.Scalar().find('=') == std::string::npos) {
        map.Fail(key, "expected KEY=VALUE strings, got '" + YAML::Dump(entry) + "'");
      }
      overrides.push_back(entry.Scalar());
    }
  }
  return overrides;
}

DockingTaskConfig ReadDockingTask(const std::string& file, const std::vector<std::string>& overrides) {
  YAML::Node root = bridge::LoadYamlFile(file);
  for (const std::string& assignment : overrides) bridge::ApplyOverride(root, assignment, file);
  DockingTaskConfig config;
  config.file = file;
  YamlMap map(root, file);
  config.scenario = bridge::ReadFilePath(map, "scenario", file);
  config.scenario_overrides = ReadOverrides(map, "scenario_set");
  map.Optional("vehicle_a", &config.vehicle_a);
  map.Optional("vehicle_b", &config.vehicle_b);
  map.Optional("latch", &config.latch);
  map.OptionalInRange("control_rate_hz", &config.control_rate_hz, 1.0, 10000.0);
  map.OptionalInRange("max_acceleration_mps2", &config.max_acceleration_mps2, 0.01,
                      50.0);  // actions divide by it
  map.OptionalInRange("max_angular_acceleration_radps2", &config.max_angular_acceleration_radps2, 0.0, 500.0);
  ReadReset(map.Map("reset"), &config.reset);
  ReadNoise(map.Map("observation_noise"), &config.noise);
  ReadReward(map.Map("reward"), &config.reward);
  ReadGuide(map.Map("guiding_region"), &config.guide);
  ReadTermination(map.Map("termination"), &config.termination);
  map.Finish();
  return config;
}

}  // namespace iapsim::rl
