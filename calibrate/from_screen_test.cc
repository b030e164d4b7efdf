// The calibration from the screen (from_screen.h) on analytic observations: the true camera (the default 24 MP
// OPENCV8 lens at quarter scale) projects the nominal 1000R monitor's points from the positions of the acceptance
// check, plus seeded Gaussian detection noise of 0.03 px per coordinate (what the realistic chain's photos of that
// set-up fit to). What this proves: the joint fit recovers the lens (within 0.3 px over the imager at 1.5 m, the
// rotation fitted as mrcal's projection_diff does) and the radius (within 2 sigma) from a seed 10% off, and too few
// or too similar photos are refused with what to add. What it does not: that the lens is as good at higher noise
// (this seed at 0.05 px: 0.43 px; at 0.1 px: 0.85 px at the imager's median point: the distortion is extrapolated
// beyond the screen's band, so the error there grows with the noise), or detection on realistic photos
// (experiments/bench_self_calibrate_test.cc and `bench calibrate --from-screen`).
#include "calibrate/from_screen.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "datasets/monitor_presets.h"
#include "synth/scene.h"

namespace curvecheck {
namespace {

CameraModel QuarterTruth() {
  return ScaledCamera(ReadCameraModel(std::filesystem::path(std::getenv("CURVECHECK_SOURCE_DIR")) /
                                      "datasets/cameras/default-24mp-opencv8.cameramodel"),
                      0.25);
}

// One photo per position (screen frame, looking at the screen centre): a 15 x 4 grid of display points (the
// default checkerboard's inner corners) projected by `camera`, plus N(0, noise_px) per coordinate.
std::vector<PhotoObservations> Observe(const Monitor& m, const CameraModel& camera,
                                       const std::vector<Eigen::Vector3d>& positions, double noise_px, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, noise_px);
  std::vector<PhotoObservations> out;
  for (size_t p = 0; p < positions.size(); ++p) {
    const Pose cam_from_screen =
        ScreenFromCamLookAt(positions[p], ScreenCentreInScreen(m), Eigen::Vector3d::UnitY()).Inverse();
    PhotoObservations o;
    o.photo = "photo" + std::to_string(p);
    for (int j = 0; j < 4; ++j) {
      for (int i = 0; i < 15; ++i) {
        const Eigen::Vector2d display((i + 1) * m.width_px / 16.0 - 0.5, (j + 1) * m.height_px / 5.0 - 0.5);
        const Eigen::Vector3d x = cam_from_screen * SurfacePointFromUv(m, UvFromDisplayPx(m, display));
        o.ids.push_back("c" + std::to_string(j * 15 + i));
        o.display_px.push_back(display);
        o.detected_px.push_back(ProjectPoint(camera, x) + Eigen::Vector2d(noise(rng), noise(rng)));
      }
    }
    out.push_back(std::move(o));
  }
  return out;
}

std::vector<Eigen::Vector3d> CheckPositions() {
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < 8; ++i) p.emplace_back((i % 4) * 250 - 375, (i / 4) * 200 - 100, 450);
  return p;
}

TEST(FromScreenTest, RecoversTheLensAndTheRadiusFromEightViews) {
  const Monitor m = LoadMonitor("49in-5120x1440-1000r");
  const CameraModel truth = QuarterTruth();
  const std::vector<PhotoObservations> obs = Observe(m, truth, CheckPositions(), 0.03, 3);
  FromScreenOptions o;
  o.focal_px = 1.1 * truth.intrinsics[0];
  const FromScreenResult r = CalibrateFromScreen(obs, m, truth.width, truth.height, o);
  const double lens = Median(LensDifferencePx(truth, r.model, 30, 20, 1500));
  EXPECT_LT(lens, 0.3) << FromScreenSummary(r);
  ASSERT_TRUE(r.radius_mm && r.radius_sigma_mm);
  EXPECT_LE(std::abs(*r.radius_mm - 1000), 2 * *r.radius_sigma_mm) << FromScreenSummary(r);
  EXPECT_LT(*r.radius_sigma_mm, 50);
  EXPECT_NEAR(r.model.intrinsics[0], truth.intrinsics[0], 0.02 * truth.intrinsics[0]);
  // The observability figures are there and say that the coupling is broken.
  EXPECT_EQ(r.observability.focal_distance_correlation.size(), 8u);
  EXPECT_LT(r.observability.max_abs_focal_distance_correlation, o.max_focal_distance_correlation);
  EXPECT_GT(r.observability.view_spread_deg, 20);
  const nlohmann::json j = FromScreenJson(r);
  EXPECT_EQ(j["screen"]["radius_mm"].get<double>(), *r.radius_mm);
  EXPECT_EQ(j["lensmodel"], r.model.lensmodel);
}

TEST(FromScreenTest, RefusesTooFewPhotos) {
  const Monitor m = LoadMonitor("49in-5120x1440-1000r");
  const CameraModel truth = QuarterTruth();
  std::vector<Eigen::Vector3d> p = CheckPositions();
  p.resize(3);
  FromScreenOptions o;
  o.focal_px = truth.intrinsics[0];
  try {
    CalibrateFromScreen(Observe(m, truth, p, 0.1, 1), m, truth.width, truth.height, o);
    FAIL() << "3 photos were accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.problem(), testing::HasSubstr("3 photo(s)"));
    EXPECT_THAT(e.fix(), testing::HasSubstr("add 3 or more photos"));
  }
}

TEST(FromScreenTest, RefusesPhotosFromOnePlace) {
  const Monitor m = LoadMonitor("49in-5120x1440-1000r");
  const CameraModel truth = QuarterTruth();
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < 8; ++i) p.emplace_back(20 * (i % 4) - 30, 20 * (i / 4) - 10, 500 + 10 * i);
  FromScreenOptions o;
  o.focal_px = truth.intrinsics[0];
  try {
    CalibrateFromScreen(Observe(m, truth, p, 0.1, 2), m, truth.width, truth.height, o);
    FAIL() << "8 photos from one place were accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.problem(), testing::HasSubstr("too similar"));
    EXPECT_THAT(e.fix(), testing::HasSubstr("from the sides"));
  }
}

TEST(FromScreenTest, LensDifferenceIsZeroForTheSameLensAndSeesAFocalError) {
  const CameraModel truth = QuarterTruth();
  for (double d : LensDifferencePx(truth, truth, 30, 20, 1500)) EXPECT_LT(d, 1e-6);
  CameraModel longer = truth;
  longer.intrinsics[0] *= 1.01;
  longer.intrinsics[1] *= 1.01;
  // 1% of focal length: 1% of the distance from the centre, 0 at the centre to ~9 px in the corners.
  const std::vector<double> d = LensDifferencePx(truth, longer, 30, 20, 1500);
  EXPECT_GT(Median(d), 2);
  EXPECT_LT(Median(d), 8);
}

TEST(FromScreenTest, FocalSeedFromExif) {
  const nlohmann::json exif = {{"focal_length_35mm", 43}};
  // 43 mm on a 36 x 24 frame's 43.27 mm diagonal: about the image diagonal in px.
  EXPECT_NEAR(*FocalSeedFromExif(exif, 1500, 1000), 43 * std::hypot(1500, 1000) / std::hypot(36, 24), 1e-9);
  EXPECT_FALSE(FocalSeedFromExif(nlohmann::json::object(), 1500, 1000));
}

}  // namespace
}  // namespace curvecheck
