#include "experiments/sweep_table.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>

#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "experiments/trial_outcome.h"

namespace curvecheck::experiments {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  for (char c : line) {
    if (c == ',') {
      cells.push_back(cell);
      cell.clear();
    } else if (c != '\r') {
      cell += c;
    }
  }
  cells.push_back(cell);
  return cells;
}

// Rows of one method, ordered by the factors' grid indices.
std::vector<size_t> MethodRows(const SweepTable& t, const std::string& method) {
  std::vector<size_t> rows;
  for (size_t r = 0; r < t.rows.size(); ++r) {
    if (t.Str(r, "method") == method) rows.push_back(r);
  }
  std::sort(rows.begin(), rows.end(), [&](size_t a, size_t b) { return t.Num(a, "index") < t.Num(b, "index"); });
  return rows;
}

std::string Outcome(const SweepTable& t, size_t r) {
  const std::string reason = t.Str(r, "reason");
  return reason.empty() ? std::string("ok") : reason;
}

// "a..b: outcome" runs along an ordered list of rows, and the successful ranges.
std::string Segments(const SweepTable& t, const std::vector<size_t>& rows, const std::string& factor,
                     std::string* ok_ranges) {
  std::string s;
  ok_ranges->clear();
  for (size_t i = 0; i < rows.size();) {
    size_t j = i;
    while (j + 1 < rows.size() && Outcome(t, rows[j + 1]) == Outcome(t, rows[i])) ++j;
    const double a = t.Num(rows[i], factor), b = t.Num(rows[j], factor);
    const std::string range = i == j ? fmt::format("{:g}", a) : fmt::format("{:g}..{:g}", a, b);
    s += fmt::format("{}{} {}", s.empty() ? "" : " | ", range, Outcome(t, rows[i]));
    if (Outcome(t, rows[i]) == "ok") *ok_ranges += (ok_ranges->empty() ? "" : ", ") + (i == j ? range : "[" + range + "]");
    i = j + 1;
  }
  return s;
}

// "2 render_refused, 1 not_found": the failures among `rows` by reason ("" when none failed).
std::string FailureCounts(const SweepTable& t, const std::vector<size_t>& rows) {
  std::map<std::string, int> reasons;
  for (size_t r : rows) {
    if (Outcome(t, r) != "ok") ++reasons[Outcome(t, r)];
  }
  std::string s;
  for (const auto& [reason, n] : reasons) s += fmt::format("{}{} {}", s.empty() ? "" : ", ", n, reason);
  return s;
}

// What a chart of `rows` says when none of them succeeded ("" when one did): an all-failing sweep is a result,
// and its chart must say so rather than look like an empty plot.
std::string NoSuccessNote(const SweepTable& t, const std::vector<size_t>& rows) {
  for (size_t r : rows) {
    if (Outcome(t, r) == "ok") return "";
  }
  return fmt::format("no point succeeded: {} of {} failed ({})", rows.size(), rows.size(), FailureCounts(t, rows));
}

std::string Stats(const SweepTable& t, const std::vector<size_t>& rows) {
  std::map<std::string, int> reasons;
  int ok = 0;
  double worst_p95 = 0, worst_z = 0, worst_err = 0;
  for (size_t r : rows) {
    const std::string o = Outcome(t, r);
    if (o == "ok") {
      ++ok;
      worst_p95 = std::max(worst_p95, t.Num(r, "verification_p95_display_px"));
      const double z = std::abs(t.Num(r, "radius_error_sigmas")), e = std::abs(t.Num(r, "radius_error_mm"));
      if (std::isfinite(z)) worst_z = std::max(worst_z, z);
      if (std::isfinite(e)) worst_err = std::max(worst_err, e);
    } else {
      ++reasons[o];
    }
  }
  std::string s = fmt::format("{} of {} points succeed", ok, rows.size());
  for (const auto& [reason, n] : reasons) s += fmt::format(", {} {}", n, reason);
  if (ok > 0) {
    s += fmt::format("; over the successes: worst verification p95 {:.3f} display px, worst |radius error| {:.1f} mm "
                     "= {:.2f} sigma",
                     worst_p95, worst_err, worst_z);
  }
  return s;
}

}  // namespace

std::vector<std::string> SweepReasons() {
  std::vector<std::string> names;
  for (TrialOutcome o : FailureOutcomes()) names.emplace_back(TrialOutcomeName(o));
  return names;
}

char ReasonLetter(const std::string& reason) { return TrialOutcomeLetter(ParseTrialOutcome(reason)); }

int SweepTable::Col(const std::string& name) const {
  const auto it = std::find(header.begin(), header.end(), name);
  return it == header.end() ? -1 : static_cast<int>(it - header.begin());
}

std::string SweepTable::Str(size_t row, const std::string& name) const {
  const int c = Col(name);
  return c < 0 ? std::string() : rows.at(row).at(static_cast<size_t>(c));
}

double SweepTable::Num(size_t row, const std::string& name) const {
  const std::string s = Str(row, name);
  if (s.empty()) return kNaN;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  return end && *end == '\0' ? v : kNaN;
}

std::string SweepTable::ToCsv() const {
  std::string s;
  for (size_t i = 0; i < header.size(); ++i) s += (i ? "," : "") + header[i];
  s += "\n";
  for (const auto& row : rows) {
    for (size_t i = 0; i < row.size(); ++i) s += (i ? "," : "") + row[i];
    s += "\n";
  }
  return s;
}

SweepTable SweepTable::FromCsv(const std::string& text, const std::string& path,
                               const std::vector<std::string>& required, const std::string& producer) {
  SweepTable t;
  const std::string file = std::filesystem::path(path).filename().string();
  std::istringstream in(text);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line == "\r") continue;
    std::vector<std::string> cells = SplitCsvLine(line);
    if (t.header.empty()) {
      t.header = std::move(cells);
      bool complete = t.Col("index") == 0;
      for (const std::string& c : required) complete = complete && t.Col(c) >= 0;
      if (!complete) {
        std::string names = "index";
        for (const std::string& c : required) names += ", " + c;
        throw Error(path, fmt::format("is not a {}: its header lacks one of {}", file, names),
                    fmt::format("give the {} that `{}` wrote", file, producer));
      }
      continue;
    }
    if (cells.size() != t.header.size()) {
      throw Error(path, fmt::format("line {} has {} cells for {} columns", number, cells.size(), t.header.size()),
                  fmt::format("give the {} that `{}` wrote, unedited", file, producer));
    }
    t.rows.push_back(std::move(cells));
  }
  if (t.header.empty()) throw Error(path, "is empty", fmt::format("give the {} that `{}` wrote", file, producer));
  return t;
}

std::vector<std::string> SweepColumns(const std::vector<std::string>& factor_names) {
  std::vector<std::string> c = {"index", "method"};
  c.insert(c.end(), factor_names.begin(), factor_names.end());
  for (const char* name :
       {"seed", "success", "reason", "verification_pass", "verification_p95_display_px",
        "verification_rms_display_px", "features", "chosen_model", "fit_status", "radius_mm", "radius_sigma_mm",
        "radius_ci95_lo_mm", "radius_ci95_hi_mm", "true_radius_mm", "radius_error_mm", "radius_error_sigmas",
        "truth_in_ci95", "render_ms", "photo_ms", "detect_ms", "verify_ms", "fit_ms", "point_ms",
        "detail"}) {
    c.emplace_back(name);
  }
  return c;
}

std::string Cell(double v, int digits) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format("{:.{}g}", v, digits);
}

std::string CellText(const std::string& text) {
  std::string s = text;
  for (char& c : s) {
    if (c == ',') c = ';';
    if (c == '"' || c == '\n' || c == '\r') c = ' ';
  }
  return s;
}

std::string SweepSummary(const SweepTable& t, const std::vector<SweepFactor>& factors,
                         const std::vector<std::string>& methods, double tolerance_display_px) {
  std::string s = fmt::format(
      "success = verification passes (95% of features within {:g} display px) and the cylinder fit gives an "
      "observable radius\n",
      tolerance_display_px);
  for (const std::string& method : methods) {
    const std::vector<size_t> rows = MethodRows(t, method);
    s += fmt::format("\n{}: {}\n", method, Stats(t, rows));
    if (rows.empty()) continue;
    if (factors.size() == 1) {
      std::string ok;
      const std::string seg = Segments(t, rows, factors[0].name, &ok);
      s += fmt::format("  {}: {}\n", factors[0].name, seg);
      s += fmt::format("  boundary: {} succeeds for {} in {}\n", method, factors[0].name, ok.empty() ? "none" : ok);
    } else {
      const SweepFactor& f1 = factors[0];
      const SweepFactor& f2 = factors[1];
      s += fmt::format("  map (rows {}, columns {} = {:g}..{:g}; . ok, N not_found, A ambiguous, T too few features, "
                       "V verification failed, I ill-conditioned fit, F fit failed, R render refused, X rejected, "
                       "E error, blank: not in these shards):\n",
                       f1.name, f2.name, f2.Value(0), f2.Value(f2.count - 1));
      std::map<std::pair<int, int>, size_t> at;
      for (size_t r : rows) {
        const int index = static_cast<int>(t.Num(r, "index")) % (f1.count * f2.count);
        at[{index / f2.count, index % f2.count}] = r;
      }
      for (int i = 0; i < f1.count; ++i) {
        std::string line;
        std::vector<size_t> along;
        for (int j = 0; j < f2.count; ++j) {
          const auto it = at.find({i, j});
          line += it == at.end() ? ' ' : ReasonLetter(Outcome(t, it->second));
          if (it != at.end()) along.push_back(it->second);
        }
        std::string ok;
        Segments(t, along, f2.name, &ok);
        s += fmt::format("  {:>10g} |{}|  ok for {} in {}\n", f1.Value(i), line, f2.name, ok.empty() ? "none" : ok);
      }
    }
  }
  return s;
}

std::vector<std::filesystem::path> WriteSweepCharts(const SweepTable& t, const std::vector<SweepFactor>& factors,
                                                    const std::vector<std::string>& methods,
                                                    double tolerance_display_px, const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> charts;
  const std::vector<std::string> reasons = SweepReasons();
  for (const std::string& method : methods) {
    const std::vector<size_t> rows = MethodRows(t, method);
    if (rows.empty()) continue;
    const std::string base = "sweep-" + method;
    // p95_or_floor: the p95, or the floor line for a point without one (gnuplot skips a point whose plotted
    // column is NaN, so the floor is written here rather than chosen in the script).
    std::string data = "# " + factors[0].name + (factors.size() > 1 ? " " + factors[1].name : std::string()) +
                       " p95_display_px radius_error_mm radius_sigma_mm reason_code letter p95_or_floor\n";
    double lowest = 0.5 * tolerance_display_px, highest = 0;
    for (size_t r : rows) {
      const double p95 = t.Num(r, "verification_p95_display_px");
      if (std::isfinite(p95) && p95 > 0) lowest = std::min(lowest, p95);
      if (std::isfinite(p95) && p95 > 0) highest = std::max(highest, p95);
    }
    const double floor_y = std::pow(10.0, std::floor(std::log10(lowest)) - 1);
    bool any_p95 = false, all_p95 = true, any_radius = false;
    for (size_t r : rows) {
      const std::string o = Outcome(t, r);
      const auto it = std::find(reasons.begin(), reasons.end(), o);
      const int code = o == "ok" ? 0 : 1 + static_cast<int>(it - reasons.begin());
      data += Cell(t.Num(r, factors[0].name)) + " ";
      if (factors.size() > 1) data += Cell(t.Num(r, factors[1].name)) + " ";
      const double p95 = t.Num(r, "verification_p95_display_px");
      const bool has_p95 = std::isfinite(p95) && p95 > 0;
      any_p95 = any_p95 || has_p95;
      all_p95 = all_p95 && has_p95;
      any_radius = any_radius || std::isfinite(t.Num(r, "radius_error_mm"));
      data += fmt::format("{} {} {} {} {} {}\n", Cell(has_p95 ? p95 : kNaN), Cell(t.Num(r, "radius_error_mm")),
                          Cell(t.Num(r, "radius_sigma_mm")), code, ReasonLetter(o), Cell(has_p95 ? p95 : floor_y));
    }
    WriteFileAtomic(dir / (base + ".dat"), data);
    std::string script;
    const std::string none_ok = NoSuccessNote(t, rows);
    const std::string title = fmt::format("curvecheck sweep: {} ({} points){}", method, rows.size(),
                                          none_ok.empty() ? "" : "\n" + none_ok);
    if (factors.size() == 1) {
      const std::string& x = factors[0].name;
      script += "set multiplot layout 2,1 title " + GnuplotString(title) + "\n";
      script += "set grid\nset key outside right\nset logscale y\nset lmargin 12\nset rmargin 24\n"
                "set offsets graph 0.03, graph 0.03, 0, 0\n";
      script += fmt::format("set xlabel {}\nset ylabel {}\n", GnuplotString(x),
                            GnuplotString(all_p95 ? "verification p95, display px"
                                                  : "verification p95, display px (bottom line: no p95)"));
      // The upper end at least twice the tolerance, so that its line shows even when every p95 is far below it.
      script += fmt::format("set yrange [{}:{}]\n", floor_y * 0.5, Cell(std::max(2 * tolerance_display_px, 1.5 * highest)));
      script += fmt::format("set arrow from graph 0, first {0} to graph 1, first {0} nohead dt 2 lc rgb 'gray40'\n",
                            tolerance_display_px);
      script += fmt::format("plot '{}.dat' using 1:($5==0?$2:1/0) with linespoints pt 7 lc rgb '#1a9850' title 'ok'",
                            base);
      for (size_t k = 0; k < reasons.size(); ++k) {
        bool present = false;
        for (size_t r : rows) present = present || Outcome(t, r) == reasons[k];
        if (!present) continue;
        // Failures without a p95 (nothing detected) sit on the floor line.
        script += fmt::format(", '' using 1:($5=={0}?$7:1/0) with points pt {1} ps 1.6 title {2}", k + 1,
                              4 + static_cast<int>(k), GnuplotString(reasons[k]));
      }
      script += "\nunset logscale y\nunset arrow\nset yrange [*:*]\n";
      script += "set ylabel 'cylinder radius error, mm (1 sigma bars)'\n";
      if (any_radius) {
        script += fmt::format(
            "plot '{}.dat' using 1:($5==0?$3:1/0):4 with yerrorbars pt 7 lc rgb '#1a9850' title 'ok', "
            "'' using 1:($5!=0?$3:1/0):4 with yerrorbars pt 6 lc rgb '#d73027' title 'failed point', "
            "0 with lines dt 2 lc rgb 'gray40' notitle\n",
            base);
      } else {
        // Nothing to plot (gnuplot refuses a plot whose points are all undefined): a labelled empty panel.
        const SweepFactor& f = factors[0];
        const double pad = f.stop != f.start ? 0.03 * std::abs(f.stop - f.start) : std::max(1.0, 0.05 * std::abs(f.start));
        script += fmt::format("set xrange [{}:{}]\nset yrange [-1:1]\nset ytics ('0' 0)\n",
                              Cell(std::min(f.start, f.stop) - pad), Cell(std::max(f.start, f.stop) + pad));
        script += "set label 1 " + GnuplotString("no radius: no point gave a cylinder fit") +
                  " at graph 0.5, graph 0.5 center\nplot NaN notitle\n";
      }
      script += "unset multiplot\n";
    } else {
      const SweepFactor& f1 = factors[0];
      const SweepFactor& f2 = factors[1];
      const double dx = f1.count > 1 ? std::abs(f1.stop - f1.start) / (f1.count - 1) : 1.0;
      const double dy = f2.count > 1 ? std::abs(f2.stop - f2.start) / (f2.count - 1) : 1.0;
      // Success boundary: a segment between every two neighbouring cells where success differs.
      std::map<std::pair<int, int>, bool> ok;
      for (size_t r : rows) {
        const int index = static_cast<int>(t.Num(r, "index")) % (f1.count * f2.count);
        ok[{index / f2.count, index % f2.count}] = Outcome(t, r) == "ok";
      }
      std::string segs = "# x y dx dy: success boundary segments\n";
      for (const auto& [ij, good] : ok) {
        const auto right = ok.find({ij.first + 1, ij.second});
        if (right != ok.end() && right->second != good) {
          const double x = 0.5 * (f1.Value(ij.first) + f1.Value(ij.first + 1)), y = f2.Value(ij.second);
          segs += fmt::format("{} {} 0 {}\n", Cell(x), Cell(y - 0.5 * dy), Cell(dy));
        }
        const auto up = ok.find({ij.first, ij.second + 1});
        if (up != ok.end() && up->second != good) {
          const double y = 0.5 * (f2.Value(ij.second) + f2.Value(ij.second + 1)), x = f1.Value(ij.first);
          segs += fmt::format("{} {} {} 0\n", Cell(x - 0.5 * dx), Cell(y), Cell(dx));
        }
      }
      WriteFileAtomic(dir / (base + "-boundary.dat"), segs);
      script += "set title " + GnuplotString(title + "\ncolour: verification p95 (display px, log), grey: no p95; "
                                             "letters: failure reason; black line: success boundary") + "\n";
      script += fmt::format("set xlabel {}\nset ylabel {}\n", GnuplotString(f1.name), GnuplotString(f2.name));
      script += "set logscale cb\nset cblabel 'verification p95, display px'\nset palette defined (0 '#1a9850', 1 "
                "'#fee08b', 2 '#d73027')\n";
      script += fmt::format("set cbrange [{}:*]\n", floor_y * 10);
      script += fmt::format("set xrange [{}:{}]\nset yrange [{}:{}]\n", std::min(f1.start, f1.stop) - 0.5 * dx,
                            std::max(f1.start, f1.stop) + 0.5 * dx, std::min(f2.start, f2.stop) - 0.5 * dy,
                            std::max(f2.start, f2.stop) + 0.5 * dy);
      script += "set style fill solid 1.0 noborder\nunset key\n";
      if (f1.count > 1) script += fmt::format("set xtics {}, {}\n", Cell(std::min(f1.start, f1.stop)), Cell(dx));
      if (f2.count > 1) script += fmt::format("set ytics {}, {}\n", Cell(std::min(f2.start, f2.stop)), Cell(dy));
      // Cells without a p95 are grey; the palette layer only when some cell has one (its colour range would
      // have no data otherwise).
      if (!any_p95) script += "unset colorbox\n";
      script += fmt::format(
          "plot '{0}.dat' using 1:2:({1}):({2}) with boxxyerror fc rgb '#d9d9d9', {3}"
          "'' using 1:2:($6!=0?stringcolumn(7):'') with labels font ',16' tc rgb 'black', "
          "'{0}-boundary.dat' using 1:2:3:4 with vectors nohead lw 3 lc rgb 'black'\n",
          base, Cell(0.5 * dx), Cell(0.5 * dy),
          any_p95 ? fmt::format("'' using 1:2:({}):({}):3 with boxxyerror fc palette, ", Cell(0.5 * dx), Cell(0.5 * dy))
                  : std::string());
    }
    const std::filesystem::path png = dir / (base + ".png");
    WriteGnuplotChart(png, script, ChartSize{1200, factors.size() == 1 ? 900 : 800});
    charts.push_back(png);
  }
  return charts;
}

}  // namespace curvecheck::experiments
