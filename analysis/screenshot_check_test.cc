// CheckScreenshot on curvecheck's own renders (lavapipe), where the truth is known two ways: pattern.json's exact
// display positions, and the renderer's own mapping error (render/mapping_error.h, no detector). The figures of the
// check must agree with the renderer's at the features; an exact render must read as exact; captures that are not
// the display pixel for pixel must be refused.
#include "analysis/screenshot_check.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <opencv2/imgproc.hpp>

#include "core/correction.h"
#include "core/monitor.h"
#include "pattern/pattern_json.h"
#include "render/mapping_error.h"
#include "render/renderer.h"

namespace curvecheck {
namespace {

// The default monitor and a viewpoint 1.5 m in front of its centre (as `render --viewpoint 0,0,500`).
const Monitor& Monitor49() {
  static const Monitor m = MonitorFromDiagonal("49in 5120x1440 1000R", 5120, 1440, 49, 1000);
  return m;
}
const Eigen::Vector3d kViewpoint(0, 0, 500);

struct Rendered {
  cv::Mat image;
  PatternFile pattern;
  MappingError mapping;
};

Renderer& SharedRenderer() {
  static Renderer r;
  return r;
}

Rendered RenderMethod(const MethodOptions& method, bool with_mapping_error, const PatternSpec& spec = {}) {
  const Monitor& m = Monitor49();
  const Pattern pattern = BuildPattern(spec, m, kViewpoint, TangentPlaneAtCentre(m));
  RenderOptions o;
  o.method = method;
  Rendered r;
  const GrayImage img = SharedRenderer().Render(m, kViewpoint, pattern, o);
  r.image = cv::Mat(img.height, img.width, CV_8UC1, const_cast<uint8_t*>(img.pixels.data())).clone();
  r.pattern = ParsePatternJson(PatternToJson(pattern, m, kViewpoint, method.ToJson()).dump(), "pattern.json");
  if (with_mapping_error) {
    r.mapping = MeasureMappingError(m, kViewpoint, pattern, SharedRenderer().RenderCoordinates(m, kViewpoint, pattern, o));
  }
  return r;
}

// The renderer's mapping error at a display position: bilinear between the four pixel centres around it.
double MappingErrorAt(const MappingError& e, const Eigen::Vector2d& px) {
  const int w = Monitor49().width_px;
  const int x0 = static_cast<int>(std::floor(px.x())), y0 = static_cast<int>(std::floor(px.y()));
  const double fx = px.x() - x0, fy = px.y() - y0;
  auto at = [&](int x, int y) { return static_cast<double>(e.map_px[static_cast<size_t>(y) * w + x]); };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) + fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

TEST(ScreenshotCheck, ExactRenderReadsBelowTwoHundredthsOfAPixel) {
  const Rendered r = RenderMethod(MethodOptions{}, false);
  const ScreenshotCheck c = CheckScreenshot(r.image, r.pattern, {});
  ASSERT_EQ(c.refusal, ScreenshotRefusal::kNone) << c.reason;
  ASSERT_EQ(c.features.size(), 60u);
  for (const ScreenshotFeature& f : c.features) EXPECT_EQ(f.refinement, "edge-areas") << f.id;
  std::cout << "exact: max " << c.max_px << " rms " << c.rms_px << " px, U " << c.expanded_uncertainty_px << "\n";
  EXPECT_LT(c.max_px, 0.02);
  EXPECT_LT(c.max_px, 0.005);  // measured 0.0024 px: the edge areas are exact for a box-filtered image
  EXPECT_EQ(c.verdict, "pass");
  // The decision rule: a tolerance below the measured error plus U cannot pass.
  ScreenshotCheckOptions tight;
  tight.tolerance_px = c.max_px;
  EXPECT_EQ(CheckScreenshot(r.image, r.pattern, tight).verdict, "inconclusive");
}

// The check's figures against the renderer's own mapping error at the same features: within 10% of max and rms, or
// within the detector's own bound (0.0025 px, the exact render's max) where 10% is below it (strips 128: 0.0004 px).
// Measured (max, rms px; check vs renderer at the features): strips 8 1.6249/0.8647 vs 1.6215/0.8651; strips 32
// 0.1000/0.0473 vs 0.0992/0.0474; strips 128 0.0057/0.0026 vs 0.0042/0.0022; warp grid 16x5 1.532/0.684 vs
// 1.553/0.691; warp grid 64x18 0.0583/0.0341 vs 0.0493/0.0235. The last is the one that misses 10%, and not by the
// detector: the renderer's figure is the geometric mapping of its coordinate pass, while the displayed image is the
// first pass's anti-aliased shading resampled by the Catmull-Rom warp, which moves edges by a few hundredths of a
// pixel more; an independent measurement (cv2.cornerSubPix, 11 px window, on the linear image blurred by 3 px)
// reads 0.0665/0.0369 px on that render. There the check is held to 0.012 px of the renderer instead.
TEST(ScreenshotCheck, AgreesWithTheRenderersMappingErrorForStripsAndWarpGrids) {
  struct Case {
    const char* name;
    MethodOptions method;
    double absolute_px = 0.0025;
  };
  std::vector<Case> cases;
  for (int strips : {8, 32, 128}) {
    MethodOptions m;
    m.method = Method::kStrips;
    m.strips = strips;
    cases.push_back({"strips", m});
  }
  for (auto [cols, rows] : {std::pair(16, 5), std::pair(64, 18)}) {
    MethodOptions m;
    m.method = Method::kWarp;
    m.warp_grid_cols = cols;
    m.warp_grid_rows = rows;
    cases.push_back({"warp grid", m, cols == 64 ? 0.012 : 0.0025});
  }
  for (const Case& k : cases) {
    const Rendered r = RenderMethod(k.method, true);
    const ScreenshotCheck c = CheckScreenshot(r.image, r.pattern, {});
    ASSERT_EQ(c.refusal, ScreenshotRefusal::kNone) << c.reason;
    double max_render = 0, sum2 = 0, worst_diff = 0;
    for (const ScreenshotFeature& f : c.features) {
      const double e_render = MappingErrorAt(r.mapping, f.exact_px);
      max_render = std::max(max_render, e_render);
      sum2 += e_render * e_render;
      worst_diff = std::max(worst_diff, std::abs(f.Error().norm() - e_render));
    }
    const double rms_render = std::sqrt(sum2 / static_cast<double>(c.features.size()));
    std::cout << k.method.Label() << ": check max " << c.max_px << " rms " << c.rms_px << " | render at features max "
              << max_render << " rms " << rms_render << " | render --accuracy max " << r.mapping.max_px << " rms "
              << r.mapping.rms_px << " | worst per-feature difference " << worst_diff << " px\n";
    EXPECT_NEAR(c.max_px, max_render, std::max(0.10 * max_render, k.absolute_px)) << k.method.Label();
    EXPECT_NEAR(c.rms_px, rms_render, std::max(0.10 * rms_render, k.absolute_px)) << k.method.Label();
  }
}

TEST(ScreenshotCheck, NoneIsMeasuredNotRefused) {
  MethodOptions none;
  none.method = Method::kNone;
  const Rendered r = RenderMethod(none, true);
  const ScreenshotCheck c = CheckScreenshot(r.image, r.pattern, {});
  ASSERT_EQ(c.refusal, ScreenshotRefusal::kNone) << c.reason;
  EXPECT_EQ(c.features.size(), 60u);
  EXPECT_GT(c.max_px, 20);
  EXPECT_EQ(c.verdict, "fail");
  // Matched by the board's indexing, not by proximity: every feature agrees with the renderer at that feature, to
  // the renderer's linearization (its error is the plane error at the exact pixel through the local Jacobian, which
  // at 50 px differs from the feature's displacement by up to 9%: measured 56.25 vs 51.37 px at c45).
  double max_render = 0, sum2 = 0;
  for (const ScreenshotFeature& f : c.features) {
    const double e_render = MappingErrorAt(r.mapping, f.exact_px);
    EXPECT_NEAR(f.Error().norm(), e_render, 0.12 * f.Error().norm() + 0.01) << f.id;
    max_render = std::max(max_render, e_render), sum2 += e_render * e_render;
  }
  std::cout << "none: renderer at the features max " << max_render << " rms "
            << std::sqrt(sum2 / static_cast<double>(c.features.size())) << " px\n";
  std::cout << "none: max " << c.max_px << " rms " << c.rms_px << ", similarity scale " << c.similarity.scale
            << " residual " << c.similarity.residual_rms_px << " of " << c.similarity.raw_rms_px << " px\n";
}

// Tags and both on exact renders, and a partial view with tags (the left half of the display grey): every tag corner
// measured by edge areas, below 0.02 px (measured 0.0085 px tags, 0.0088 px both). The detector's own tag corners
// are 0.21 px per axis inside the tag on these captures.
TEST(ScreenshotCheck, TagsBothAndAPartialViewOfTags) {
  for (PatternKind kind : {PatternKind::kAprilTag, PatternKind::kBoth}) {
    PatternSpec spec;
    spec.kind = kind;
    Rendered r = RenderMethod(MethodOptions{}, false, spec);
    const ScreenshotCheck c = CheckScreenshot(r.image, r.pattern, {});
    ASSERT_EQ(c.refusal, ScreenshotRefusal::kNone) << c.reason;
    EXPECT_EQ(static_cast<int>(c.features.size()), c.pattern_features);
    for (const ScreenshotFeature& f : c.features) EXPECT_EQ(f.refinement, "edge-areas") << f.id;
    std::cout << PatternKindName(kind) << ": " << c.features.size() << " features, max " << c.max_px << " rms "
              << c.rms_px << " px\n";
    EXPECT_LT(c.max_px, 0.02);
    if (kind == PatternKind::kAprilTag) {
      r.image(cv::Rect(0, 0, 2560, 1440)).setTo(128);
      const ScreenshotCheck half = CheckScreenshot(r.image, r.pattern, {});
      ASSERT_EQ(half.refusal, ScreenshotRefusal::kNone) << half.reason;
      EXPECT_GT(half.features.size(), 40u);
      EXPECT_LT(half.features.size(), c.features.size() * 6 / 10);
      EXPECT_LT(half.max_px, 0.02);
    }
  }
}

TEST(ScreenshotCheck, RefusesCroppedScaledLetterboxedAndShiftedCaptures) {
  const Rendered r = RenderMethod(MethodOptions{}, false);
  // A crop (a window's client area) and a downscaled screenshot: the size is not the display's.
  const ScreenshotCheck crop = CheckScreenshot(r.image(cv::Rect(0, 30, 5120, 1380)).clone(), r.pattern, {});
  EXPECT_EQ(crop.refusal, ScreenshotRefusal::kWrongSize);
  EXPECT_NE(crop.reason.find("5120 x 1380"), std::string::npos) << crop.reason;
  cv::Mat half;
  cv::resize(r.image, half, {}, 0.5, 0.5, cv::INTER_AREA);
  const ScreenshotCheck scaled = CheckScreenshot(half, r.pattern, {});
  EXPECT_EQ(scaled.refusal, ScreenshotRefusal::kWrongSize);
  EXPECT_NE(scaled.reason.find("scaled by 0.5"), std::string::npos) << scaled.reason;
  // A letterbox: the content scaled by 0.95 into a capture of the right size, grey bars around.
  cv::Mat small, letterbox(r.image.size(), CV_8UC1, cv::Scalar(0));
  cv::resize(r.image, small, {}, 0.95, 0.95, cv::INTER_AREA);
  small.copyTo(letterbox(cv::Rect((5120 - small.cols) / 2, (1440 - small.rows) / 2, small.cols, small.rows)));
  const ScreenshotCheck boxed = CheckScreenshot(letterbox, r.pattern, {});
  EXPECT_EQ(boxed.refusal, ScreenshotRefusal::kScaled) << boxed.reason;
  EXPECT_NEAR(boxed.similarity.scale, 0.95, 0.002);
  // Shifted by a title bar: 24 px down, the top rows lost, grey below.
  cv::Mat shifted(r.image.size(), CV_8UC1, cv::Scalar(128));
  r.image(cv::Rect(0, 0, 5120, 1440 - 24)).copyTo(shifted(cv::Rect(0, 24, 5120, 1440 - 24)));
  const ScreenshotCheck moved = CheckScreenshot(shifted, r.pattern, {});
  EXPECT_EQ(moved.refusal, ScreenshotRefusal::kShifted) << moved.reason;
  EXPECT_NEAR(moved.similarity.offset_at_centre_px.y(), 24, 0.05);
}

}  // namespace
}  // namespace curvecheck
