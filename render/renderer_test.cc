// Renderer tests on Mesa lavapipe (no GPU needed). Each method's accuracy is measured without any detector:
// the method's own pipeline renders the plane coordinates each pixel shows, compared with the exact mapping of
// the geometry core (MeasureMappingError). Tolerances are per method and parameter.
#include "render/renderer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "core/correction.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "render/mapping_error.h"

namespace curvecheck {
namespace {

Renderer& SharedRenderer() {
  static Renderer renderer;  // device set-up once per test binary
  return renderer;
}

MappingError Measure(const Monitor& m, const Eigen::Vector3d& eye, const Pattern& p, const MethodOptions& method) {
  RenderOptions o;
  o.method = method;
  const CoordinateImage c = SharedRenderer().RenderCoordinates(m, eye, p, o);
  const MappingError e = MeasureMappingError(m, eye, p, c);
  std::cout << method.Label() << ": rms " << e.rms_px << " p99 " << e.p99_px << " max " << e.max_px << " px over "
            << e.pixels << " px\n";
  return e;
}

MethodOptions Options(Method method) {
  MethodOptions o;
  o.method = method;
  return o;
}

// The issue's reference configuration: a 34" 3440x1440 panel bent to 1000R, eye centred 600 mm from the screen.
// Reference worst placement errors (numpy): strips 8/32/128 -> 1.9/0.12/0.0075 px; a bilinear grid with
// 256/64/16 px spacing -> 3.2/0.20/0.013 px. Our warp grid interpolates linearly on two triangles per cell (the
// thesis's distortion mesh, 4.2.3), and resamples the first pass, so its figures differ a little.
class ReferenceConfiguration : public ::testing::Test {
 protected:
  void SetUp() override {
    monitor_ = MonitorFromDiagonal("34 1000R", 3440, 1440, 34, 1000);
    eye_ = ScreenCentreInScreen(monitor_) + Eigen::Vector3d(0, 0, 600);
    PatternSpec spec;
    spec.cols = 16;
    spec.rows = 6;
    spec.margin = 0.01;
    pattern_ = BuildPattern(spec, monitor_, eye_, TangentPlaneAtCentre(monitor_));
  }
  Monitor monitor_;
  Eigen::Vector3d eye_;
  Pattern pattern_;
};

TEST_F(ReferenceConfiguration, ExactIsExactToFloatPrecision) {
  const MappingError e = Measure(monitor_, eye_, pattern_, Options(Method::kExact));
  EXPECT_GT(e.pixels, 3'000'000);
  EXPECT_EQ(e.missing_pixels, 0);
  EXPECT_LT(e.max_px, 0.002);
}

TEST_F(ReferenceConfiguration, StripsMatchReferenceFigures) {
  const std::pair<int, double> reference[] = {{8, 1.9}, {32, 0.12}, {128, 0.0075}};
  for (const auto& [strips, max_px] : reference) {
    MethodOptions o = Options(Method::kStrips);
    o.strips = strips;
    const MappingError e = Measure(monitor_, eye_, pattern_, o);
    EXPECT_NEAR(e.max_px, max_px, 0.15 * max_px) << strips << " strips";
    EXPECT_EQ(e.missing_pixels, 0);
  }
}

TEST_F(ReferenceConfiguration, WarpGridConvergesQuadraticallyAndPerFragmentIsExact) {
  MethodOptions o = Options(Method::kWarp);
  const MappingError per_fragment = Measure(monitor_, eye_, pattern_, o);
  EXPECT_LT(per_fragment.max_px, 0.005);  // coordinates are smooth: cubic resampling is exact to ~1e-3 px
  const std::tuple<int, double, double> grids[] = {{256, 2.5, 4.5}, {64, 0.15, 0.40}, {16, 0.008, 0.03}};
  for (const auto& [spacing, lo, hi] : grids) {
    o.warp_grid_cols = (3440 + spacing - 1) / spacing;
    o.warp_grid_rows = (1440 + spacing - 1) / spacing;
    const MappingError e = Measure(monitor_, eye_, pattern_, o);
    EXPECT_GT(e.max_px, lo) << spacing << " px grid";
    EXPECT_LT(e.max_px, hi) << spacing << " px grid";
  }
}

TEST_F(ReferenceConfiguration, MeshUniformAndNoneBaseline) {
  MethodOptions o = Options(Method::kMesh);
  o.mesh_subdivision = MeshSubdivision::kUniform;
  o.mesh_patch_px = 256;
  o.mesh_level = 16;  // 16 px spacing
  EXPECT_LT(Measure(monitor_, eye_, pattern_, o).max_px, 0.02);
  o.mesh_level = 1;  // one quad per 256 px patch: the curvature shows
  EXPECT_GT(Measure(monitor_, eye_, pattern_, o).max_px, 0.5);
  // The uncorrected baseline on a 1000R panel is off by far more than a pixel.
  EXPECT_GT(Measure(monitor_, eye_, pattern_, Options(Method::kNone)).max_px, 50);
}

// Thesis 4.3.2, Fig 4.8: from the cylinder axis, an edge centred on the optical axis maps to an S-shaped curve
// whose midpoint is where linear interpolation puts it, so the midpoint-only heuristic (Perez) leaves it coarse;
// the extended heuristic (quarter points too) subdivides it.
TEST(MeshHeuristic, ExtendedHeuristicCatchesTheBlindSpot) {
  const Monitor m = MonitorFromDiagonal("49 500R", 2560, 720, 49, 500);
  const Eigen::Vector3d eye(0, 0, 0);
  PatternSpec spec;
  spec.cols = 9;
  spec.rows = 4;
  const Pattern p = BuildPattern(spec, m, eye, TangentPlaneAtCentre(m));
  MethodOptions o = Options(Method::kMesh);
  o.mesh_patch_px = 256;
  o.mesh_tolerance_px = 0.05;
  o.mesh_subdivision = MeshSubdivision::kPerez;
  const MappingError perez = Measure(m, eye, p, o);
  o.mesh_subdivision = MeshSubdivision::kExtended;
  const MappingError extended = Measure(m, eye, p, o);
  EXPECT_GT(perez.max_px, 0.15);
  EXPECT_LT(extended.max_px, 0.5 * perez.max_px);
}

// lavapipe drops primitives from very large tessellated draws (renderer.cc, kMaxTrianglesPerDraw); the
// renderer splits patches and batches draws so that the finest subdivisions still draw every pixel.
TEST(MeshHeuristic, FinestUniformSubdivisionDrawsEveryPixel) {
  const Monitor m = MonitorFromDiagonal("49 1000R", 2560, 720, 49, 1000);
  const Eigen::Vector3d eye(0, 0, 0);
  PatternSpec spec;
  const Pattern p = BuildPattern(spec, m, eye, TangentPlaneAtCentre(m));
  MethodOptions o = Options(Method::kMesh);
  o.mesh_subdivision = MeshSubdivision::kUniform;
  for (int level : {48, 64}) {
    o.mesh_level = level;
    const MappingError e = Measure(m, eye, p, o);
    EXPECT_EQ(e.missing_pixels, 0) << level;
    EXPECT_LT(e.max_px, 0.01) << level;
  }
}

// On a flat monitor the mesh mapping is a homography: with the depth as perspective weight the interpolation is
// exact, so even one quad per patch is right (review finding: the xz distance of Eq 4.9 was off by 2.8 px here).
TEST(MeshHeuristic, FlatMonitorIsExactWithCoarsePatches) {
  const Monitor m = MonitorFromDiagonal("27 flat", 2560, 1440, 27, 0);
  for (const Eigen::Vector3d& eye : {Eigen::Vector3d(0, 0, 600), Eigen::Vector3d(300, -100, 500)}) {
    PatternSpec spec;
    const Pattern p = BuildPattern(spec, m, eye, TangentPlaneAtCentre(m));
    const MappingError e = Measure(m, eye, p, Options(Method::kMesh));
    EXPECT_LT(e.max_px, 0.01);
  }
}

// Where methods fail (issue 3 item 7): each method renders correctly (mapping error within its tolerance) or
// refuses with an Error; which one is pinned here.
struct FailureCase {
  const char* name;
  Eigen::Vector3d eye_from_centre;
};

TEST(FailureCases, EachMethodRendersCorrectlyOrRefuses) {
  const Monitor m = MonitorFromDiagonal("49 1000R", 2560, 720, 49, 1000);  // half resolution: same geometry
  const FailureCase cases[] = {
      {"outside the cylinder", {0, 0, 2500}},      // beyond the far side of the circle (2R)
      {"above the screen", {0, 400, 700}},         // well above the top edge (H/2 = 168 mm)
      {"off axis, far to the side", {-500, -250, 900}},
      {"closer than 10 cm", {0, 0, 80}},           // inside the chord plane: field of view > 180 deg
  };
  struct Expect {
    Method method;
    double tolerance_px;
    bool refuses_inside_chord;  // refuses when the field of view reaches 180 deg
  };
  MethodOptions strips = Options(Method::kStrips);
  strips.strips = 256;
  const std::pair<MethodOptions, Expect> methods[] = {
      {Options(Method::kExact), {Method::kExact, 0.002, false}},
      {Options(Method::kWarp), {Method::kWarp, 0.01, true}},
      // The heuristic's tolerance (0.05 px) is an estimate from sample points, not a bound: far off axis the
      // measured worst error reaches ~0.5 px. Pinned here as measured; the bench charts it.
      {Options(Method::kMesh), {Method::kMesh, 0.6, true}},
      {strips, {Method::kStrips, 0.05, false}},
  };
  for (const FailureCase& c : cases) {
    const Eigen::Vector3d eye = ScreenCentreInScreen(m) + c.eye_from_centre;
    PatternSpec spec;
    spec.cols = 10;
    spec.rows = 4;
    const Pattern p = BuildPattern(spec, m, eye, TangentPlaneAtCentre(m));
    const bool wide = c.eye_from_centre.z() <= m.sagitta_mm();
    for (const auto& [options, expect] : methods) {
      SCOPED_TRACE(std::string(c.name) + " / " + options.Label());
      if (wide && expect.refuses_inside_chord) {
        RenderOptions o;
        o.method = options;
        try {
          SharedRenderer().RenderCoordinates(m, eye, p, o);
          ADD_FAILURE() << "rendered instead of refusing";
        } catch (const Error& e) {
          EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("180 deg"));
          std::cout << "refused: " << e.what() << "\n";
        }
        continue;
      }
      const MappingError e = Measure(m, eye, p, options);
      EXPECT_EQ(e.missing_pixels, 0);
      EXPECT_LT(e.max_px, expect.tolerance_px);
    }
  }
}

TEST(FailureCases, InvalidViewpointsAreRefusedByEveryMethod) {
  const Monitor m = MonitorFromDiagonal("27", 1280, 720, 27, 0);
  PatternSpec spec;
  const Pattern p = BuildPattern(spec, m, {0, 0, 600}, TangentPlaneAtCentre(m));
  for (Method method : {Method::kExact, Method::kWarp, Method::kMesh, Method::kStrips, Method::kNone}) {
    RenderOptions o;
    o.method.method = method;
    EXPECT_THROW(SharedRenderer().Render(m, {0, 0, -5}, p, o), Error) << MethodName(method);
  }
}

// The shaded image: the four quadrants around each checkerboard corner alternate black and white, the
// surround is grey, and every method agrees with exact away from edges.
TEST(Shading, CheckerboardCornersAndSurround) {
  const Monitor m = MonitorFromDiagonal("34 1900R", 1720, 720, 34, 1900);
  const Eigen::Vector3d eye = ScreenCentreInScreen(m) + Eigen::Vector3d(100, -50, 800);
  PatternSpec spec;
  spec.cols = 12;
  spec.rows = 5;
  const Pattern p = BuildPattern(spec, m, eye, TangentPlaneAtCentre(m));
  RenderOptions o;
  const GrayImage exact = SharedRenderer().Render(m, eye, p, o);
  auto at = [&](const GrayImage& img, double x, double y) {
    return img.pixels[static_cast<size_t>(std::lround(y)) * img.width + static_cast<size_t>(std::lround(x))];
  };
  EXPECT_EQ(at(exact, 0, 0), 128);
  EXPECT_EQ(at(exact, m.width_px - 1, m.height_px - 1), 128);
  int corners = 0;
  for (const Feature& f : p.features) {
    if (f.kind != "corner" || !f.visible) continue;
    const Eigen::Vector2d c = *f.display_px;
    const int tl = at(exact, c.x() - 4, c.y() - 4), tr = at(exact, c.x() + 4, c.y() - 4);
    const int bl = at(exact, c.x() - 4, c.y() + 4), br = at(exact, c.x() + 4, c.y() + 4);
    EXPECT_EQ(tl, br) << f.id;
    EXPECT_EQ(tr, bl) << f.id;
    EXPECT_EQ(std::abs(tl - tr), 255) << f.id;
    ++corners;
  }
  EXPECT_EQ(corners, 11 * 4);
  // Other methods agree with exact wherever exact's 3 x 3 neighbourhood is uniform (away from edges, where
  // each method's small placement differences change anti-aliased values).
  auto uniform = [&](int x, int y) {
    const int v = exact.pixels[static_cast<size_t>(y) * exact.width + x];
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (exact.pixels[static_cast<size_t>(y + dy) * exact.width + (x + dx)] != v) return false;
      }
    }
    return true;
  };
  for (Method method : {Method::kWarp, Method::kMesh, Method::kStrips}) {
    o.method = Options(method);
    o.method.strips = 128;
    const GrayImage img = SharedRenderer().Render(m, eye, p, o);
    size_t compared = 0, differ = 0;
    for (int y = 1; y + 1 < img.height; ++y) {
      for (int x = 1; x + 1 < img.width; ++x) {
        if (!uniform(x, y)) continue;
        ++compared;
        const size_t i = static_cast<size_t>(y) * img.width + x;
        differ += std::abs(img.pixels[i] - exact.pixels[i]) > 8 ? 1 : 0;
      }
    }
    EXPECT_GT(compared, img.pixels.size() * 9 / 10);
    EXPECT_LT(static_cast<double>(differ) / compared, 1e-4) << MethodName(method);
  }
}

}  // namespace
}  // namespace curvecheck
