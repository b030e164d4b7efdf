// Charts through gnuplot (Debian's gnuplot-nox), the one plotting tool of the project: benches, sweeps and the
// HTML report all draw with it, so every chart can be re-drawn by hand from the script and data it leaves behind.
//
// A chart is a gnuplot script without `set terminal` / `set output` (the caller picks the format) that reads its
// data from files named in the script. RenderGnuplot adds the terminal, runs gnuplot and returns the image bytes;
// WriteGnuplotChart also leaves the script beside the image so it can be re-run.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/file_io.h"

namespace curvecheck {

enum class ChartFormat { kPng, kSvg };

struct ChartSize {
  int width = 1200, height = 800;  // pixels (PNG) or SVG user units
};

// `text` as a double-quoted gnuplot string literal, quotes and backslashes escaped and line breaks as \n.
std::string GnuplotString(std::string_view text);

// Runs gnuplot on `script` (the terminal and output lines are prepended) and returns the image file's bytes.
// Data files the script names must exist. The script runs from `working_dir` when it is non-empty, so relative
// data paths resolve there. Throws Error (with gnuplot's own message) if gnuplot is missing or fails, or if it
// writes no image.
std::string RenderGnuplot(std::string_view script, ChartFormat format, ChartSize size = {},
                          const std::filesystem::path& working_dir = {});

// Draws `script` into `image` (format from its extension: .png or .svg) and writes the complete script (terminal
// and output included) to the same name with extension .gp, both atomically. Returns the .gp path.
std::filesystem::path WriteGnuplotChart(const std::filesystem::path& image, std::string_view script,
                                        ChartSize size = {});

// The Pareto front of points to minimise in both coordinates (time and error, say): front[i] is true when no
// other point is at most as large in both and smaller in one. Non-finite points are never on the front and never
// dominate.
std::vector<bool> ParetoFront(const std::vector<double>& cost, const std::vector<double>& error);

// A private temporary folder for a chart's script and data files (curvecheck_chart_XXXXXX), removed with
// everything in it when the object goes. Throws Error if it cannot be created (the message names `purpose`).
class ChartDataFolder : public TempFolder {
 public:
  explicit ChartDataFolder(const std::string& purpose = "gnuplot") : TempFolder("curvecheck_chart", purpose) {}
};

// Base64 (RFC 4648, with padding) of `bytes`: for data: URIs in self-contained HTML.
std::string Base64(std::string_view bytes);

}  // namespace curvecheck
