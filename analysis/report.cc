#include "analysis/report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "analysis/report_charts.h"
#include "analysis/report_format.h"
#include "analysis/result_reader.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/image_decode.h"

#include <opencv2/imgcodecs.hpp>

#ifndef CURVECHECK_VERSION
#define CURVECHECK_VERSION "unknown"
#endif

namespace curvecheck {
namespace {

using namespace report_internal;  // NOLINT: the page builder is made of these helpers

namespace fs = std::filesystem;
using json = nlohmann::json;

// ---------------------------------------------------------------------------------------------------------------
// Page

constexpr char kStyle[] = R"css(
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1200px; padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.2em; }
h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.8em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.chosen { background: #fff4d6; font-weight: bold; }
.verdict { font-size: 1.6em; font-weight: bold; padding: 0.1em 0.5em; border-radius: 0.2em; }
.pass { background: #d9f2d9; color: #135e13; }
.fail { background: #f8d7d7; color: #8b1a1a; }
.inconclusive { background: #fff1c2; color: #6b5200; }
.big { font-size: 1.4em; font-weight: bold; }
#warnings { border: 2px solid #d08000; background: #fff3dc; padding: 0.5em 1em; margin: 1em 0; }
#warnings h2 { border: none; margin: 0.2em 0; color: #8a5300; }
.note { color: #555; font-style: italic; }
figure { margin: 1em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; max-width: 70em; }
code { background: #f4f4f4; padding: 0 0.2em; word-break: break-all; }
dt { font-weight: bold; margin-top: 0.4em; }
)css";

// Sets data-images-ok="N/M" on <body> once the page has loaded: N of the M images decoded (tests read it).
constexpr char kImageCheck[] = R"js(
window.addEventListener('load', function () {
  var images = document.images, ok = 0;
  for (var i = 0; i < images.length; ++i) {
    if (images[i].complete && images[i].naturalWidth > 0) ++ok;
  }
  document.body.setAttribute('data-images-ok', ok + '/' + images.length);
});
)js";

struct Warnings {
  std::vector<std::string> items;  // HTML
  void Add(std::string html) { items.push_back(std::move(html)); }
};

// "pass", "fail" or "inconclusive" of a verification object (older result.json: from "pass").
std::string VerdictOf(const json& v) {
  if (v.contains("verdict") && v["verdict"].is_string()) return v["verdict"].get<std::string>();
  return v.value("pass", false) ? "pass" : "fail";
}

std::string Upper(std::string text) {
  for (char& ch : text) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return text;
}

std::string VerdictCell(const std::string& verdict) {
  return fmt::format("<span class=\"{}\">{}</span>", verdict, Upper(verdict));
}

std::string ModelsTable(const json& fit, Warnings& warnings) {
  std::optional<double> best_bic;
  for (const json& k : fit["candidates"]) {
    if (const auto b = Opt(k["bic"])) best_bic = best_bic ? std::min(*best_bic, *b) : *b;
  }
  std::ostringstream s;
  s << "<table id=\"models\"><thead><tr><th>model</th><th>parameters</th><th>RMS, px</th>"
       "<th>held-out RMS, px (shuffled / strips)</th>"
       "<th>noise, px</th><th>BIC</th><th>&#916;BIC</th><th>radius &#177; &#963;, mm</th><th>95% interval, mm</th>"
       "<th>other parameters</th><th>converged</th><th>fits the detection noise (&#967;&#178;/dof, p)</th><th>notes</th>"
       "</tr></thead><tbody>\n";
  for (const json& k : fit["candidates"]) {
    const bool chosen = k.value("chosen", false);
    const std::string name = Str(k["model"]);
    const std::optional<double> radius = Opt(k["radius_mm"]), sigma = Opt(k["radius_sigma_mm"]);
    const std::optional<double> bic = Opt(k["bic"]);
    const int dec = DecimalsFor(sigma);
    std::string radius_text = radius ? fmt::format("{} &#177; {}", Fixed(radius, dec), Fixed(sigma, dec)) : "&#8212;";
    std::string interval;
    if (radius) {
      interval = fmt::format("{} .. {}", Fixed(Opt(k["radius_ci95_mm"][0]), dec), Fixed(Opt(k["radius_ci95_mm"][1]), dec));
    } else if (const auto bound = OptAt(k, "radius_lower_bound_mm"); bound && *bound > 0) {
      interval = fmt::format("flat consistent; |R| &gt; {:.0f}", *bound);
    } else {
      interval = "&#8212;";
    }
    std::string extra;
    if (const auto e = k.find("extra"); e != k.end()) {
      for (const auto& [param, value] : e->items()) {
        extra += fmt::format("{}{} = {} &#177; {}", extra.empty() ? "" : "<br>", Html(param),
                             Opt(value["value"]) ? fmt::format("{:.4g}", *Opt(value["value"])) : "&#8212;",
                             Opt(value["sigma"]) ? fmt::format("{:.2g}", *Opt(value["sigma"])) : "&#8212;");
      }
    }
    std::vector<std::string> notes;
    const bool converged = k.value("converged", true);
    if (!converged) notes.push_back("did not converge");
    if (k.value("ill_conditioned", false)) notes.push_back("ill-conditioned");
    if (k.contains("condition_note")) {
      notes.push_back(Html(Str(k["condition_note"])));
      warnings.Add(fmt::format("Model <b>{}</b>{}: {}", Html(name), chosen ? " (chosen)" : "",
                               Html(Str(k["condition_note"]))));
    } else if (k.value("ill_conditioned", false) && chosen) {
      warnings.Add(fmt::format("The chosen model <b>{}</b> is ill-conditioned.", Html(name)));
    }
    if (const auto w = k.find("warnings"); w != k.end()) {
      for (const json& text : *w) {
        notes.push_back(Html(Str(text)));
        warnings.Add(fmt::format("Model <b>{}</b>: {}", Html(name), Html(Str(text))));
      }
    }
    if (chosen && !converged) warnings.Add(fmt::format("The chosen model <b>{}</b> did not converge.", Html(name)));
    // Adequacy against the detection noise (absent in result.json written before it).
    std::string adequacy = "&#8212;";
    const bool adequate = k.value("adequate", true);
    if (k.contains("adequate")) {
      const std::optional<double> chi2 = Opt(k["chi2"]), p_value = Opt(k.value("chi2_p_value", json(nullptr)));
      const long dof = k.value("dof", 0L);
      adequacy = fmt::format("{} ({}, p {})", adequate ? "yes" : "<b>no</b>",
                             chi2 && dof > 0 ? fmt::format("{:.2f}", *chi2 / static_cast<double>(dof)) : "&#8212;",
                             p_value ? fmt::format("{:.2g}", *p_value) : "&#8212;");
    }
    if (k.contains("adequacy_note")) notes.push_back(Html(Str(k["adequacy_note"])));
    // The strip veto of the model choice (screen_fit.h FitOptions::heldout_strips; absent in older result.json).
    if (k.value("vetoed", false)) {
      notes.push_back("left out: predicts strips of the screen left out of the fit worse than a simpler adequate "
                      "model");
    }
    const std::optional<double> strips = k.contains("heldout_strips_px") ? Opt(k["heldout_strips_px"]) : std::nullopt;
    const std::string heldout =
        Fixed(Opt(k["heldout_rms_px"]), 4) + (strips ? " / " + Fixed(strips, 4) : std::string());
    s << fmt::format(
        "<tr data-model=\"{}\" data-chosen=\"{}\" data-radius-mm=\"{}\" data-adequate=\"{}\"{}><td>{}{}</td>"
        "<td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td><td>{}</td><td>{}</td>"
        "<td>{}</td></tr>\n",
        Html(name), chosen ? "true" : "false", Exact(radius), adequate ? "true" : "false",
        chosen ? " class=\"chosen\"" : "", Html(name),
        chosen ? " (chosen)" : "", k["parameters"].get<long>(), Fixed(Opt(k["rms_px"]), 4),
        heldout, Fixed(Opt(k["noise_px"]), 4), Fixed(bic, 1),
        bic && best_bic ? fmt::format("{:.1f}", *bic - *best_bic) : "&#8212;", radius_text, interval,
        extra.empty() ? "&#8212;" : extra, converged ? "yes" : "<b>no</b>", adequacy,
        fmt::format("{}", fmt::join(notes, "; ")));
  }
  s << "</tbody></table>\n";
  return s.str();
}

// The uncertainty budget (result.json fit.uncertainty_budget): one row per source with its type, its standard
// uncertainty of R, of the curvature and of the first camera's position (axis frame), its source and assumption;
// the combined row, the coverage factor and the 95% interval. "" when the result has no budget.
std::string BudgetTable(const json& fit) {
  if (!fit.contains("uncertainty_budget") || !fit["uncertainty_budget"].is_object() ||
      !fit["uncertainty_budget"].contains("components")) {
    return "";
  }
  const json& b = fit["uncertainty_budget"];
  const json empty = json::object();
  const json& cam = b.contains("camera_position") ? b["camera_position"] : empty;
  const auto pos = [&](const char* axis, size_t i) -> std::optional<double> {
    if (!cam.contains(axis)) return std::nullopt;
    return Opt(cam[axis]["components"][i]["standard_uncertainty_mm"]);
  };
  const auto pos_c = [&](const char* axis) -> std::optional<double> {
    if (!cam.contains(axis)) return std::nullopt;
    return Opt(cam[axis]["combined_standard_uncertainty_mm"]);
  };
  std::ostringstream s;
  s << "<table id=\"budget\"><thead><tr><th>source</th><th>type</th><th>u(R) mm</th><th>u(k) 1/m</th>"
       "<th>u(camera x, y, z) mm</th><th>how</th><th>assumption</th></tr></thead><tbody>\n";
  const json& rows = b["components"];
  for (size_t i = 0; i < rows.size(); ++i) {
    const json& c = rows[i];
    const std::optional<double> uk = Opt(b["curvature"]["components"][i]["standard_uncertainty_per_mm"]);
    s << "<tr" << (Str(c["name"]) == Str(b["dominant"]) ? " class=\"dominant\"" : "") << "><td>" << Html(Str(c["name"]))
      << "</td><td>" << Html(Str(c["type"]))
      << (c.value("distribution", std::string()) == "rectangular" ? ", rectangular" : "") << "</td><td>"
      << Fixed(Opt(c["standard_uncertainty_mm"]), 2)
      << "</td><td>" << Fixed(uk ? std::optional<double>(*uk * 1000) : std::nullopt, 5) << "</td><td>"
      << Fixed(pos("x", i), 2) << ", " << Fixed(pos("y", i), 2) << ", " << Fixed(pos("z", i), 2) << "</td><td>"
      << Html(Str(c["source"])) << "</td><td>" << Html(Str(c["assumption"])) << "</td></tr>\n";
  }
  const std::optional<double> ukc = Opt(b["curvature"]["combined_standard_uncertainty_per_mm"]);
  s << "<tr class=\"combined\"><td><b>combined</b></td><td></td><td>"
    << ValueSpan("budget-combined-mm", Opt(b["combined_standard_uncertainty_mm"]), 2) << "</td><td>"
    << Fixed(ukc ? std::optional<double>(*ukc * 1000) : std::nullopt, 5) << "</td><td>" << Fixed(pos_c("x"), 2)
    << ", " << Fixed(pos_c("y"), 2) << ", " << Fixed(pos_c("z"), 2) << "</td><td colspan=\"2\">quadrature sum; "
    << "dominant: " << Html(Str(b["dominant"])) << "</td></tr>\n</tbody></table>\n";
  const json& iv = b["interval95_mm"];
  s << "<p>95% interval of R: " << Fixed(Opt(iv[0]), 1) << " to " << Fixed(Opt(iv[1]), 1)
    << " mm, coverage factor " << ValueSpan("budget-coverage-factor", Opt(b["coverage_factor"]), 3) << " ("
    << Html(Str(b.value("interval_note", json("")))) << "). " << Html(Str(b.value("correlations", json(""))))
    << ".</p>\n";
  if (b.contains("detection_noise_independence") && b["detection_noise_independence"].value("tested", false)) {
    const json& ni = b["detection_noise_independence"];
    s << "<p id=\"noise-independence\" data-independent=\"" << (ni.value("independent", true) ? "true" : "false")
      << "\">The detection-noise row's assumption, "
      << (ni.value("independent", true) ? "independent errors" : "<b>independent errors, contradicted</b>") << ": "
      << Html(Str(ni["summary"])) << ".</p>\n";
  }
  return s.str();
}

std::string FeaturesTable(const json& r) {
  std::ostringstream s;
  s << fmt::format("<details><summary>All {} features (detections, residuals, deviations)</summary>\n",
                   r["features"].size());
  s << "<table id=\"features\"><thead><tr><th>photo</th><th>id</th><th>detected, camera px</th>"
       "<th>verification residual, camera px</th><th>residual, display px</th><th>residual, arcmin</th>"
       "<th>fit residual, camera px</th><th>deviation &#177; &#963;, mm</th><th>flag</th></tr></thead><tbody>\n";
  const auto pair = [](const json& f, const char* key, int decimals) -> std::string {
    const auto it = f.find(key);
    if (it == f.end()) return "&#8212;";
    return fmt::format("{}, {}", Fixed(Opt((*it)[0]), decimals), Fixed(Opt((*it)[1]), decimals));
  };
  for (const json& f : r["features"]) {
    std::string flag = f.contains("flag") ? Html(Str(f["flag"])) : std::string();
    if (f.value("fit_outlier", false)) flag += std::string(flag.empty() ? "" : "; ") + "fit outlier";
    s << fmt::format(
        "<tr><td>{}</td><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>\n",
        Html(Str(f["photo"])), Html(Str(f["id"])), pair(f, "detected_px", 2), pair(f, "residual_px", 3),
        pair(f, "residual_display_px", 3), Fixed(OptAt(f, "residual_arcmin"), 3), pair(f, "fit_residual_px", 3),
        OptAt(f, "deviation_mm") ? fmt::format("{} &#177; {}", Fixed(OptAt(f, "deviation_mm"), 3),
                                               Fixed(OptAt(f, "deviation_sigma_mm"), 3))
                                 : std::string("&#8212;"),
        flag);
  }
  s << "</tbody></table></details>\n";
  return s.str();
}

// The overlay as the page embeds it: the PNG re-encoded as JPEG at the same size (issue 18: the demo's 3000 x 2000
// overlay is 2.9 MB as PNG, 0.4 MB as JPEG at quality 92, so the page is 0.8 MB instead of 4.2 MB). The same pixels
// are shown (no downscaling; the residual vectors are drawn magnified and several pixels wide, which JPEG keeps);
// the lossless PNG stays beside result.json. Returns {MIME type, bytes}; the PNG as given if it cannot be decoded
// or has transparency, or the JPEG is not smaller (a small flat image).
std::pair<std::string, std::string> OverlayForPage(const std::string& png, const std::string& name) {
  cv::Mat img;
  try {
    img = DecodeImage(png, name);
  } catch (const Error&) {
    return {"image/png", png};
  }
  if (img.depth() == CV_16U) img.convertTo(img, CV_8U, 1.0 / 257);
  if (img.channels() == 4) return {"image/png", png};  // JPEG has no transparency; WriteOverlays writes none
  std::vector<uchar> jpeg;
  if (!cv::imencode(".jpg", img, jpeg, {cv::IMWRITE_JPEG_QUALITY, 92}) || jpeg.size() >= png.size()) {
    return {"image/png", png};
  }
  return {"image/jpeg", std::string(reinterpret_cast<const char*>(jpeg.data()), jpeg.size())};
}

}  // namespace

std::string OverlayFileName(const std::string& photo_name) {
  return "overlay-" + fs::path(photo_name).stem().string() + ".png";
}

ReportAssets LoadReportAssets(const json& result, const fs::path& dir, const std::string& source) {
  ReportAssets assets;
  assets.source = source;
  const auto inputs = result.find("inputs");
  if (inputs == result.end() || !inputs->contains("photos") || !(*inputs)["photos"].is_array()) return assets;
  for (const json& p : (*inputs)["photos"]) {
    if (!p.is_object() || p.value("status", "") != "used" || !p.contains("name") || !p["name"].is_string()) continue;
    const std::string name = p["name"].get<std::string>();
    const fs::path file = dir / OverlayFileName(name);
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) {
      assets.overlay_missing[name] = fmt::format("{} was not found beside {}", file.filename().string(),
                                                 fs::path(source).filename().string());
      continue;
    }
    try {
      std::string bytes = ReadFileToString(file);
      if (!IsPng(bytes)) {
        assets.overlay_missing[name] = file.filename().string() + " is not a PNG image";
      } else {
        // Decoded once, so that a damaged file is said (in the page and by `curvecheck report`) instead of
        // embedded as a broken image.
        try {
          DecodeImage(bytes, file.string());
          assets.overlay_png[name] = std::move(bytes);
        } catch (const Error& e) {
          assets.overlay_missing[name] = fmt::format("{} is damaged ({})", file.filename().string(), e.what());
        }
      }
    } catch (const Error& e) {
      assets.overlay_missing[name] = e.what();
    }
  }
  return assets;
}

std::string ReportHtml(const json& r, const ReportAssets& assets, const ReportOptions& options) {
  CheckResultJson(r, assets.source);
  if (options.chart_width_px < 100 || options.chart_height_px < 100 || options.chart_width_px > 10000 ||
      options.chart_height_px > 10000) {
    throw Error("report options", "chart sizes must be 100 .. 10000 px");
  }
  std::optional<ChartDataFolder> dir;
  if (options.charts) dir.emplace("the report's charts");
  const ChartDataFolder* chart_dir = dir ? &*dir : nullptr;

  const json& v = r["verification"];
  const json& fit = r["fit"];
  const json& inputs = r["inputs"];
  const json& monitor = inputs["monitor"];
  const bool has_fit = !fit["model"].is_null();
  const bool pass = v["pass"].get<bool>();
  Warnings warnings;

  // Warnings of the fit as a whole.
  if (const auto w = fit.find("warnings"); w != fit.end()) {
    for (const json& text : *w) warnings.Add(Html(Str(text)));
  }
  if (!has_fit) warnings.Add("No screen fit: " + Html(Str(fit["failure"])));
  if (v.contains("failure")) warnings.Add("Verification: " + Html(Str(v["failure"])));
  int used = 0, rejected = 0;
  for (const json& p : inputs["photos"]) (p["status"] == "used" ? used : rejected) += 1;
  if (rejected > 0) {
    warnings.Add(fmt::format("{} of {} photos were rejected (reasons in the photo table).", rejected, used + rejected));
  }
  if (has_fit && fit.contains("outliers") && !fit["outliers"].empty()) {
    warnings.Add(fmt::format("{} features were left out of the screen fit as outliers (listed under Features).",
                             fit["outliers"].size()));
  }
  const std::string models_table = has_fit ? ModelsTable(fit, warnings) : std::string();

  std::ostringstream s;
  s << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
    << "<title>curvecheck report: " << Html(Str(monitor["name"])) << "</title>\n<style>" << kStyle
    << "</style>\n<script>" << kImageCheck << "</script>\n</head>\n<body>\n";
  s << "<h1>curvecheck report</h1>\n<p>" << Html(Str(monitor["name"])) << " &#183; from <code>" << Html(assets.source)
    << "</code> (" << Html(Str(r["format"])) << ")</p>\n";

  // Summary.
  const std::optional<double> radius = has_fit ? Opt(fit["radius_mm"]) : std::nullopt;
  const std::optional<double> sigma = has_fit ? Opt(fit["radius_sigma_mm"]) : std::nullopt;
  const int dec = DecimalsFor(sigma);
  // The three-state verdict (result.json before it had one: pass or fail from "pass").
  const std::string verdict = VerdictOf(v);
  s << "<h2>Summary</h2>\n<p>Verification: <span id=\"verdict\" class=\"verdict " << verdict << "\" data-pass=\""
    << (pass ? "true" : "false") << "\" data-verdict=\"" << verdict << "\">" << Upper(verdict) << "</span></p>\n";
  if (v.contains("error_p95_display_px")) {
    s << "<p>Correction error (the smooth part of the residuals, separated from detection noise): 95% of the "
         "features are displaced by at most e = "
      << ValueSpan("error-p95-display-px", Opt(v["error_p95_display_px"]), 3) << " display px, expanded uncertainty U = "
      << ValueSpan("expanded-uncertainty-display-px", Opt(v["expanded_uncertainty_display_px"]), 3)
      << " display px (95%), test-uncertainty ratio T/U = "
      << ValueSpan("tolerance-ratio", Opt(v["tolerance_ratio"]), 1) << ". Decision rule: pass when e + U &#8804; T, "
      << "fail when e &#8722; U &gt; T, otherwise inconclusive. " << Html(Str(v.value("reason", json(""))))
      << ".</p>\n";
    if (v.contains("advice")) s << "<p id=\"advice\"><b>To decide:</b> " << Html(Str(v["advice"])) << ".</p>\n";
  }
  s << "<p>Raw residuals (error and noise together): 95% of the features are within " << ValueSpan("p95-display-px", Opt(v["p95_display_px"]), 3)
    << " display px of an exact planar perspective image of the pattern (tolerance "
    << ValueSpan("tolerance-display-px", Opt(v["tolerance_display_px"]), 3) << " display px). RMS "
    << ValueSpan("rms-display-px", Opt(v["rms_display_px"]), 3) << " display px, " << Fixed(Opt(v["rms_px"]), 3)
    << " camera px, " << Fixed(Opt(v["rms_arcmin"]), 3) << " arcmin; max " << Fixed(Opt(v["max_display_px"]), 3)
    << " display px. " << ValueSpan("feature-count", static_cast<double>(r["features"].size()), 0)
    << " features from " << ValueSpan("photo-count", static_cast<double>(used), 0) << " photo(s) used"
    << (rejected ? fmt::format(", {} rejected", rejected) : std::string()) << ".</p>\n";

  if (has_fit) {
    s << "<p class=\"big\">Radius: " << ValueSpan("radius-mm", radius, dec) << " &#177; "
      << ValueSpan("radius-sigma-mm", sigma, dec) << " mm (1 &#963;)</p>\n";
    if (radius) {
      s << "<p>95% interval " << ValueSpan("radius-ci95-lo-mm", Opt(fit["radius_ci95_mm"][0]), dec) << " .. "
        << ValueSpan("radius-ci95-hi-mm", Opt(fit["radius_ci95_mm"][1]), dec) << " mm";
    } else {
      s << "<p><b>The radius is not measurable as a number</b>";
      if (const auto bound = OptAt(fit, "radius_lower_bound_mm"); bound && *bound > 0) {
        s << fmt::format(": flat is consistent with the data (|R| above {:.0f} mm at 95%)", *bound);
      }
      s << "<span hidden>" << ValueSpan("radius-ci95-lo-mm", std::nullopt, 0)
        << ValueSpan("radius-ci95-hi-mm", std::nullopt, 0) << "</span>";
    }
    if (const auto nominal = OptAt(monitor, "radius_mm")) {
      s << fmt::format("; nominal {:g} mm", *nominal);
      if (radius) s << fmt::format(" ({:+.2f}%)", 100 * (*radius - *nominal) / *nominal);
    } else {
      s << "; nominal: flat";
    }
    s << ".</p>\n<p>Chosen model: <span id=\"chosen-model\" class=\"value\" data-value=\"" << Html(Str(fit["model"]))
      << "\"><b>" << Html(Str(fit["model"])) << "</b></span> &#8212; " << Html(Str(fit["choice_reason"]))
      << ". Fit RMS " << Fixed(Opt(fit["rms_px"]), 4) << " camera px, noise " << Fixed(Opt(fit["noise_px"]), 4)
      << " px per coordinate.</p>\n";
    s << "<p>The uncertainty holds under these assumptions:</p>\n<ul id=\"assumptions\">\n";
    for (const json& a : fit["assumptions"]) s << "<li>" << Html(Str(a)) << "</li>\n";
    s << "</ul>\n";
  } else {
    s << "<p class=\"big\">Radius: " << ValueSpan("radius-mm", std::nullopt, 1) << " (no screen fit: "
      << Html(Str(fit["failure"])) << ")</p>\n<span hidden>" << ValueSpan("radius-sigma-mm", std::nullopt, 1)
      << ValueSpan("radius-ci95-lo-mm", std::nullopt, 0) << ValueSpan("radius-ci95-hi-mm", std::nullopt, 0)
      << "<span id=\"chosen-model\" data-value=\"\"></span></span>\n";
  }

  if (!warnings.items.empty()) {
    s << "<div id=\"warnings\"><h2>Warnings</h2><ul>\n";
    for (const std::string& w : warnings.items) s << "<li class=\"warning\">" << w << "</li>\n";
    s << "</ul></div>\n";
  } else {
    s << "<div id=\"warnings\" hidden></div>\n";
  }

  // Model selection.
  if (has_fit) {
    s << "<h2>Model selection</h2>\n<p>Every screen model tried, simplest first. The chosen one is the simplest "
         "that the data supports (BIC and held-out error); &#916;BIC is against the lowest BIC.</p>\n"
      << models_table << Figure(RadiusChart(r), options, chart_dir);
    const std::string budget = BudgetTable(fit);
    if (!budget.empty()) {
      s << "<h2>Uncertainty budget</h2>\n<p>Each source of uncertainty of the radius and of the first camera's "
           "position, as a standard uncertainty (GUM: type A from the data's statistics, type B from other "
           "information), combined in quadrature; the radius's sigma above is the combined one.</p>\n"
        << budget;
    }
  }

  // Verification residuals.
  s << "<h2>Verification residuals</h2>\n" << Figure(ResidualHistogram(r), options, chart_dir);

  // Deviations.
  s << "<h2>Deviation map</h2>\n" << Figure(DeviationChart(r), options, chart_dir);

  // Photos.
  s << "<h2>Photos</h2>\n<table id=\"photos\"><thead><tr><th>photo</th><th>status</th><th>detector</th>"
       "<th>detections (flagged)</th><th>verified</th><th>RMS, camera px</th><th>RMS, display px</th>"
       "<th>95%, display px</th><th>verdict</th><th>camera position, mm</th><th>stated viewpoint, mm</th>"
       "</tr></thead><tbody>\n";
  std::map<std::string, const json*> cameras;
  if (has_fit) {
    for (const json& cam : fit["cameras"]) cameras[Str(cam["photo"])] = &cam;
  }
  for (const json& p : inputs["photos"]) {
    const std::string name = Str(p["name"]);
    const bool is_used = p["status"] == "used";
    const json* det = p.contains("detection") ? &p["detection"] : nullptr;
    const json* ver = p.contains("verification") ? &p["verification"] : nullptr;
    const auto cam = cameras.find(name);
    s << fmt::format(
        "<tr data-photo=\"{}\" data-status=\"{}\" data-features=\"{}\" data-rms-px=\"{}\" "
        "data-rms-display-px=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td><td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td></tr>\n",
        Html(name), is_used ? "used" : "rejected", det ? fmt::format("{}", (*det)["features"].get<long>()) : "null",
        Exact(ver ? Opt((*ver)["rms_px"]) : std::nullopt), Exact(ver ? Opt((*ver)["rms_display_px"]) : std::nullopt),
        Html(name), is_used ? "used" : "<b>rejected</b>: " + Html(Str(p.value("reason", json("")))),
        det ? Html(Str((*det)["detector"])) : "&#8212;",
        det ? fmt::format("{} ({})", (*det)["features"].get<long>(), (*det)["flagged"].get<long>()) : "&#8212;",
        ver ? fmt::format("{}", (*ver)["features"].get<long>()) : "&#8212;",
        Fixed(ver ? Opt((*ver)["rms_px"]) : std::nullopt, 3), Fixed(ver ? Opt((*ver)["rms_display_px"]) : std::nullopt, 3),
        Fixed(ver ? Opt((*ver)["p95_display_px"]) : std::nullopt, 3),
        ver ? VerdictCell(VerdictOf(*ver)) : "&#8212;",
        cam != cameras.end() ? Vec3((*cam->second)["position_mm"], 1) : "&#8212;",
        cam != cameras.end() ? Vec3((*cam->second)["stated_viewpoint_mm"], 1) : "&#8212;");
  }
  s << "</tbody></table>\n<p>Camera positions are in the screen frame (origin on the cylinder axis at the height of "
       "the screen's vertical centre, x right, y up, z toward the viewer), from the chosen model's fit.</p>\n";

  size_t index = 0;
  for (const json& p : inputs["photos"]) {
    ++index;
    if (p["status"] != "used") continue;
    const std::string name = Str(p["name"]);
    s << fmt::format("<section id=\"photo-{}\" data-photo=\"{}\">\n<h3>Photo {}: {}</h3>\n", index, Html(name), index,
                     Html(name));
    if (const auto det = p.find("detection"); det != p.end() && !(*det)["notes"].empty()) {
      s << "<p>Detection notes: ";
      bool first = true;
      for (const json& n : (*det)["notes"]) {
        s << (first ? "" : "; ") << Html(Str(n));
        first = false;
      }
      s << "</p>\n";
    }
    const auto png = assets.overlay_png.find(name);
    if (png != assets.overlay_png.end() && IsPng(png->second)) {
      const auto [mime, bytes] = OverlayForPage(png->second, name);
      s << fmt::format(
          "<figure id=\"overlay-{}\"><img class=\"overlay\" src=\"data:{};base64,{}\" alt=\"overlay of {}\">"
          "<figcaption>Overlay of {}: the photo with the expected planar perspective grid (green), the verification "
          "residuals (red) and the screen fit's residuals (blue), both magnified (see the legend in the image).</figcaption>"
          "</figure>\n",
          index, mime, Base64(bytes), Html(name), Html(name));
    } else {
      const auto why = assets.overlay_missing.find(name);
      s << fmt::format("<p class=\"note\" id=\"overlay-{}\">No overlay image: {}.</p>\n", index,
                       Html(why != assets.overlay_missing.end()
                                ? why->second
                                : png != assets.overlay_png.end() ? "the overlay given is not a PNG image"
                                                                  : "no overlay was given"));
    }
    s << Figure(PhotoResidualChart(r, name, index), options, chart_dir) << "</section>\n";
  }

  // Features.
  s << "<h2>Features</h2>\n";
  if (has_fit && fit.contains("outliers") && !fit["outliers"].empty()) {
    s << "<p>Left out of the screen fit as outliers: ";
    bool first = true;
    for (const json& o : fit["outliers"]) {
      s << (first ? "" : ", ") << Html(Str(o["photo"])) << " " << Html(Str(o["id"]));
      first = false;
    }
    s << ".</p>\n";
  }
  s << FeaturesTable(r);

  // Provenance.
  const json& camera = inputs["camera"];
  s << "<h2>Provenance</h2>\n<dl id=\"provenance\">\n";
  s << "<dt>Command</dt><dd><code>" << Html(r.contains("command") ? Str(r["command"]) : "(not recorded)")
    << "</code></dd>\n";
  s << "<dt>Camera model</dt><dd><code>" << Html(Str(camera["path"])) << "</code>: " << Html(Str(camera["lensmodel"]))
    << fmt::format(", {} x {} px", camera["imagersize"][0].get<long>(), camera["imagersize"][1].get<long>())
    << " (fixed in the fit; its uncertainty is not propagated)</dd>\n";
  s << "<dt>Monitor (nominal)</dt><dd>" << Html(Str(monitor["name"]))
    << fmt::format(": {} x {} px, {:.2f} x {:.2f} mm active area, radius ", monitor["resolution"][0].get<long>(),
                   monitor["resolution"][1].get<long>(), monitor["width_mm"].get<double>(),
                   monitor["height_mm"].get<double>())
    << (OptAt(monitor, "radius_mm") ? fmt::format("{:g} mm", *OptAt(monitor, "radius_mm")) : std::string("flat"))
    << (OptAt(monitor, "pixel_pitch_mm") ? fmt::format(", pixel pitch {:.4f} mm", *OptAt(monitor, "pixel_pitch_mm"))
                                         : std::string())
    << "</dd>\n<dt>Photos and patterns</dt><dd><ul>\n";
  for (const json& p : inputs["photos"]) {
    s << "<li><code>" << Html(Str(p["photo"])) << "</code> showing <code>" << Html(Str(p["pattern"]))
      << "</code></li>\n";
  }
  s << "</ul></dd>\n<dt>Software</dt><dd>Page written by curvecheck " << Html(CURVECHECK_VERSION)
    << " (<code>curvecheck report RESULT.json</code> re-writes it); charts drawn with gnuplot from the numbers of "
       "the result.";
  if (const auto t = r.find("timing_ms"); t != r.end()) {
    s << fmt::format(" Analysis time: {} ms (fit {} ms).", Fixed(OptAt(*t, "total"), 0), Fixed(OptAt(*t, "fit"), 0));
  }
  s << "</dd>\n</dl>\n</body>\n</html>\n";
  return s.str();
}

}  // namespace curvecheck
