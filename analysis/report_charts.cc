#include "analysis/report_charts.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "analysis/report_format.h"
#include "core/file_io.h"
#include "core/gnuplot.h"

namespace curvecheck::report_internal {

namespace fs = std::filesystem;

std::string Figure(const Chart& chart, const ReportOptions& options, const ChartDataFolder* dir) {
  std::string body;
  if (!chart.missing.empty()) {
    body = fmt::format("<p class=\"note\">No chart: {}</p>", Html(chart.missing));
  } else if (!options.charts || dir == nullptr) {
    body = "<p class=\"note\">Chart not drawn (charts were switched off).</p>";
  } else {
    const fs::path sub = dir->Subfolder(chart.id);
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

}  // namespace curvecheck::report_internal
