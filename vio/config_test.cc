#include "vio/config.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace iapsim::vio {
namespace {

std::string ErrorOf(const std::string& path, const std::vector<std::string>& overrides) {
  try {
    LoadVioConfig(path, overrides);
  } catch (const bridge::ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(VioConfigTest, NoFileGivesTheDefaultsOfTableIX) {
  const VioConfig config = LoadVioConfig("", {});
  EXPECT_EQ(config.estimator.window_keyframes, EstimatorOptions{}.window_keyframes);
  EXPECT_EQ(config.tracker.max_features, TrackerOptions{}.max_features);
  EXPECT_FALSE(config.range_sigma_m.has_value());
  EXPECT_FALSE(config.anchors.has_value());  // every anchor of the scenario
  const PhysicalConstraintOptions& p = config.estimator.physical;
  EXPECT_DOUBLE_EQ(p.sigma_link_m, 0.04);
  EXPECT_DOUBLE_EQ(p.sigma_rate_radps, 0.1);
  EXPECT_DOUBLE_EQ(p.sigma_attitude_rad, 0.01);
  EXPECT_DOUBLE_EQ(p.attitude_correlation_s, 0.0);  // white, as the seed weights r_kq
  EXPECT_DOUBLE_EQ(p.drift_prior_position_m, 0.05);
  EXPECT_DOUBLE_EQ(p.drift_prior_yaw_rad, 0.1);
  EXPECT_DOUBLE_EQ(p.drift_step_position_m, 0.01);
  EXPECT_DOUBLE_EQ(p.drift_step_yaw_rad, 0.04);
}

TEST(VioConfigTest, AFileAndOverridesSetTheirKeys) {
  const std::string path = ::testing::TempDir() + "vio_config_test_" + std::to_string(getpid()) + ".yaml";
  std::ofstream(path) << "tracker: {max_features: 200}\nestimator:\n  window_keyframes: 8\nvirpo:\n"
                         "  sigma_attitude_rad: 0.04\n";
  const VioConfig config = LoadVioConfig(
      path, {"uwb.sigma_m=0.1", "virpo.sigma_attitude_rad=0.03", "uwb.anchors=[anchor1, anchor3]",
             "estimator.function_tolerance=1e-6", "virpo.attitude_correlation_s=1.5"});
  EXPECT_EQ(config.tracker.max_features, 200);
  EXPECT_EQ(config.estimator.window_keyframes, 8);
  EXPECT_DOUBLE_EQ(config.estimator.function_tolerance, 1e-6);  // Ceres's default, against ours of 1e-5
  EXPECT_DOUBLE_EQ(config.estimator.physical.sigma_attitude_rad, 0.03);  // the override wins
  EXPECT_DOUBLE_EQ(config.estimator.physical.attitude_correlation_s, 1.5);
  ASSERT_TRUE(config.range_sigma_m.has_value());
  EXPECT_DOUBLE_EQ(*config.range_sigma_m, 0.1);
  EXPECT_EQ(config.anchors, (std::vector<std::string>{"anchor1", "anchor3"}));
  EXPECT_EQ(LoadVioConfig("", {"uwb.anchors=[]"}).anchors, std::vector<std::string>{});  // VIO's 0 anchors
  std::remove(path.c_str());
}

TEST(VioConfigTest, BadKeysAndValuesAreClearErrors) {
  const std::string misspelt = ErrorOf("", {"virpo.sigma_lnk_m=0.1"});
  EXPECT_NE(misspelt.find("virpo.sigma_lnk_m"), std::string::npos) << misspelt;
  const std::string negative = ErrorOf("", {"virpo.sigma_link_m=-1"});
  EXPECT_NE(negative.find("virpo.sigma_link_m"), std::string::npos) << negative;
  EXPECT_NE(negative.find("must be in"), std::string::npos) << negative;
  const std::string not_a_number = ErrorOf("", {"estimator.window_keyframes=many"});
  EXPECT_NE(not_a_number.find("estimator.window_keyframes"), std::string::npos) << not_a_number;
  const std::string nan = ErrorOf("", {"virpo.sigma_attitude_rad=.nan"});
  EXPECT_NE(nan.find("virpo.sigma_attitude_rad"), std::string::npos) << nan;
  const std::string not_a_list = ErrorOf("", {"uwb.anchors=anchor1"});
  EXPECT_NE(not_a_list.find("uwb.anchors: expected a list of anchor names"), std::string::npos) << not_a_list;
  const std::string nested = ErrorOf("", {"uwb.anchors=[[anchor1]]"});
  EXPECT_NE(nested.find("uwb.anchors: expected an anchor's name"), std::string::npos) << nested;
  const std::string missing = ErrorOf("/nonexistent/vio.yaml", {});
  EXPECT_NE(missing.find("/nonexistent/vio.yaml"), std::string::npos) << missing;
}

}  // namespace
}  // namespace iapsim::vio
