#include "experiments/demo.h"

#include <fmt/format.h>

#include "analysis/overlay.h"
#include "analysis/report.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/stopwatch.h"
#include "core/viewing.h"
#include "datasets/dataset_files.h"
#include "experiments/scene_lookup.h"
#include "experiments/trial.h"

namespace curvecheck::experiments {

bool RunDemo(const std::filesystem::path& out, std::ostream& log) {
  namespace fs = std::filesystem;
  const SyntheticScene scene = LoadEmbeddedScene("default", "demo");
  // The embedded scenes and camera models, written beside the outputs so that they document their inputs.
  const fs::path datasets = WriteDatasetFiles(out / "datasets");
  const Monitor& m = scene.monitor;
  const Eigen::Vector3d viewpoint = scene.screen_from_cam.translation;
  const ViewingGeometry view = DescribeViewing(m, viewpoint);
  log << fmt::format("curvecheck demo: {} ({} x {} px, {:.1f} x {:.1f} mm, nominal R = {:.0f} mm)\n", m.name,
                     m.width_px, m.height_px, m.width_mm, m.height_mm, m.radius_mm())
      << fmt::format(
             "camera {} ({} x {} px) at ({:g}, {:g}, {:g}) mm, {:.0f} mm from the screen centre "
             "({:.1f} x {:.1f} deg of view)\n\n",
             scene.camera.lensmodel, scene.camera.width, scene.camera.height, viewpoint.x(), viewpoint.y(),
             viewpoint.z(), view.distance_to_centre_mm, view.horizontal_fov_deg, view.vertical_fov_deg);

  // 1. Render: a 32 x 9 checkerboard corrected for the camera's position (the stated viewpoint).
  Stopwatch watch;
  PatternSpec spec;
  spec.cols = 32;
  spec.rows = 9;
  Renderer renderer;
  const TrialDisplay display = RenderTrialDisplay(renderer, m, viewpoint, spec);
  const fs::path pattern_png = out / "pattern.png", pattern_json = out / "pattern.json";
  WritePng8(pattern_png, display.image.width, display.image.height, 1, display.image.pixels.data());
  WriteFileAtomic(pattern_json, display.PatternJson().dump(1) + "\n");
  log << fmt::format(
      "1. render   {} corners, exact ray cast on {}: {:.0f} ms ({:.0f} ms on the device) -> {}\n",
      display.pattern.features.size(), renderer.device_name(), watch.Ms(), display.timing.render_ms,
      pattern_png.string());

  // 2. Capture: the synthetic camera photographs the display; 3. analyse the photo.
  const fs::path photo_png = out / "photo.png", truth_json = out / "photo.truth.json";
  const fs::path camera_path = datasets / "cameras" / fs::path(scene.camera_model_path).filename();
  // The photo goes to the analysis in memory (the PNG is for the user); the analysis keeps it scaled for the
  // overlay, which therefore reads nothing back (issue 18).
  AnalyzeOptions analyze_options;
  analyze_options.overlay_max_px = kOverlayMaxPx;
  const TrialAnalysis trial =
      PhotographAndAnalyse(scene, display.image, {photo_png, pattern_json}, camera_path, analyze_options);
  WriteSyntheticPhoto(photo_png, trial.photo);
  WriteFileAtomic(truth_json, TruthJson(scene, display.pattern.features).dump(1) + "\n");
  log << fmt::format("2. capture  synthetic {} x {} photo, {}x{} supersampled: {:.0f} ms -> {}\n",
                     trial.photo.width, trial.photo.height, scene.optics.supersample,
                     scene.optics.supersample, trial.photo_ms, photo_png.string());

  watch.Restart();
  const AnalysisResult& r = trial.analysis;
  const fs::path analysis_dir = out / "analysis";
  fs::create_directories(analysis_dir);
  if (r.UsedPhotos() == 0) {
    log << SummaryText(r);
    throw Error(photo_png.string(), "the demo's photo could not be analysed: " + r.photos.front().rejected,
                "report this as a bug");
  }
  // The overlays drawn once, written and embedded from memory (not read back and decoded again).
  const fs::path result_json = analysis_dir / "result.json";
  ReportAssets assets;
  assets.source = result_json.string();
  std::vector<fs::path> overlays;
  for (size_t i = 0; i < r.photos.size(); ++i) {
    if (r.OverlaySource(i) < 0) continue;
    std::string png = OverlayPng(r, i);
    overlays.push_back(analysis_dir / OverlayFileName(r.photos[i].name));
    WriteFileAtomic(overlays.back(), png);
    assets.overlay_png[r.photos[i].name] = std::move(png);
  }
  const nlohmann::json result = ResultJson(r, "curvecheck demo");
  WriteFileAtomic(result_json, result.dump(1) + "\n");
  const fs::path report_html = analysis_dir / "report.html";
  WriteFileAtomic(report_html, ReportHtml(result, assets));
  log << fmt::format(
      "3. analyze  {} features detected ({}), verification, fit of {} screen models: {:.0f} ms -> {}\n\n",
      r.photos.front().detection.features.size(), r.photos.front().detection.detector,
      r.fit ? r.fit->candidates.size() : 0, r.total_ms + watch.Ms(), result_json.string());

  log << SummaryText(r);
  bool ok = r.verification.pass && r.fit;
  if (r.fit) {
    const ModelFit& f = r.fit->Chosen();
    const double true_radius = 1 / scene.truth.curvature_per_mm;
    if (f.radius_mm) {
      const bool inside = true_radius >= f.radius_ci95_mm[0] && true_radius <= f.radius_ci95_mm[1];
      log << fmt::format(
          "truth: R = {:.1f} mm; the fit is off by {:+.1f} mm = {:+.2f} sigma, {} its 95% interval\n",
          true_radius, *f.radius_mm - true_radius,
          (*f.radius_mm - true_radius) / f.radius_sigma_mm.value_or(1), inside ? "inside" : "OUTSIDE");
      ok = ok && inside;
    } else {
      ok = false;
    }
  }
  log << fmt::format(
      "\noutputs: {}/ (pattern.png + .json, photo.png + .truth.json, analysis/result.json, "
      "analysis/report.html, analysis/{})\n",
      out.string(), overlays.empty() ? std::string("") : overlays.front().filename().string());
  return ok;
}

}  // namespace curvecheck::experiments
