// `curvecheck demo`: the main job on the embedded default. Today the geometry core and the renderer exist;
// the capture -> analyze stages are added by issues 4 to 6, and the demo says so instead of pretending.
#include <fmt/format.h>

#include <Eigen/Core>
#include <iostream>

#include <filesystem>

#include "app/commands.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "render/mapping_error.h"
#include "render/pattern_json.h"
#include "render/renderer.h"
#include "core/correction.h"
#include "core/screen_geometry.h"
#include "core/viewing.h"
#include "datasets/monitor_presets.h"

namespace curvecheck::app {

int RunDemo(const DemoOptions& o) {
  const Monitor m = LoadMonitor(kDefaultMonitorPreset);
  // The default scene's camera: 1.5 m in front of the screen centre, on its normal.
  const Eigen::Vector3d viewpoint = ScreenCentreInScreen(m) + Eigen::Vector3d(0, 0, 1500);
  const PatternPlane plane = TangentPlaneAtCentre(m);
  const ViewingGeometry view = DescribeViewing(m, viewpoint);

  std::cout << fmt::format("curvecheck demo: {} ({} x {} px, {:.1f} x {:.1f} mm, R = {:.0f} mm)\n", m.name,
                           m.width_px, m.height_px, m.width_mm, m.height_mm, m.radius_mm())
            << fmt::format("viewpoint ({:g}, {:g}, {:g}) mm, {:.0f} mm from the screen centre: {:.2f} x {:.2f} deg, "
                           "{:.1f} px/deg at the centre\n\n",
                           viewpoint.x(), viewpoint.y(), viewpoint.z(), view.distance_to_centre_mm,
                           view.horizontal_fov_deg, view.vertical_fov_deg, view.pixels_per_degree_horizontal);

  // Correction mapping at a few display pixels: what each must show, and how far the pattern is stretched
  // compared with an uncorrected (flat-assuming) display of the same pattern.
  std::cout << "correction mapping (pattern plane tangent at the screen centre):\n"
            << "  display px            pattern point (mm)      laid flat, uncorrected (mm)   shift (px)\n";
  const double pitch = m.pixel_pitch_mm();
  for (const Eigen::Vector2d& px : {Eigen::Vector2d(0, 0), Eigen::Vector2d(1280, 360), Eigen::Vector2d(2559.5, 719.5),
                                   Eigen::Vector2d(3840, 1080), Eigen::Vector2d(5119, 1439)}) {
    const Eigen::Vector2d pattern = *PatternFromDisplayPx(m, viewpoint, plane, px);
    const Eigen::Vector2d flat((px.x() + 0.5) * pitch - 0.5 * m.width_mm, 0.5 * m.height_mm - (px.y() + 0.5) * pitch);
    std::cout << fmt::format("  ({:7.1f}, {:6.1f})    ({:8.2f}, {:7.2f})       ({:8.2f}, {:7.2f})            {:6.1f}\n",
                             px.x(), px.y(), pattern.x(), pattern.y(), flat.x(), flat.y(),
                             (pattern - flat).norm() / pitch);
  }

  // Self-check of the geometry on a 257 x 73 grid: display px -> pattern -> display px.
  double worst_px = 0;
  for (int i = 0; i <= 256; ++i) {
    for (int j = 0; j <= 72; ++j) {
      const Eigen::Vector2d px(-0.5 + m.width_px * i / 256.0, -0.5 + m.height_px * j / 72.0);
      const Eigen::Vector2d back = *DisplayPxFromPattern(m, viewpoint, plane, *PatternFromDisplayPx(m, viewpoint, plane, px));
      worst_px = std::max(worst_px, (back - px).norm());
    }
  }
  std::cout << fmt::format("\ngeometry self-check: display -> pattern -> display round trip, worst {:.2e} px over "
                           "{} points\n",
                           worst_px, 257 * 73);
  // Render the default patterns for this viewpoint with the exact method and measure its mapping error.
  std::filesystem::create_directories(o.output_dir);
  Renderer renderer;
  std::cout << fmt::format("\nrender (exact ray cast on {}, set-up {:.0f} ms):\n", renderer.device_name(),
                           renderer.setup_ms());
  RenderOptions options;
  for (PatternKind kind : {PatternKind::kCheckerboard, PatternKind::kAprilTag}) {
    PatternSpec spec;
    spec.kind = kind;
    const Pattern pattern = BuildPattern(spec, m, viewpoint, plane);
    RenderTiming timing;
    const GrayImage image = renderer.Render(m, viewpoint, pattern, options, &timing);
    const MappingError err =
        MeasureMappingError(m, viewpoint, pattern, renderer.RenderCoordinates(m, viewpoint, pattern, options));
    const std::filesystem::path png = std::filesystem::path(o.output_dir) / fmt::format("{}.png", PatternKindName(kind));
    nlohmann::json doc = PatternToJson(pattern, m, viewpoint, options.method.ToJson());
    doc["mapping_error_px"] = {{"rms", err.rms_px}, {"p99", err.p99_px}, {"max", err.max_px}};
    WritePng8(png, image.width, image.height, 1, image.pixels.data());
    WriteFileAtomic(std::filesystem::path(png).replace_extension(".json"), doc.dump(1) + "\n");
    std::cout << fmt::format("  {:<13} {:>4} features, {:6.1f} ms, mapping error max {:.4f} px -> {}\n",
                             PatternKindName(kind), pattern.features.size(), timing.render_ms, err.max_px,
                             png.string());
  }
  std::cout << "\nnot yet available (the demo will run them as they land):\n"
               "  capture synthetic ray-traced photo            issue 4\n"
               "  calibrate camera model                        issue 5\n"
               "  analyze verification, radius fit, report      issue 6\n"
            << fmt::format("outputs are in {}/\n", o.output_dir);
  return worst_px < 1e-6 ? 0 : 1;
}

}  // namespace curvecheck::app
