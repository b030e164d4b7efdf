// Internal to the HTML report (analysis/report.cc): the charts of the page, drawn by gnuplot (core/gnuplot.h) from
// the numbers of result.json.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analysis/report.h"
#include "analysis/report_format.h"
#include "core/gnuplot.h"

namespace curvecheck::report_internal {

// A gnuplot chart: the script reads its data from `files` (name, contents), written into a temporary folder that
// is the script's working folder. A chart with a non-empty `missing` is not drawn; the page says why.
struct Chart {
  std::string id, alt, caption;
  std::string script;
  std::vector<std::pair<std::string, std::string>> files;
  std::string missing;
  double aspect = 0;  // height / width of the plotted area when it is drawn to scale (0: the default chart size)
};

// The <figure> of a chart: drawn by gnuplot into `dir`/<chart id>/ and embedded as a PNG data: URI, or a note
// saying why it is not drawn (chart.missing, charts switched off, or no folder).
std::string Figure(const Chart& chart, const ReportOptions& options, const ChartDataFolder* dir);

// Length of a 2-vector member, nullopt when absent or not two numbers.
std::optional<double> Length(const json& f, const char* key);

// The verification residuals (display px) against the tolerance.
Chart ResidualHistogram(const json& r);

// The radius of every candidate model with its 95% interval.
Chart RadiusChart(const json& r);

// Arc-length position on the screen (x, mm from the centre, right positive; y, mm, up positive) of a display
// point given as u, v in -1..1 (architecture.md).
std::pair<double, double> ScreenMm(double u, double v, double width_mm, double height_mm);

// The deviation map of the chosen model, mm along the surface normal, over the screen.
Chart DeviationChart(const json& r);

// One photo's verification residuals over the display: colour = length in display px (green within the tolerance,
// through yellow to red beyond), arrows = the residual direction, magnified.
Chart PhotoResidualChart(const json& r, const std::string& photo, size_t index);

}  // namespace curvecheck::report_internal
