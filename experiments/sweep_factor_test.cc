// Each sweep factor's apply function on the embedded default scene: it changes what its meaning says and
// nothing of the camera placement it does not own; the camera stays at its distance from the screen centre
// under yaw and pitch; ParseFactor takes names and aliases and refuses what is out of range. Does not prove
// that a changed scene photographs as intended (synth/ tests that).
#include "experiments/sweep_factor.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "core/error.h"
#include "core/screen_geometry.h"
#include "experiments/scene_lookup.h"

namespace curvecheck::experiments {
namespace {

using ::testing::HasSubstr;

class SweepFactorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { base_ = new SyntheticScene(LoadEmbeddedScene("default", "test")); }
  static void TearDownTestSuite() { delete base_; }

  // The point with one factor at `value` (a 32 x 9 board).
  static SweepPoint At(const std::string& factor, double value) {
    PatternSpec spec;
    spec.cols = 32;
    spec.rows = 9;
    SweepFactor f = ParseFactor(factor + "=" + std::to_string(value));
    return MakeSweepPoint(*base_, spec, {f}, {value});
  }
  static SyntheticScene* base_;
};

SyntheticScene* SweepFactorTest::base_ = nullptr;

TEST_F(SweepFactorTest, EveryFactorHasAnApplyFunctionAndAUniqueName) {
  std::set<std::string> names;
  for (const FactorInfo& f : SweepFactors()) {
    EXPECT_NE(f.apply, nullptr) << f.name;
    EXPECT_TRUE(names.insert(f.name).second) << f.name;
    EXPECT_TRUE(names.insert(f.alias).second || std::string(f.alias) == f.name) << f.alias;
    EXPECT_LT(f.lo, f.hi) << f.name;
  }
  EXPECT_EQ(SweepFactors().size(), 11u);
}

TEST_F(SweepFactorTest, GeometryFactorsMoveTheCameraAroundTheCentre) {
  const Eigen::Vector3d centre = ScreenCentreInScreen(base_->monitor);
  const double distance = (base_->screen_from_cam.translation - centre).norm();
  const SweepPoint yaw = At("yaw", 30);
  EXPECT_NEAR((yaw.scene.screen_from_cam.translation - centre).norm(), distance, 1e-9);
  EXPECT_GT(yaw.scene.screen_from_cam.translation.x(), 100);  // to the right
  EXPECT_TRUE(yaw.viewpoint_in_screen.isApprox(yaw.scene.screen_from_cam.translation));
  // Looking at the centre: camera z points at it.
  const Eigen::Vector3d z = yaw.scene.screen_from_cam.RotationMatrix().col(2);
  EXPECT_TRUE(z.isApprox((centre - yaw.scene.screen_from_cam.translation).normalized(), 1e-9));
  const SweepPoint pitch = At("pitch_deg", 20);
  EXPECT_NEAR((pitch.scene.screen_from_cam.translation - centre).norm(), distance, 1e-9);
  EXPECT_GT(pitch.scene.screen_from_cam.translation.y(), 100);  // up
  const SweepPoint far = At("distance", 2000);
  EXPECT_NEAR((far.scene.screen_from_cam.translation - centre).norm(), 2000, 1e-9);
  // The viewpoint offset moves the camera, not the viewpoint the pattern is rendered for.
  const SweepPoint offset = At("viewpoint_offset_mm", 300);
  EXPECT_TRUE(offset.viewpoint_in_screen.isApprox(base_->screen_from_cam.translation));
  EXPECT_NEAR(offset.scene.screen_from_cam.translation.x() - offset.viewpoint_in_screen.x(), 300, 1e-9);
}

TEST_F(SweepFactorTest, SceneFactorsChangeTheirFieldOnly) {
  const SweepPoint defocus = At("defocus", 2);
  EXPECT_EQ(defocus.scene.optics.blur, Blur::kGaussian);
  EXPECT_EQ(defocus.scene.optics.blur_px, 2);
  EXPECT_EQ(At("defocus", 0).scene.optics.blur, Blur::kNone);
  EXPECT_TRUE(defocus.scene.screen_from_cam.translation.isApprox(base_->screen_from_cam.translation));
  EXPECT_FALSE(At("noise", 0).scene.sensor.noise);
  const SweepPoint noisy = At("noise_x", 2);
  EXPECT_DOUBLE_EQ(noisy.scene.sensor.full_well_e, base_->sensor.full_well_e / 4);
  EXPECT_DOUBLE_EQ(noisy.scene.sensor.read_noise_e, base_->sensor.read_noise_e / 2);
  EXPECT_EQ(At("exposure", 0.5).scene.optics.exposure, 0.5);
  EXPECT_EQ(At("fill", 0.5).scene.display.fill_factor, 0.5);
  EXPECT_DOUBLE_EQ(At("radius_ratio", 2).scene.truth.curvature_per_mm, base_->monitor.curvature_per_mm / 2);
  EXPECT_DOUBLE_EQ(At("coverage", 0.6).spec.margin, 0.2);
  const SweepPoint square = At("square_px", 100);
  EXPECT_DOUBLE_EQ(square.spec.square_mm, 100 * base_->monitor.pixel_pitch_mm());
  EXPECT_EQ(square.spec.cols, static_cast<int>(0.9 * base_->monitor.width_px / 100));
  EXPECT_EQ(square.spec.rows, static_cast<int>(0.9 * base_->monitor.height_px / 100));
}

TEST_F(SweepFactorTest, ParseFactorReadsGridsAndRefusesBadText) {
  const SweepFactor f = ParseFactor("yaw=0:40:5");
  EXPECT_EQ(f.name, "yaw_deg");
  EXPECT_EQ(f.count, 5);
  EXPECT_EQ(f.Value(4), 40);
  EXPECT_EQ(f.Value(1), 10);
  try {
    ParseFactor("tilt=0:1:2");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("'tilt' is not a sweep factor"));
  }
  EXPECT_THROW(ParseFactor("yaw=0:90:3"), Error);  // outside -85..85
  EXPECT_THROW(ParseFactor("yaw=0:10:0"), Error);
  EXPECT_THROW(ParseFactor("yaw"), Error);
}

}  // namespace
}  // namespace curvecheck::experiments
