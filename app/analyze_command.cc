// `curvecheck analyze --camera cam.cameramodel --pattern pattern.json photo.png [photo2.png ...] -o OUTDIR`:
// detection, verification of the correction, the screen fit with model selection, deviations; writes
// OUTDIR/result.json (architecture.md, "File contracts"), one overlay image per photo and OUTDIR/report.html (the
// self-contained page, analysis/report.h; --no-report skips it).
#include "app/analyze_command.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include "analysis/pipeline.h"
#include "analysis/report.h"
#include "analysis/result_reader.h"
#include "app/cli.h"
#include "app/output_paths.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/stopwatch.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct AnalyzeArgs {
  std::string camera;
  std::vector<std::string> patterns;
  std::vector<std::string> photos;
  std::string output;
  AnalyzeOptions options;
  std::vector<std::string> models;
  std::string detector = "auto";
  bool no_fit = false;
  bool no_overlays = false;
  bool no_report = false;
  double magnification = 50;
  std::string command_line;
  std::string lens_covariance;
  double pitch_tolerance_percent = 0.1;
  std::optional<double> prefilter_sigma_px;
};

int RunAnalyze(AnalyzeArgs a) {
  if (a.patterns.size() != 1 && a.patterns.size() != a.photos.size()) {
    throw Error("--pattern",
                fmt::format("{} pattern files for {} photos", a.patterns.size(), a.photos.size()),
                "give one --pattern for all photos, or one per photo in the order of the photos");
  }
  if (!a.models.empty()) a.options.fit.models = ParseScreenModels(a.models, "analyze options");
  a.options.fit_screen = !a.no_fit;
  if (!(a.pitch_tolerance_percent >= 0 && a.pitch_tolerance_percent < 50)) {
    throw Error("--pitch-tolerance", fmt::format("{} % is not a tolerance", a.pitch_tolerance_percent),
                "give a percentage from 0 to 50, e.g. 0.1");
  }
  a.options.fit.pitch_tolerance_relative = a.pitch_tolerance_percent / 100;
  if (a.prefilter_sigma_px) {
    const double p = *a.prefilter_sigma_px;
    if (!(p == -1 || (p >= 0 && p <= 10))) {
      throw Error("--prefilter-sigma", fmt::format("{} px is not a prefilter", p),
                  "give -1 (auto: from the moire measured in the photo), 0 (none) or a sigma up to 10 px");
    }
    a.options.detect.prefilter_sigma_px = p;
  }
  a.options.lens_covariance = a.lens_covariance;
  a.options.detect.detector = ParseDetector(a.detector, "analyze options");
  // The overlays are drawn on the image the analysis keeps (no second decode of each photo).
  a.options.overlay_max_px = a.no_overlays ? 0 : kOverlayMaxPx;
  a.options.Check("analyze options");
  if (!(a.magnification > 0) || !std::isfinite(a.magnification)) {
    throw Error("--magnify", fmt::format("{} is not a positive finite factor", a.magnification), "give e.g. 50");
  }

  std::vector<PhotoInput> inputs;
  std::vector<fs::path> input_paths = {a.camera};
  if (!a.lens_covariance.empty()) input_paths.push_back(a.lens_covariance);
  for (size_t i = 0; i < a.photos.size(); ++i) {
    inputs.push_back({a.photos[i], a.patterns[a.patterns.size() == 1 ? 0 : i]});
    input_paths.push_back(inputs.back().photo);
    input_paths.push_back(inputs.back().pattern);
  }
  const fs::path dir = a.output;
  const fs::path result_path = dir / "result.json";
  const fs::path report_path = dir / "report.html";
  // Every output is checked before the work (minutes on many large photos): against the inputs, and the folder
  // made, writable and locked against a second run into it. The overlays' names are known now (PhotoNames).
  const std::vector<std::string> names = PhotoNames(inputs);
  std::vector<NamedOutput> outputs = {{"result.json", result_path}, {"report.html", report_path}};
  for (const std::string& name : names) outputs.push_back({"an overlay", dir / OverlayFileName(name)});
  CheckOutputs(outputs, input_paths);
  OutputFolder folder(dir, "-o");

  const AnalysisResult r = Analyze(a.camera, inputs, a.options);
  std::cout << SummaryText(r);
  if (r.UsedPhotos() == 0) {
    // One line, the first photo's reason: the most common case is a single photo.
    const PhotoAnalysis& p = r.photos.front();
    throw Error("", p.rejected + (r.photos.size() > 1 ? fmt::format(" (and {} more photos rejected)", r.photos.size() - 1) : ""),
                "");
  }
  // result.json, the overlays and report.html are published together (core/file_io.h OutputSet): an interrupted
  // or failed run leaves the previous complete set, never a new result.json beside an old report.html. Members
  // of the previous set that this run does not write (report.html with --no-report, overlays with --no-overlays)
  // go, so that nothing stale is read as part of the new set.
  OutputSet set;
  ReportAssets assets;
  std::vector<fs::path> overlays;
  for (size_t i = 0; i < r.photos.size(); ++i) {
    const PhotoAnalysis& p = r.photos[i];
    if (!p.used) continue;
    const fs::path path = dir / OverlayFileName(p.name);
    if (a.no_overlays) {
      set.RemoveOnPublish(path);
      assets.overlay_missing[p.name] = "analyze ran with --no-overlays";
      continue;
    }
    std::string png = OverlayPng(r, i, a.magnification);
    set.Write(path, png);
    overlays.push_back(path);
    if (!a.no_report) assets.overlay_png[p.name] = std::move(png);
  }
  const std::string result_text = ResultJson(r, a.command_line).dump(1) + "\n";
  set.Write(result_path, result_text);
  std::string html;
  std::string report_failure;
  const Stopwatch watch;
  if (a.no_report) {
    set.RemoveOnPublish(report_path);
  } else {
    // The page from the document just written, read back as `curvecheck report` reads it (so it shows what the
    // file says: a non-finite number in memory is null there), with the overlays just drawn.
    try {
      const nlohmann::json result = ParseResultJson(result_text, result_path.string());
      assets.source = result_path.string();
      html = ReportHtml(result, assets);
      set.Write(report_path, html);
    } catch (const Error& e) {
      report_failure = e.what();
      set.RemoveOnPublish(report_path);
    }
  }
  set.Publish();
  folder.Keep();
  std::cout << "wrote " << result_path.string();
  for (const fs::path& p : overlays) std::cout << ", " << p.filename().string();
  std::cout << "\n";
  if (!report_failure.empty()) {
    throw Error(report_path.string(), fmt::format("not written ({}); {} was written", report_failure,
                                                  result_path.string()),
                "fix that and run `curvecheck report " + result_path.string() + "`, or pass --no-report");
  }
  if (!a.no_report) {
    std::cout << fmt::format("wrote {} ({:.2f} MB) in {:.0f} ms\n", report_path.string(), html.size() / 1e6,
                             watch.Ms());
  }
  return 0;
}

}  // namespace

void AddAnalyzeCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<AnalyzeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "analyze",
      "Detect the pattern in photos, verify the correction (planar perspective check), fit the screen (radius with "
      "uncertainty, model selection, deviations); writes OUTDIR/result.json, overlay images and report.html");
  cmd->add_option("--camera,-c", args->camera, "The camera's mrcal .cameramodel (calibrated at the photos' size)")
      ->required();
  cmd->add_option("--pattern,-p", args->patterns,
                  "pattern.json of the rendering shown in the photos: once for all photos, or once per photo "
                  "in order")
      ->required()
      ->expected(1)
      ->take_all()
      ->allow_extra_args(false);
  cmd->add_option("photos", args->photos, "Photos (PNG/JPEG, 8 or 16 bit)")->required();
  cmd->add_option("-o,--output", args->output, "Output folder (created if missing)")->required();
  cmd->add_option("--detector", args->detector,
                  "auto | mrgingham | opencv-sb | opencv-classic | apriltag")
      ->capture_default_str();
  cmd->add_option("--tolerance", args->options.verify.tolerance_display_px,
                  "Verification passes when 95% of the features are within this many display px of the planar "
                  "perspective image")
      ->capture_default_str();
  cmd->add_option("--models", args->models,
                  "Screen models to try (default: all): flat, cylinder, cylinder+lean, varying-curvature, "
                  "varying-curvature-quadratic, cylinder+deviation")
      ->delimiter(',')
      ->expected(1)
      ->take_all()
      ->allow_extra_args(false);
  cmd->add_option("--expected-noise", args->options.fit.expected_noise_px,
                  "Expected detection noise per coordinate, px (scales the robust loss)")
      ->capture_default_str();
  cmd->add_option("--lens-covariance", args->lens_covariance,
                  "The lens calibration's intrinsics covariance (curvecheck.intrinsics_covariance/1, written by "
                  "`curvecheck calibrate`); default: CAM.intrinsics_covariance.json beside --camera when it exists, "
                  "else the lens is taken as exact (the budget says so)");
  cmd->add_option("--pitch-tolerance", args->pitch_tolerance_percent,
                  "Tolerance of the datasheet's pixel pitch, percent (half-width of a rectangular distribution; "
                  "its u = tolerance/sqrt(3) is the budget's pixel-pitch row: u(R)/R = u(p)/p)")
      ->capture_default_str();
  cmd->add_option("--prefilter-sigma", args->prefilter_sigma_px,
                  "Gaussian prefilter of the detector, sigma in camera px: -1 auto (default: against the moire "
                  "measured in the photo, and 2 x the display pitch for the refinement), 0 none, or a fixed sigma "
                  "(result.json records the one used: inputs.photos[].detection.moire.filter_sigma_px)");
  cmd->add_flag("--correct-pixel-locking", args->options.correct_pixel_locking,
                "Remove the detector's pixel-locking (estimated with the verification's error field, reported in "
                "result.json either way) from the detections before the screen fit (experimental: see README)");
  cmd->add_flag("--no-fit", args->no_fit, "Detection and verification only");
  cmd->add_flag("--no-overlays", args->no_overlays, "Do not write overlay images");
  cmd->add_flag("--no-report", args->no_report, "Do not write report.html (the HTML page; see `curvecheck report`)");
  cmd->add_option("--magnify", args->magnification, "Magnification of the residual vectors in the overlays")
      ->capture_default_str();
  cmd->callback([&run, args] {
    args->command_line = CommandLine();
    run = [args] { return RunAnalyze(*args); };
  });
}

}  // namespace curvecheck::app
