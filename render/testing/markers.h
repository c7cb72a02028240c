#pragma once
// For render tests: a bright marker on black, and where it appears.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

#include "render/image.h"
#include "render/scene.h"

namespace iapsim::render::testing {

/// Black sky, no light: an unlit white disc of `radius_m` (a flat cylinder, its axis along z_O) at X_BO on
/// `body` (empty: fixed in W, X_BO = X_WO) is the only thing drawn. A disc facing the camera images as a
/// circle centred on its centre's projection (a sphere's outline would be an ellipse pushed outward).
inline Scene DiscMarkerScene(const Eigen::Isometry3d& X_BO, double radius_m, const std::string& body = "") {
  Scene scene;
  scene.sky_color.setZero();
  scene.sun.shadows = false;
  Material white;
  white.color.setOnes();
  white.unlit = true;
  SceneObject marker;
  marker.name = "marker";
  marker.body = body;
  marker.mesh = scene.AddMesh(MakeCylinder(radius_m, 1e-4, scene.AddMaterial(white), 64));
  marker.X_BO = X_BO;
  scene.AddObject(marker);
  return scene;
}

/// Intensity-weighted centroid of the image's red channel, pixel-centre convention.
inline Eigen::Vector2d Centroid(const Image& image) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const double w = image.Pixel(u, v)[0];
      sum += w * Eigen::Vector2d(u, v);
      total += w;
    }
  }
  EXPECT_GT(total, 0.0) << "the marker is not in the image";
  return sum / total;
}

}  // namespace iapsim::render::testing
