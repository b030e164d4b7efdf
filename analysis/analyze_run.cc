// `curvecheck analyze` once its options are parsed (analyze_run.h).
#include "analysis/analyze_run.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <filesystem>
#include <ostream>

#include "analysis/overlay.h"
#include "analysis/report.h"
#include "analysis/result_reader.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/output_paths.h"
#include "core/stopwatch.h"

namespace curvecheck {
namespace fs = std::filesystem;

void AnalyzeToFolder(AnalyzeRequest a, std::ostream& log) {
  if (a.patterns.size() != 1 && a.patterns.size() != a.photos.size()) {
    throw Error("--pattern",
                fmt::format("{} pattern files for {} photos", a.patterns.size(), a.photos.size()),
                "give one --pattern for all photos, or one per photo in the order of the photos");
  }
  if (!a.models.empty()) a.options.fit.models = ParseScreenModels(a.models, "analyze options");
  a.options.fit_screen = !a.no_fit;
  a.options.fit.pitch_tolerance_relative = PitchToleranceFromPercent(a.pitch_tolerance_percent, "--pitch-tolerance");
  if (a.prefilter_sigma_px) {
    const double p = *a.prefilter_sigma_px;
    if (!(p == -1 || (p >= 0 && p <= 10))) {
      throw Error("--prefilter-sigma", fmt::format("{} px is not a prefilter", p),
                  "give -1 (auto: from the moire measured in the photo), 0 (none) or a sigma up to 10 px");
    }
    a.options.detect.prefilter_sigma_px = p;
  }
  if (!a.lens_misfit.empty()) {
    if (a.lens_misfit.size() != 2 || !(a.lens_misfit[0] > 0) || !IsLensMisfitField(a.lens_misfit[0], a.lens_misfit[1])) {
      throw Error("--lens-misfit", fmt::format("{} is not an RMS and a length", fmt::join(a.lens_misfit, ",")),
                  "give RMS_PX,LENGTH_PX: the misfit field's RMS per coordinate (0 to 100 px) and its correlation "
                  "length (px), e.g. 0.1,1200 (curvecheck calibrate's report: candidates[].misfit)");
    }
    a.options.fit.stated_lens_misfit_px = a.lens_misfit[0];
    a.options.fit.stated_lens_misfit_length_px = a.lens_misfit[1];
    a.options.fit.stated_lens_misfit_source = "stated with --lens-misfit";
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
  log << SummaryText(r);
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
  // Every photo read has its overlay, a duplicate too (drawn with the detections of its content, marked as not
  // used in the fit: overlay.h); the page shows the used photos'.
  for (size_t i = 0; i < r.photos.size(); ++i) {
    const PhotoAnalysis& p = r.photos[i];
    if (r.OverlaySource(i) < 0) continue;
    const fs::path path = dir / OverlayFileName(p.name);
    if (a.no_overlays) {
      set.RemoveOnPublish(path);
      if (p.used) assets.overlay_missing[p.name] = "analyze ran with --no-overlays";
      continue;
    }
    std::string png = OverlayPng(r, i, a.magnification);
    set.Write(path, png);
    overlays.push_back(path);
    if (!a.no_report && p.used) assets.overlay_png[p.name] = std::move(png);
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
  log << "wrote " << result_path.string();
  for (const fs::path& p : overlays) log << ", " << p.filename().string();
  log << "\n";
  if (!report_failure.empty()) {
    throw Error(report_path.string(), fmt::format("not written ({}); {} was written", report_failure,
                                                  result_path.string()),
                "fix that and run `curvecheck report " + result_path.string() + "`, or pass --no-report");
  }
  if (!a.no_report) {
    log << fmt::format("wrote {} ({:.2f} MB) in {:.0f} ms\n", report_path.string(), html.size() / 1e6,
                             watch.Ms());
  }
}

}  // namespace curvecheck
