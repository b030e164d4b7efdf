#include "analysis/report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "analysis/result_reader.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"

#ifndef CURVECHECK_VERSION
#define CURVECHECK_VERSION "unknown"
#endif

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// ---------------------------------------------------------------------------------------------------------------
// Text

// `text` for HTML element content and attribute values: markup characters as entities, control characters other
// than tab and newline (which a result.json string may carry as \u0001) as U+FFFD.
std::string Html(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 && c != '\n' && c != '\t') {
          out += "&#xFFFD;";
        } else {
          out += c;
        }
    }
  }
  return out;
}

std::string Str(const json& v) { return v.is_string() ? v.get<std::string>() : std::string(); }

std::optional<double> Opt(const json& v) {
  if (v.is_number()) return v.get<double>();
  return std::nullopt;
}
// Member `key` of object `o` as a number, nullopt when absent or null.
std::optional<double> OptAt(const json& o, const char* key) {
  const auto it = o.find(key);
  return it == o.end() ? std::nullopt : Opt(*it);
}

// The exact value for a data-value attribute: shortest round-trip decimal, or "null".
std::string Exact(std::optional<double> x) { return x ? fmt::format("{}", *x) : "null"; }

// For reading: fixed decimals, or an em dash when there is no number.
std::string Fixed(std::optional<double> x, int decimals) {
  return x ? fmt::format("{:.{}f}", *x, decimals) : std::string("&#8212;");
}

// An element with an id whose data-value is the exact number and whose text is the rounded one.
std::string ValueSpan(const std::string& id, std::optional<double> x, int decimals) {
  return fmt::format("<span id=\"{}\" class=\"value\" data-value=\"{}\">{}</span>", id, Exact(x), Fixed(x, decimals));
}

// Decimals that show a value with uncertainty `sigma` to about two significant digits of sigma (0..4).
int DecimalsFor(std::optional<double> sigma) {
  if (!sigma || !(*sigma > 0)) return 1;
  return std::clamp(1 - static_cast<int>(std::floor(std::log10(*sigma))), 0, 4);
}

std::string Vec3(const json& v, int decimals) {
  if (!v.is_array() || v.size() != 3) return "&#8212;";
  return fmt::format("({}, {}, {})", Fixed(Opt(v[0]), decimals), Fixed(Opt(v[1]), decimals),
                     Fixed(Opt(v[2]), decimals));
}

// A number for a gnuplot data file ("NaN" for none, which gnuplot leaves out or draws transparent).
std::string Dat(std::optional<double> x) { return x && std::isfinite(*x) ? fmt::format("{}", *x) : "NaN"; }

// A label inside a gnuplot data file: double-quoted, without quotes, comment characters or line breaks of its own.
std::string DatLabel(std::string_view s) {
  std::string out = "\"";
  for (char c : s) out += (c == '"' || c == '\\') ? '\'' : (c == '\n' || c == '\r' || c == '#' ? ' ' : c);
  return out + "\"";
}

// A number rounded to 1, 2 or 5 times a power of ten.
double NiceNumber(double x) {
  if (!(x > 0) || !std::isfinite(x)) return 1;
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  const double m = x / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

bool IsPng(std::string_view bytes) { return bytes.size() > 8 && bytes.substr(0, 8) == "\x89PNG\r\n\x1a\n"; }

// ---------------------------------------------------------------------------------------------------------------
// Charts

// A gnuplot chart: the script reads its data from `files` (name, contents), written into a temporary folder that
// is the script's working folder. A chart with a non-empty `missing` is not drawn; the page says why.
struct Chart {
  std::string id, alt, caption;
  std::string script;
  std::vector<std::pair<std::string, std::string>> files;
  std::string missing;
  double aspect = 0;  // height / width of the plotted area when it is drawn to scale (0: the default chart size)
};

std::string Figure(const Chart& chart, const ReportOptions& options, const fs::path* dir) {
  std::string body;
  if (!chart.missing.empty()) {
    body = fmt::format("<p class=\"note\">No chart: {}</p>", Html(chart.missing));
  } else if (!options.charts || dir == nullptr) {
    body = "<p class=\"note\">Chart not drawn (charts were switched off).</p>";
  } else {
    const fs::path sub = *dir / chart.id;
    fs::create_directories(sub);
    for (const auto& [name, contents] : chart.files) WriteFileAtomic(sub / name, contents);
    // Charts drawn to scale get the height their plot needs (about 260 px of margins and colour box across, 150 down).
    const int height = chart.aspect > 0 ? std::clamp(static_cast<int>(std::lround((options.chart_width_px - 260) *
                                                                                  chart.aspect)) + 150,
                                                     250, 2 * options.chart_height_px)
                                        : options.chart_height_px;
    const std::string png = RenderGnuplot(chart.script, ChartFormat::kPng, {options.chart_width_px, height}, sub);
    body = fmt::format("<img class=\"chart\" src=\"data:image/png;base64,{}\" alt=\"{}\" width=\"{}\" height=\"{}\">",
                       Base64(png), Html(chart.alt), options.chart_width_px, height);
  }
  return fmt::format("<figure id=\"{}\">{}<figcaption>{}</figcaption></figure>\n", Html(chart.id), body,
                     chart.caption);
}

// Length of a 2-vector member, nullopt when absent or not two numbers.
std::optional<double> Length(const json& f, const char* key) {
  const auto it = f.find(key);
  if (it == f.end() || !it->is_array() || it->size() != 2 || !(*it)[0].is_number() || !(*it)[1].is_number()) {
    return std::nullopt;
  }
  return std::hypot((*it)[0].get<double>(), (*it)[1].get<double>());
}

Chart ResidualHistogram(const json& r) {
  Chart c;
  c.id = "chart-residual-histogram";
  c.alt = "histogram of the verification residuals in display pixels against the tolerance";
  const json& v = r["verification"];
  const double tol = v["tolerance_display_px"].get<double>();
  const std::optional<double> p95 = Opt(v["p95_display_px"]);
  std::vector<double> lengths;
  for (const json& f : r["features"]) {
    if (const auto len = Length(f, "residual_display_px")) lengths.push_back(*len);
  }
  c.caption = fmt::format(
      "Verification residuals of all {} features with a display-pixel residual: the distance, in display pixels, "
      "between each detected corner and where an exact planar perspective image of the pattern puts it. Red: the "
      "tolerance ({} display px); black: the 95th percentile ({} display px). The verification passes when the 95th "
      "percentile is within the tolerance.",
      lengths.size(), fmt::format("{:g}", tol), Fixed(p95, 3));
  if (lengths.empty()) {
    c.missing = "no feature has a display-pixel residual";
    return c;
  }
  const double hi = std::max({*std::max_element(lengths.begin(), lengths.end()), 1.5 * tol, p95.value_or(0) * 1.1});
  const int bins = 40;
  const double width = hi / bins;
  std::vector<int> count(bins, 0);
  for (double x : lengths) ++count[static_cast<size_t>(std::clamp(static_cast<int>(x / width), 0, bins - 1))];
  std::string dat = "# bin centre (display px), features\n";
  for (int b = 0; b < bins; ++b) dat += fmt::format("{} {}\n", (b + 0.5) * width, count[static_cast<size_t>(b)]);
  c.files.push_back({"histogram.dat", dat});
  c.script = fmt::format(
      "set title {}\nset xlabel 'verification residual length, display px'\nset ylabel 'features'\n"
      "set style fill solid 0.75 border rgb '#333333'\nset boxwidth {} absolute\nset xrange [0:{}]\n"
      "set yrange [0:*]\nset grid ytics\n"
      "set arrow 1 from {}, graph 0 to {}, graph 1 nohead lc rgb '#d73027' lw 2\n"
      "set label 1 {} at {}, graph 0.95 offset 0.6,0 tc rgb '#d73027'\n",
      GnuplotString(fmt::format("Verification residuals, all photos ({} features)", lengths.size())), width, hi, tol,
      tol, GnuplotString(fmt::format("tolerance {:g}", tol)), tol);
  if (p95) {
    c.script += fmt::format(
        "set arrow 2 from {}, graph 0 to {}, graph 1 nohead lc rgb '#000000' lw 1.5 dt 2\n"
        "set label 2 {} at {}, graph 0.87 offset 0.6,0\n",
        *p95, *p95, GnuplotString(fmt::format("95th percentile {:.3f}", *p95)), *p95);
  }
  c.script += "plot 'histogram.dat' using 1:2 with boxes lc rgb '#4575b4' notitle\n";
  return c;
}

Chart RadiusChart(const json& r) {
  Chart c;
  c.id = "chart-radius";
  c.alt = "radius of every candidate screen model with its 95% interval";
  const json& fit = r["fit"];
  if (fit["model"].is_null()) {
    c.missing = "there is no screen fit";
    return c;
  }
  std::string chosen_dat, other_dat, no_radius;
  int n = 0;
  double lo_all = INFINITY, hi_all = -INFINITY;
  for (const json& k : fit["candidates"]) {
    const std::optional<double> radius = Opt(k["radius_mm"]);
    const std::string name = Str(k["model"]);
    if (!radius) {
      const std::optional<double> bound = OptAt(k, "radius_lower_bound_mm");
      no_radius += fmt::format("{}{}", no_radius.empty() ? "" : "; ", Html(name)) +
                   (bound && *bound > 0 ? fmt::format(" (flat is consistent; |R| above {:.0f} mm at 95%)", *bound)
                                        : name == "flat" ? std::string(" (no curvature by construction)")
                                                         : std::string(" (no radius)"));
      continue;
    }
    ++n;
    const double lo = Opt(k["radius_ci95_mm"][0]).value_or(*radius), hi = Opt(k["radius_ci95_mm"][1]).value_or(*radius);
    lo_all = std::min({lo_all, lo, *radius});
    hi_all = std::max({hi_all, hi, *radius});
    const std::string row = fmt::format("{} {} {} {} {}\n", n, *radius, lo, hi, DatLabel(name));
    (k.value("chosen", false) ? chosen_dat : other_dat) += row;
  }
  c.caption = "Radius of each candidate screen model (mm) with its 95% interval (computed on the curvature 1/R and "
              "inverted, so it can be asymmetric); the chosen model in red, the nominal radius dotted." +
              (no_radius.empty() ? std::string() : " Not shown, no radius as a number: " + no_radius + ".");
  if (n == 0) {
    c.missing = "no candidate model measured a radius as a number";
    return c;
  }
  const std::optional<double> nominal = OptAt(r["inputs"]["monitor"], "radius_mm");
  if (nominal) {
    lo_all = std::min(lo_all, *nominal);
    hi_all = std::max(hi_all, *nominal);
  }
  const double pad = std::max(1.0, 0.1 * (hi_all - lo_all));
  c.files.push_back({"chosen.dat", "# index radius_mm lo95 hi95 model\n" + chosen_dat});
  c.files.push_back({"others.dat", "# index radius_mm lo95 hi95 model\n" + other_dat});
  c.script = fmt::format(
      "set title 'Radius by candidate model (95% intervals)'\nset ylabel 'radius, mm'\nset xrange [0.5:{}]\n"
      "set yrange [{}:{}]\nset grid ytics\nset key top left\nset bars 2\n",
      n + 0.5, lo_all - pad, hi_all + pad);
  if (nominal) {
    c.script += fmt::format(
        "set arrow 1 from graph 0, first {} to graph 1, first {} nohead lc rgb '#555555' dt 3 lw 1.5\n"
        "set label 1 {} at graph 0.99, first {} right offset 0,0.7\n",
        *nominal, *nominal, GnuplotString(fmt::format("nominal {:g} mm", *nominal)), *nominal);
  }
  std::vector<std::string> plots;
  if (!other_dat.empty()) {
    plots.push_back("'others.dat' using 1:2:3:4:xtic(5) with yerrorbars pt 7 ps 1.2 lw 2 lc rgb '#4575b4' "
                    "title 'candidate'");
  }
  if (!chosen_dat.empty()) {
    plots.push_back("'chosen.dat' using 1:2:3:4:xtic(5) with yerrorbars pt 7 ps 1.5 lw 2.5 lc rgb '#d73027' "
                    "title 'chosen'");
  }
  c.script += "plot " + fmt::format("{}", fmt::join(plots, ", ")) + "\n";
  return c;
}

// Arc-length position on the screen (x, mm from the centre, right positive; y, mm, up positive) of a display
// point given as u, v in -1..1 (architecture.md).
std::pair<double, double> ScreenMm(double u, double v, double width_mm, double height_mm) {
  return {u * width_mm / 2, -v * height_mm / 2};
}

Chart DeviationChart(const json& r) {
  Chart c;
  c.id = "chart-deviation-map";
  c.alt = "map of the screen's deviation from the chosen model's base surface, mm";
  const json& monitor = r["inputs"]["monitor"];
  const double w_mm = monitor["width_mm"].get<double>(), h_mm = monitor["height_mm"].get<double>();
  const double nx = monitor["resolution"][0].get<double>(), ny = monitor["resolution"][1].get<double>();
  const auto dev = r.find("deviations");
  std::string map_dat, feat_dat;
  double extent = 0;
  int map_values = 0, feature_values = 0;
  if (dev != r.end()) {
    const json& map = (*dev)["map"];
    const int nu = map["nu"].get<int>(), nv = map["nv"].get<int>();
    const json& mm = map["mm"];
    for (int j = 0; j < nv; ++j) {
      for (int i = 0; i < nu; ++i) {
        const std::optional<double> d = Opt(mm[static_cast<size_t>(j * nu + i)]);
        const auto [x, y] = ScreenMm(-1 + (2 * i + 1.0) / nu, -1 + (2 * j + 1.0) / nv, w_mm, h_mm);
        map_dat += fmt::format("{} {} {}\n", x, y, Dat(d));
        if (d) {
          extent = std::max(extent, std::abs(*d));
          ++map_values;
        }
      }
      map_dat += "\n";
    }
  }
  for (const json& f : r["features"]) {
    const std::optional<double> d = OptAt(f, "deviation_mm");
    const auto px = f.find("display_px");
    if (!d || px == f.end()) continue;
    const double u = 2 * ((*px)[0].get<double>() + 0.5) / nx - 1, v = 2 * ((*px)[1].get<double>() + 0.5) / ny - 1;
    const auto [x, y] = ScreenMm(u, v, w_mm, h_mm);
    feat_dat += fmt::format("{} {} {}\n", x, y, *d);
    extent = std::max(extent, std::abs(*d));
    ++feature_values;
  }
  const std::string note = dev != r.end() && (*dev).contains("note") ? Html(Str((*dev)["note"])) : std::string();
  c.caption = fmt::format(
      "Deviation of the physical screen from the chosen model's base surface along its normal, mm (toward the "
      "viewer positive), over the screen: x is the arc length from the centre, y the height, both mm, seen from the "
      "front. Background: the smoothed map ({} cells with support; grey where no feature supports it); dots: the "
      "{} features' own values.{}",
      map_values, feature_values, note.empty() ? note : " The map, as result.json defines it: " + note + ".");
  c.aspect = h_mm / w_mm;
  if (map_values == 0 && feature_values == 0) {
    c.missing = "the result has no deviations (no screen fit, or no feature supports the map)";
    return c;
  }
  extent = NiceNumber(std::max(extent, 1e-3));
  c.files.push_back({"map.dat", "# x_mm y_mm deviation_mm (rows of the map, blank line between rows)\n" + map_dat});
  c.files.push_back({"features.dat", "# x_mm y_mm deviation_mm\n" + feat_dat});
  c.script = fmt::format(
      "set title 'Deviation from the fitted surface along its normal (mm, toward the viewer +)'\n"
      "set xlabel 'x along the screen (arc length from the centre), mm'\nset ylabel 'y, mm (up)'\n"
      "set size ratio -1\nset xrange [{}:{}]\nset yrange [{}:{}]\nset cbrange [{}:{}]\n"
      "set cblabel 'deviation, mm'\nset palette defined (0 '#2166ac', 0.5 '#f7f7f7', 1 '#b2182b')\n"
      "set object 1 rectangle from graph 0, graph 0 to graph 1, graph 1 behind fillcolor rgb '#c8c8c8' "
      "fillstyle solid noborder\n",
      -w_mm / 2, w_mm / 2, -h_mm / 2, h_mm / 2, -extent, extent);
  std::vector<std::string> plots;
  if (map_values > 0) plots.push_back("'map.dat' using 1:2:3 with image notitle");
  if (feature_values > 0) {
    plots.push_back("'features.dat' using 1:2:3 with points pt 7 ps 0.9 lc palette notitle");
    plots.push_back("'features.dat' using 1:2 with points pt 6 ps 0.9 lc rgb '#333333' notitle");
  }
  c.script += "plot " + fmt::format("{}", fmt::join(plots, ", ")) + "\n";
  return c;
}

// One photo's verification residuals over the display: colour = length in display px (green within the tolerance,
// through yellow to red beyond), arrows = the residual direction, magnified.
Chart PhotoResidualChart(const json& r, const std::string& photo, size_t index) {
  Chart c;
  c.id = fmt::format("chart-photo-{}-residuals", index);
  c.alt = "map of the verification residuals of photo " + photo;
  const json& monitor = r["inputs"]["monitor"];
  const double nx = monitor["resolution"][0].get<double>(), ny = monitor["resolution"][1].get<double>();
  const double tol = r["verification"]["tolerance_display_px"].get<double>();
  std::string dat;
  double longest = 0;
  int n = 0;
  for (const json& f : r["features"]) {
    if (Str(f["photo"]) != photo) continue;
    const auto px = f.find("display_px");
    const auto res = f.find("residual_display_px");
    const std::optional<double> len = Length(f, "residual_display_px");
    if (px == f.end() || !len) continue;
    dat += fmt::format("{} {} {} {} {}\n", (*px)[0].get<double>(), (*px)[1].get<double>(), (*res)[0].get<double>(),
                       (*res)[1].get<double>(), *len);
    longest = std::max(longest, *len);
    ++n;
  }
  // Arrows: the longest residual drawn as 4% of the display's width.
  const double magnify = NiceNumber(0.04 * nx / std::max(longest, 1e-6));
  c.caption = fmt::format(
      "Verification residuals of {} over the display ({} features; display pixel coordinates, top left origin): "
      "colour = residual length in display px (green up to the tolerance of {:g} px, then yellow to red); arrows = "
      "residual direction, magnified {:g} times.",
      Html(photo), n, tol, magnify);
  if (n == 0) {
    c.missing = "no feature of this photo has a display-pixel residual";
    return c;
  }
  c.aspect = ny / nx;
  const double cb_max = std::max(longest, 1.25 * tol);
  const double t = std::min(tol / cb_max, 1.0);
  c.files.push_back({"residuals.dat", "# display_x display_y residual_x residual_y length (display px)\n" + dat});
  c.script = fmt::format(
      "set title {}\nset xlabel 'display x, px'\nset ylabel 'display y, px'\nset size ratio -1\n"
      "set xrange [-0.5:{}]\nset yrange [{}:-0.5]\nset cbrange [0:{}]\nset cblabel 'residual, display px'\n"
      "set palette defined (0 '#1a9850', {} '#a6d96a', {} '#fee08b', 1 '#d73027')\n"
      "set object 1 rectangle from graph 0, graph 0 to graph 1, graph 1 behind fillcolor rgb '#f4f4f4' "
      "fillstyle solid noborder\n"
      "plot 'residuals.dat' using 1:2:5 with points pt 5 ps 1.6 lc palette notitle, "
      "'residuals.dat' using 1:2:($3*{}):($4*{}) with vectors head filled size screen 0.006,20 lw 1.2 "
      "lc rgb '#222222' notitle\n",
      GnuplotString(fmt::format("{}: verification residuals (arrows x{:g})", photo, magnify)), nx - 0.5, ny - 0.5,
      cb_max, t * 0.999, t, magnify, magnify);
  return c;
}

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

std::string StatusCell(bool pass) {
  return pass ? "<span class=\"pass\">PASS</span>" : "<span class=\"fail\">FAIL</span>";
}

std::string ModelsTable(const json& fit, Warnings& warnings) {
  std::optional<double> best_bic;
  for (const json& k : fit["candidates"]) {
    if (const auto b = Opt(k["bic"])) best_bic = best_bic ? std::min(*best_bic, *b) : *b;
  }
  std::ostringstream s;
  s << "<table id=\"models\"><thead><tr><th>model</th><th>parameters</th><th>RMS, px</th><th>held-out RMS, px</th>"
       "<th>noise, px</th><th>BIC</th><th>&#916;BIC</th><th>radius &#177; &#963;, mm</th><th>95% interval, mm</th>"
       "<th>other parameters</th><th>converged</th><th>notes</th></tr></thead><tbody>\n";
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
    s << fmt::format(
        "<tr data-model=\"{}\" data-chosen=\"{}\" data-radius-mm=\"{}\"{}><td>{}{}</td><td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td><td>{}</td><td>{}</td>"
        "</tr>\n",
        Html(name), chosen ? "true" : "false", Exact(radius), chosen ? " class=\"chosen\"" : "", Html(name),
        chosen ? " (chosen)" : "", k["parameters"].get<long>(), Fixed(Opt(k["rms_px"]), 4),
        Fixed(Opt(k["heldout_rms_px"]), 4), Fixed(Opt(k["noise_px"]), 4), Fixed(bic, 1),
        bic && best_bic ? fmt::format("{:.1f}", *bic - *best_bic) : "&#8212;", radius_text, interval,
        extra.empty() ? "&#8212;" : extra, converged ? "yes" : "<b>no</b>", fmt::format("{}", fmt::join(notes, "; ")));
  }
  s << "</tbody></table>\n";
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
        assets.overlay_png[name] = std::move(bytes);
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
  const fs::path* chart_dir = dir ? &dir->path() : nullptr;

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
  s << "<h2>Summary</h2>\n<p>Verification: <span id=\"verdict\" class=\"verdict " << (pass ? "pass" : "fail")
    << "\" data-pass=\"" << (pass ? "true" : "false") << "\">" << (pass ? "PASS" : "FAIL") << "</span></p>\n";
  s << "<p>95% of the features are within " << ValueSpan("p95-display-px", Opt(v["p95_display_px"]), 3)
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
        ver ? StatusCell((*ver)["pass"].get<bool>()) : "&#8212;",
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
      s << fmt::format(
          "<figure id=\"overlay-{}\"><img class=\"overlay\" src=\"data:image/png;base64,{}\" alt=\"overlay of {}\">"
          "<figcaption>Overlay of {}: the photo with the expected planar perspective grid (green), the verification "
          "residuals (red) and the screen fit's residuals (blue), both magnified (see the legend in the image).</figcaption>"
          "</figure>\n",
          index, Base64(png->second), Html(name), Html(name));
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
