// truth.json alone: the true geometry and the camera come back as the scene holds them, and each feature's point
// and image position are the true surface point and its projection.
#include "synth/truth_json.h"

#include <gtest/gtest.h>

#include "core/screen_geometry.h"
#include "pattern/pattern.h"

namespace curvecheck {
namespace {

TEST(TruthJson, CarriesTheSceneAndProjectsTheTrueSurface) {
  SyntheticScene s;
  s.monitor = MonitorFromDiagonal("49 test", 5120, 1440, 49, 1000);
  s.truth.curvature_per_mm = 1 / 1080.0;
  s.truth.lean_deg = 1.5;
  s.truth.bumps = {{0.2, -0.3, 0.1, 0.2, 2.0}};
  s.camera = PinholeModel(3000, 2000, 2000);
  s.camera_model_path = "pinhole.cameramodel";
  s.screen_from_cam.translation = {100, 50, 600};
  s.screen_from_cam = ScreenFromCamLookAt(s.screen_from_cam.translation, {0, 0, -1000}, Eigen::Vector3d::UnitY());
  Feature on_screen;
  on_screen.id = "c0";
  on_screen.visible = true;
  on_screen.display_px = Eigen::Vector2d(3000.25, 500.5);
  Feature missed;  // no display position: the ray missed the surface
  missed.id = "c1";

  const nlohmann::json j = TruthJson(s, {on_screen, missed});
  EXPECT_EQ(j["format"], "curvecheck.truth/1");
  EXPECT_DOUBLE_EQ(j["true_monitor"]["radius_mm"].get<double>(), 1080.0);
  EXPECT_EQ(j["true_monitor"]["lean_deg"].get<double>(), 1.5);
  EXPECT_EQ(j["true_monitor"]["bumps"][0]["height_mm"].get<double>(), 2.0);
  EXPECT_EQ(j["camera"]["model"], "pinhole.cameramodel");
  EXPECT_EQ(j["camera"]["position_mm"][2].get<double>(), 600.0);
  EXPECT_EQ(j["camera"]["screen_from_cam"][1][2].get<double>(), s.screen_from_cam.RotationMatrix()(1, 2));

  const Eigen::Vector3d p = TrueSurfacePointInScreen(s, UvFromDisplayPx(s.monitor, *on_screen.display_px));
  const Eigen::Vector3d p_in_cam = s.screen_from_cam.Inverse() * p;
  const Eigen::Vector2d q = ProjectPoint(s.camera, p_in_cam);
  const nlohmann::json& f = j["features"][0];
  EXPECT_EQ(f["point_mm"][0].get<double>(), p.x());
  EXPECT_EQ(f["point_mm"][2].get<double>(), p.z());
  EXPECT_EQ(f["image_px"][0].get<double>(), q.x());
  EXPECT_EQ(f["image_px"][1].get<double>(), q.y());
  EXPECT_TRUE(f["visible"].get<bool>());
  EXPECT_FALSE(j["features"][1].contains("image_px"));
  EXPECT_FALSE(j["features"][1]["visible"].get<bool>());

  s.truth.curvature_per_mm = 0;
  EXPECT_EQ(TruthJson(s, {})["true_monitor"]["radius_mm"], "flat");
}

}  // namespace
}  // namespace curvecheck
