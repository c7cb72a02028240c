// A small scene from YAML (tests/render/golden/small_scene.yaml) against its stored image. llvmpipe versions
// differ by a level here and there, so the comparison has a tolerance; a changed look on purpose is stored
// with tools/regenerate_render_golden.sh (IAPSIM_REGENERATE_GOLDEN=1).

#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <string>

#include "render/renderer.h"
#include "render/scene_config.h"

namespace iapsim::render {
namespace {

const std::string kGoldenDir = std::string(IAPSIM_SOURCE_DIR) + "/tests/render/golden/";

TEST(Golden, SmallSceneMatchesItsStoredImage) {
  const Scene scene = LoadScene(kGoldenDir + "small_scene.yaml");
  std::unique_ptr<Renderer> renderer = MakeRenderer();
  renderer->SetScene(scene);
  Camera camera;
  camera.intrinsics = CameraIntrinsics::FromHorizontalFov(160, 120, 70.0 * M_PI / 180.0);
  // 1.6 m up, 3 m behind the origin, looking north and 15° down
  const Eigen::Matrix3d R_WF =
      Eigen::AngleAxisd(-15.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() = R_WF * OpticalToForwardRightDown();
  X_WC.translation() = Eigen::Vector3d(-3.0, 0.0, -1.6);
  Image image;
  renderer->Render(camera, X_WC, &image, nullptr);

  const std::string golden_path = kGoldenDir + "small_scene.png";
  const char* regenerate = std::getenv("IAPSIM_REGENERATE_GOLDEN");
  if (regenerate && std::string(regenerate) == "1") {
    WritePng(image, golden_path);
    std::cout << "wrote " << golden_path << "\n";
    return;
  }
  const Image golden = ReadImageFile(golden_path);
  ASSERT_EQ(golden.width, image.width);
  ASSERT_EQ(golden.height, image.height);
  double sum_abs = 0.0;
  int far_off = 0;
  for (std::size_t i = 0; i < image.rgb.size(); ++i) {
    const int d = std::abs(int(image.rgb[i]) - int(golden.rgb[i]));
    sum_abs += d;
    far_off += d > 16;
  }
  const double mean_abs = sum_abs / image.rgb.size();
  EXPECT_LT(mean_abs, 1.0) << "mean difference per channel, levels";
  EXPECT_LT(far_off, static_cast<int>(image.rgb.size() / 100)) << "channels more than 16 levels off";
  if (HasFailure()) {
    const std::string actual = ::testing::TempDir() + "small_scene.actual.png";
    WritePng(image, actual);
    std::cout << "this render: " << actual << "\n";
  }
}

}  // namespace
}  // namespace iapsim::render
