// The table of a stability sweep (`curvecheck sweep`, issue 7 items 3-4) and what is derived from it: sweep.csv
// reading and writing (SweepTable, Cell, CellText: also the tables of `bench validity`), the failure boundaries as text, and the per-method failure-map charts. Shared by a sweep
// run and `sweep merge`, so that a merged sweep reports exactly what an unsharded run would.
//
// sweep.csv: one row per grid point, columns `index, method, <factor 1>[, <factor 2>], seed, success, reason,
// ...` (SweepColumns()). Cells hold no commas or quotes (free text has them replaced), so the file is plain
// comma-separated. Columns ending in `_ms` are wall times: they differ from run to run (render_ms is 0 where the
// display image came from the render cache, which depends on the order the workers took the points); everything
// else is deterministic for a given grid point.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "experiments/sweep_factor.h"

namespace curvecheck::experiments {

// The failure reasons of the `reason` column, in pipeline order (TrialOutcomeName of FailureOutcomes(); a point
// gets the first that applies; "" on success).
std::vector<std::string> SweepReasons();
// The map letter of a `reason` cell (TrialOutcomeLetter; '.' for success, 'E' for a name it does not know).
char ReasonLetter(const std::string& reason);

struct SweepTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  int Col(const std::string& name) const;  // -1 when absent
  std::string Str(size_t row, const std::string& name) const;
  double Num(size_t row, const std::string& name) const;  // NaN when absent or not a number

  std::string ToCsv() const;
  // Throws Error naming `path` for a malformed file: a header without "index" first and every `required` column,
  // or a row of another length. `producer` names the command that writes such files, for the fix.
  static SweepTable FromCsv(const std::string& text, const std::string& path,
                            const std::vector<std::string>& required = {"method", "reason"},
                            const std::string& producer = "curvecheck sweep");
};

// The columns of sweep.csv for these factor names.
std::vector<std::string> SweepColumns(const std::vector<std::string>& factor_names);

// A number for a cell: `digits` significant digits ("%.6g" by default), "nan" for NaN, "inf"/"-inf".
std::string Cell(double v, int digits = 6);
// Free text for a cell: commas become ';', quotes and line breaks become spaces.
std::string CellText(const std::string& text);

// The failure boundaries per method as text: for one factor, the runs of successful values and the failures
// beyond them with their reasons; for two, a letter map (rows: factor 1, columns: factor 2) and the successful
// range of factor 2 for each value of factor 1. `factors` in grid order; rows in any order.
std::string SweepSummary(const SweepTable& table, const std::vector<SweepFactor>& factors,
                         const std::vector<std::string>& methods, double tolerance_display_px);

// Writes `dir`/sweep-<method>.png (+ .gp and .dat) for every method: 1 factor: verification p95 (display px,
// log) and the radius error with its 1-sigma bar against the factor, failures marked by reason; 2 factors: a
// heatmap of the p95 (grey where a cell has none) with failed cells lettered by reason and the success boundary
// drawn. A method none of whose points succeeded still gets its chart, titled "no point succeeded: N of N failed
// (reasons)"; a panel with nothing to plot is drawn empty with a label saying why. Returns the PNGs.
std::vector<std::filesystem::path> WriteSweepCharts(const SweepTable& table, const std::vector<SweepFactor>& factors,
                                                    const std::vector<std::string>& methods,
                                                    double tolerance_display_px, const std::filesystem::path& dir);

}  // namespace curvecheck::experiments
