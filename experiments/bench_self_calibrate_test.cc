// The calibration from the screen end to end on realistic synthetic photos: the acceptance check's set-up (8
// quarter-scale photos of the default pattern on the 49" 1000R monitor from x in {-375, -125, 125, 375}, y in
// {-100, 100}, z 450 mm, through the default scene's realistic imaging chain), one seed. What this proves: that
// detection, the joint fit and the lens comparison work together on photos like the check's, and that for this seed
// the lens is within 0.3 px (median over the imager, at 1.5 m) and the true radius within 2 sigma. What it does
// not: the coverage over seeds (that is `bench calibrate --from-screen`). The check's 8 photos fail the precision
// check (median projection sigma 0.140 px over the covered cells, limit 0.123 px, seed 1), so the trial adds the 4
// suggested photos (recorded as test properties).
#include <gtest/gtest.h>

#include "core/screen_geometry.h"
#include "experiments/bench_self_calibrate.h"
#include "experiments/scene_lookup.h"
#include "synth/scene.h"

namespace curvecheck::experiments {
namespace {

TEST(SelfCalibrationTrialTest, EightRealisticQuarterScalePhotos) {
  SyntheticScene scene = FindScene("default", "test");
  scene.camera = ScaledCamera(scene.camera, 0.25);
  Renderer renderer;
  const Eigen::Vector3d viewpoint(0, 0, 500);
  const TrialDisplay display = RenderTrialDisplay(renderer, scene.monitor, viewpoint, PatternSpec{});
  const PatternFile pattern = ParsePatternJson(display.PatternJson().dump(), "test pattern");
  std::vector<Eigen::Vector3d> positions;
  for (int i = 0; i < 8; ++i) positions.emplace_back((i % 4) * 250 - 375, (i / 4) * 200 - 100, 450);
  const SelfCalibrationTrial t =
      RunSelfCalibrationTrial(scene, display, pattern, positions, 0.0, 1, 0.9 * scene.camera.intrinsics[0]);
  ASSERT_TRUE(t.error.empty()) << t.error;
  // The first calibration's precision check (its median projection sigma where the screen was seen), reported.
  RecordProperty("first_precise", t.first_precise ? 1 : 0);
  RecordProperty("first_sigma_px", std::to_string(t.first_sigma_px));
  RecordProperty("photos", t.photos);
  EXPECT_LT(t.lens_median_px, 0.3) << t.lensmodel;
  EXPECT_LE(std::abs(t.radius_mm - 1000), 2 * t.radius_sigma_mm) << t.radius_mm << " +- " << t.radius_sigma_mm;
  EXPECT_GT(t.radius_sigma_mm, 0);
}

}  // namespace
}  // namespace curvecheck::experiments
