// `curvecheck demo`: the main job on the embedded default, end to end: render a corrected checkerboard for the
// default scene's camera position (exact method, Vulkan), photograph it with the synthetic camera (the default
// scene: 49" 1000R monitor, 24 MP OPENCV8 camera 1.5 m in front of the centre, an ideal true monitor), and
// analyse the photo (detect, verify, fit the screen). Prints the verdict and the radius against the truth.
#include <fmt/format.h>

#include <Eigen/Core>
#include <chrono>
#include <filesystem>
#include <iostream>

#include "analysis/pipeline.h"
#include "analysis/report.h"
#include "app/commands.h"
#include "app/output_paths.h"
#include "synth/synthetic_camera.h"
#include "core/correction.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/screen_geometry.h"
#include "core/viewing.h"
#include "datasets/dataset_files.h"
#include "pattern/pattern_json.h"
#include "render/renderer.h"

namespace curvecheck::app {
namespace {

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int RunDemo(const DemoOptions& o) {
  namespace fs = std::filesystem;
  const fs::path out = o.output_dir;
  PrepareOutputDir(out, "--output");
  // The embedded scenes and camera models, written out so that the scene finds its camera model and the
  // outputs document their inputs.
  const fs::path datasets = WriteDatasetFiles(out / "datasets");
  const fs::path scene_path = datasets / "scenes" / "default.yaml";
  const SyntheticScene scene = LoadScene(scene_path);
  const Monitor& m = scene.monitor;
  const Eigen::Vector3d viewpoint = scene.camera_position_in_screen;
  const ViewingGeometry view = DescribeViewing(m, viewpoint);
  std::cout << fmt::format("curvecheck demo: {} ({} x {} px, {:.1f} x {:.1f} mm, nominal R = {:.0f} mm)\n", m.name,
                           m.width_px, m.height_px, m.width_mm, m.height_mm, m.radius_mm())
            << fmt::format("camera {} ({} x {} px) at ({:g}, {:g}, {:g}) mm, {:.0f} mm from the screen centre "
                           "({:.1f} x {:.1f} deg of view)\n\n",
                           scene.camera.lensmodel, scene.camera.width, scene.camera.height, viewpoint.x(),
                           viewpoint.y(), viewpoint.z(), view.distance_to_centre_mm, view.horizontal_fov_deg,
                           view.vertical_fov_deg);

  // 1. Render: a 32 x 9 checkerboard corrected for the camera's position (the stated viewpoint).
  auto t0 = std::chrono::steady_clock::now();
  PatternSpec spec;
  spec.cols = 32;
  spec.rows = 9;
  const Pattern pattern = BuildPattern(spec, m, viewpoint, TangentPlaneAtCentre(m));
  Renderer renderer;
  RenderOptions options;
  RenderTiming timing;
  const GrayImage image = renderer.Render(m, viewpoint, pattern, options, &timing);
  const fs::path pattern_png = out / "pattern.png", pattern_json = out / "pattern.json";
  WritePng8(pattern_png, image.width, image.height, 1, image.pixels.data());
  WriteFileAtomic(pattern_json, PatternToJson(pattern, m, viewpoint, options.method.ToJson()).dump(1) + "\n");
  std::cout << fmt::format("1. render   {} corners, exact ray cast on {}: {:.0f} ms ({:.0f} ms on the device) -> {}\n",
                           pattern.features.size(), renderer.device_name(), MsSince(t0), timing.render_ms,
                           pattern_png.string());

  // 2. Capture: the synthetic camera photographs the display.
  t0 = std::chrono::steady_clock::now();
  const Image8 display = ReadImage8(pattern_png);
  const SyntheticPhoto photo = RenderSyntheticPhoto(scene, display);
  const fs::path photo_png = out / "photo.png", truth_json = out / "photo.truth.json";
  WriteSyntheticPhoto(photo_png, photo);
  WriteFileAtomic(truth_json, TruthJson(scene, pattern.features).dump(1) + "\n");
  std::cout << fmt::format("2. capture  synthetic {} x {} photo, {}x{} supersampled: {:.0f} ms -> {}\n", photo.width,
                           photo.height, scene.optics.supersample, scene.optics.supersample, MsSince(t0),
                           photo_png.string());

  // 3. Analyze.
  t0 = std::chrono::steady_clock::now();
  const fs::path analysis_dir = out / "analysis";
  PrepareOutputDir(analysis_dir, "--output");
  const fs::path camera_path = datasets / "cameras" / fs::path(scene.camera_model_path).filename();
  const AnalysisResult r = Analyze(camera_path, {{photo_png, pattern_json}}, AnalyzeOptions{});
  if (r.UsedPhotos() == 0) {
    std::cout << SummaryText(r);
    throw Error(photo_png.string(), "the demo's photo could not be analysed: " + r.photos.front().rejected,
                "report this as a bug");
  }
  const std::vector<fs::path> overlays = WriteOverlays(r, analysis_dir);
  const fs::path result_json = analysis_dir / "result.json";
  const nlohmann::json result = ResultJson(r, "curvecheck demo");
  WriteFileAtomic(result_json, result.dump(1) + "\n");
  const fs::path report_html = analysis_dir / "report.html";
  WriteFileAtomic(report_html, ReportHtml(result, LoadReportAssets(result, analysis_dir, result_json.string())));
  std::cout << fmt::format("3. analyze  {} features detected ({}), verification, fit of {} screen models: {:.0f} ms -> {}\n\n",
                           r.photos.front().detection.features.size(), r.photos.front().detection.detector,
                           r.fit ? r.fit->candidates.size() : 0, MsSince(t0), result_json.string());

  std::cout << SummaryText(r);
  bool ok = r.verification.pass;
  if (r.fit) {
    const ModelFit& f = r.fit->Chosen();
    const double true_radius = 1 / scene.truth.curvature_per_mm;
    if (f.radius_mm) {
      const bool inside = true_radius >= f.radius_ci95_mm[0] && true_radius <= f.radius_ci95_mm[1];
      std::cout << fmt::format("truth: R = {:.1f} mm; the fit is off by {:+.1f} mm = {:+.2f} sigma, {} its 95% interval\n",
                               true_radius, *f.radius_mm - true_radius,
                               (*f.radius_mm - true_radius) / f.radius_sigma_mm.value_or(1),
                               inside ? "inside" : "OUTSIDE");
      ok = ok && inside;
    } else {
      ok = false;
    }
  } else {
    ok = false;
  }
  std::cout << fmt::format("\noutputs: {}/ (pattern.png + .json, photo.png + .truth.json, analysis/result.json, "
                           "analysis/report.html, analysis/{})\n",
                           out.string(), overlays.empty() ? std::string("") : overlays.front().filename().string());
  return ok ? 0 : 1;
}

}  // namespace curvecheck::app
