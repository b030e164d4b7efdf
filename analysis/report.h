// The HTML report of an analysis (issue 7 item 1): one self-contained page (report.html) made from result.json
// (curvecheck.result/1) and the overlay images, that opens offline in any browser.
//
// Contents: the summary (verification verdict, radius +- sigma with its 95% interval and the stated assumptions,
// the chosen model and why, every warning of the fit), the model-selection table, the radius of every candidate
// with its interval (chart), the verification residuals against the tolerance (histogram), the deviation map in
// mm, one section per photo (detection and verification numbers, camera position, the overlay, a residual map),
// every feature, and the provenance (command, camera model, monitor, patterns, photos, software).
//
// Self-contained: images are data: URIs (overlays re-encoded as JPEG at their own size, which keeps the page small:
// 0.8 MB for the demo instead of 4.2 MB with the PNG; charts are PNG drawn by gnuplot from the result's
// numbers, core/gnuplot.h); no script, style or image is fetched from anywhere and the page names no URL. Every
// string from the document is HTML-escaped.
//
// Stable hooks for tests and scripts (each element's data-value holds the exact number of result.json, printed
// shortest round-trip; its text is rounded for reading):
//   #verdict (data-pass "true"/"false"), #radius-mm, #radius-sigma-mm, #radius-ci95-lo-mm, #radius-ci95-hi-mm
//   (data-value "null" when the document has null), #chosen-model, #feature-count (length of `features`),
//   #rms-display-px, #p95-display-px, #tolerance-display-px, #photo-count; #photos tbody rows carry
//   data-photo, data-status, data-features (detections), data-rms-px, data-rms-display-px; #models rows carry
//   data-model, data-chosen, data-radius-mm; #warnings lists every warning; <body data-images-ok="N/M"> is set
//   by an inline script after load: N of the M <img> elements decoded.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

namespace curvecheck {

struct ReportAssets {
  // Overlay PNG bytes of the used photos, by photo name (inputs.photos[].name).
  std::map<std::string, std::string> overlay_png;
  // Why a used photo has no overlay ("overlay-x.png not found beside result.json"), by photo name; the page
  // shows the reason in the overlay's place. A used photo in neither map gets "no overlay was given".
  std::map<std::string, std::string> overlay_missing;
  // Where the document came from (shown in the page): "out/result.json".
  std::string source = "result.json";
};

struct ReportOptions {
  // Draw the charts with gnuplot. false: each chart is a placeholder note (the page is otherwise the same; for
  // fuzzing the page builder without starting processes).
  bool charts = true;
  // Chart size in pixels (PNG).
  int chart_width_px = 1100, chart_height_px = 480;
};

// The page. Checks `result` first (CheckResultJson; throws Error naming assets.source and the key at fault);
// throws Error if gnuplot is missing or fails.
std::string ReportHtml(const nlohmann::json& result, const ReportAssets& assets, const ReportOptions& options = {});

// The overlay file of a photo, as WriteOverlays (overlay.h) names it: "overlay-<stem of name>.png".
std::string OverlayFileName(const std::string& photo_name);

// The overlays of the used photos of `result`, read from `dir` (the folder of result.json) and decoded to check
// them; a missing, unreadable or damaged file (truncated, corrupt data) is recorded in overlay_missing, never
// thrown. `source` goes to ReportAssets::source.
ReportAssets LoadReportAssets(const nlohmann::json& result, const std::filesystem::path& dir,
                              const std::string& source);

}  // namespace curvecheck
