// The textured quad of `curvecheck pattern`, proved from its outputs alone: the features found in texture.png,
// placed on the quad by plane.json's corners and seen from plane.json's eye through the curved screen, land on
// pattern.json's exact display positions.
#include "render/pattern_texture.h"

#include <gtest/gtest.h>

#include <fmt/format.h>

#include <iostream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/screenshot_check.h"
#include "core/correction.h"
#include "core/monitor_json.h"
#include "detect/detect.h"
#include "pattern/pattern_json.h"

namespace curvecheck {
namespace {

Eigen::Vector3d Vec3(const nlohmann::json& j) { return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()}; }

const Monitor& Monitor49() {
  static const Monitor m = MonitorFromDiagonal("49in 5120x1440 1000R", 5120, 1440, 49, 1000);
  return m;
}

TEST(PatternTexture, QuadIsTheChordPlaneThroughTheDisplaysCorners) {
  const Monitor& m = Monitor49();
  const Eigen::Vector3d eye(0, 0, 500);
  const nlohmann::json plane = PlaneToJson(MakePatternQuad(m, eye), m, eye, RenderOptions{}, "texture.png");
  ASSERT_EQ(plane["corners"].size(), 4u);
  // Not widened from this eye: the quad's corners are the display's corners, seen from the eye.
  EXPECT_FALSE(plane["frustum"]["vertical_extents_widened"].get<bool>());
  const std::map<std::string, Eigen::Vector2d> expected = {{"top_left", {-0.5, -0.5}},
                                                           {"top_right", {5119.5, -0.5}},
                                                           {"bottom_right", {5119.5, 1439.5}},
                                                           {"bottom_left", {-0.5, 1439.5}}};
  for (const nlohmann::json& c : plane["corners"]) {
    const auto px = DisplayPxFromPoint(m, eye, Vec3(c["in_screen_mm"]));
    ASSERT_TRUE(px);
    EXPECT_NEAR((*px - expected.at(c["corner"].get<std::string>())).norm(), 0, 1e-6) << c["corner"];
    EXPECT_NEAR((Vec3(c["from_eye_mm"]) + eye - Vec3(c["in_screen_mm"])).norm(), 0, 1e-9);
    EXPECT_NEAR(c["uv_v_down"][1].get<double>() + c["uv_v_up"][1].get<double>(), 1, 0);
  }
  // z of the chord plane, -R cos(theta).
  EXPECT_NEAR(plane["plane"]["z_mm"].get<double>(), -m.radius_mm() * std::cos(m.half_sector_rad()), 1e-9);
}

// From plane.json alone (its corners, texture size, eye and monitor): texture px -> point on the quad -> ray from
// the eye -> display px, for every feature found in the texture; against pattern.json's exact display_px. Two eyes:
// centred, and 250 mm above the centre (above the top edge), where 4.2.2 widens the extents.
TEST(PatternTexture, TextureAndPlaneJsonReproducePatternJsonsDisplayPositions) {
  Renderer renderer;
  for (const Eigen::Vector3d& eye : {Eigen::Vector3d(0, 0, 500), Eigen::Vector3d(0, 250, 500)}) {
    const Monitor& m = Monitor49();
    const Pattern pattern = BuildPattern(PatternSpec{}, m, eye, TangentPlaneAtCentre(m));
    const PatternQuad quad = MakePatternQuad(m, eye);
    const RenderOptions options;
    const GrayImage texture = RenderPatternTexture(renderer, quad, eye, pattern, options);
    const nlohmann::json plane = PlaneToJson(quad, m, eye, options, "texture.png");
    const PatternFile pattern_json =
        ParsePatternJson(PatternToJson(pattern, m, eye, options.method.ToJson()).dump(), "pattern.json");

    // The features in the texture: named by the detector, measured by edge areas with the lines' directions from the
    // detected neighbours.
    const cv::Mat image(texture.height, texture.width, CV_8UC1, const_cast<uint8_t*>(texture.pixels.data()));
    const Detection det = DetectFeatures(image, pattern_json, DetectOptions{});
    ASSERT_TRUE(det.failure.empty()) << det.failure;
    ASSERT_EQ(det.features.size(), 60u);
    std::map<std::string, Eigen::Vector2d> found;
    for (const DetectedFeature& d : det.features) found[d.id] = d.px;
    cv::Mat linear;
    image.convertTo(linear, CV_64F, 1.0 / 255);
    cv::pow(linear, options.display_gamma, linear);

    // plane.json alone from here on.
    std::map<std::string, Eigen::Vector3d> corner;
    for (const nlohmann::json& c : plane["corners"]) corner[c["corner"].get<std::string>()] = Vec3(c["in_screen_mm"]);
    const double tw = plane["texture"]["size_px"][0].get<double>(), th = plane["texture"]["size_px"][1].get<double>();
    const Eigen::Vector3d plane_eye = Vec3(plane["eye_mm"]);
    const nlohmann::json& pm = plane["monitor"];
    const Monitor plane_monitor = MonitorFromActiveArea(
        "plane.json", pm["resolution"][0].get<int>(), pm["resolution"][1].get<int>(), pm["width_mm"].get<double>(),
        pm["height_mm"].get<double>(), pm["radius_mm"].is_number() ? pm["radius_mm"].get<double>() : 0.0);
    double worst = 0;
    const int per_row = 15;
    for (const Feature& f : pattern_json.features) {
      const int k = std::stoi(f.id.substr(1)), col = k % per_row;
      const Eigen::Vector2d here = found.at(f.id);
      const Eigen::Vector2d row_dir = found.at(fmt::format("c{}", col + 1 < per_row ? k + 1 : k - 1)) - here;
      const Eigen::Vector2d col_dir = found.at(fmt::format("c{}", k + per_row < 60 ? k + per_row : k - per_row)) - here;
      const auto refined =
          RefineXCornerByEdgeAreas(linear, here, row_dir, col_dir, 0.45 * std::min(row_dir.norm(), col_dir.norm()));
      ASSERT_TRUE(refined) << f.id;
      const double fx = (refined->px.x() + 0.5) / tw, fy = (refined->px.y() + 0.5) / th;
      const Eigen::Vector3d on_quad = corner["top_left"] + fx * (corner["top_right"] - corner["top_left"]) +
                                      fy * (corner["bottom_left"] - corner["top_left"]);
      const auto display = DisplayPxFromPoint(plane_monitor, plane_eye, on_quad);
      ASSERT_TRUE(display) << f.id;
      worst = std::max(worst, (*display - *f.display_px).norm());
    }
    std::cout << "eye (" << eye.transpose() << "): widened " << quad.frustum.vertical_extents_widened
              << ", largest |plane.json + texture.png - pattern.json| " << worst << " display px\n";
    EXPECT_EQ(quad.frustum.vertical_extents_widened, eye.y() > 0);
    EXPECT_LT(worst, 0.02);
  }
}

}  // namespace
}  // namespace curvecheck
