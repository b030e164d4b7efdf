#include "experiments/bench_calibrate.h"

#include <fmt/format.h>

#include <algorithm>

#include "calibrate/calibrate.h"
#include "calibrate/truth_comparison.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/stats.h"
#include "experiments/machine_info.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;

struct Row {
  std::string label, lensmodel;
  int nparams = 0;
  double median_s = 0, min_s = 0, solve_s = 0;
  double residual_rms_px = 0;
  TruthComparison truth;
  bool pareto = false;
};

std::string SplinedModel(int nx, int width, int height) {
  const int ny = std::max(4, static_cast<int>(std::lround(nx * double(height) / width)));
  return fmt::format("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx={}_Ny={}_fov_x_deg=auto", nx, ny);
}

std::string Csv(const std::vector<Row>& rows, const std::string& header) {
  std::string s = header;
  s += "label,lensmodel,params,median_s,min_s,median_solve_s,residual_rms_px,rms_px,observed_rms_px,"
       "confident_rms_px,confident_points,grid_points,sigma_rms_px,within_3sigma,pareto\n";
  for (const Row& r : rows) {
    const TruthComparison& t = r.truth;
    s += fmt::format("{},{},{},{:.4f},{:.4f},{:.4f},{:.5f},{:.5f},{:.5f},{:.5f},{},{},{:.5f},{},{}\n",
                     r.label, r.lensmodel, r.nparams, r.median_s, r.min_s, r.solve_s, r.residual_rms_px,
                     t.rms_px, t.observed_rms_px, t.confident_rms_px, t.confident_points,
                     t.points + t.no_sigma, t.rms_sigma_px, t.within_3sigma, r.pareto ? 1 : 0);
  }
  return s;
}

// Error against the truth (RMS over the imager) against the median calibration time, log-log; every point
// labelled; the reported uncertainty (RMS) of each model as an open marker on the same vertical; the Pareto
// front as a line.
std::string ChartScript(const std::string& csv, const std::string& title) {
  return fmt::format(R"(set datafile separator ','
set title {title}
set logscale xy
set xlabel 'median calibration time (s): mrcal seed + solve + uncertainty, Python start included'
set ylabel 'projection error vs the true lens, RMS over the imager (px)'
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set key outside right top
set format y '%g'
plot \
  '{csv}' skip 1 using 4:8 with points pt 7 ps 1.6 lc rgb '#1f77b4' title 'recovered - truth', \
  '{csv}' skip 1 using 4:13 with points pt 6 ps 1.6 lc rgb '#2ca02c' title 'reported sigma (RMS)', \
  '{csv}' skip 1 using 4:8:1 with labels offset 0.8,0.7 left font ',9' notitle, \
  '< grep ",1$" {csv} | sort -t, -k4 -g' using 4:8 with lines lw 2 lc rgb '#cc0000' title 'Pareto front'
)",
                     fmt::arg("title", GnuplotString(title)), fmt::arg("csv", csv));
}

}  // namespace

void BenchCalibrateOptions::Check() const {
  CheckCount(runs, 1, 50, "--runs");
  CheckCount(views, 6, 200, "--views");
}

void RunBenchCalibrate(const BenchCalibrateOptions& a, const fs::path& dir, std::ostream& log) {
  a.Check();
  SyntheticBoardOptions o;
  o.camera = StrongOpencv8Lens();
  o.views = a.views;
  o.seed = a.seed;
  const std::string machine = DescribeMachine();
  const std::string title = fmt::format(
      "bench calibrate: {} views of a synthetic flat board (seed {}), true lens {} {}x{} "
      "(StrongOpencv8Lens); "
      "median of {} runs\n{}",
      o.views, o.seed, o.camera.lensmodel, o.camera.width, o.camera.height, a.runs, machine);
  log << title << "\n" << std::flush;
  const SyntheticBoardSet set = MakeSyntheticBoardSet(o);
  std::vector<ChessboardDetection> detections;
  for (size_t k = 0; k < set.views.size(); ++k) {
    detections.push_back(DetectChessboard(set.views[k].photo, set.board, ChessboardOptions()));
    detections.back().photo = fmt::format("view{}", k);
  }

  std::vector<std::pair<std::string, std::string>> models = {{"OPENCV4", "LENSMODEL_OPENCV4"},
                                                             {"OPENCV8", "LENSMODEL_OPENCV8"}};
  for (int nx : a.splined_nx) {
    const std::string m = SplinedModel(nx, o.camera.width, o.camera.height);
    models.emplace_back(
        fmt::format("splined {}x{}", nx, m.substr(m.find("Ny=") + 3, m.find("_fov") - m.find("Ny=") - 3)), m);
  }
  log << fmt::format("{:<14} {:>6} {:>9} {:>9} {:>9} {:>10} {:>10} {:>11} {:>11} {:>9} {:>9}\n", "model",
                     "params", "median s", "solve s", "resid px", "err px", "err obs px", "err conf px",
                     "conf points", "sigma px", "in 3 sig");
  std::vector<Row> rows;
  for (const auto& [label, lensmodel] : models) {
    CalibrateOptions options;
    options.lensmodels = {lensmodel};
    options.cross_validate = false;
    Row row;
    row.label = label;
    std::vector<double> times, solves;
    CalibrationResult result;
    for (int i = 0; i < a.runs; ++i) {
      result = Calibrate(detections, set.board, options);
      times.push_back(result.optimize_s);
      solves.push_back(result.Chosen().solve_s);
    }
    const CandidateResult& c = result.Chosen();
    if (!c.error.empty()) {
      log << fmt::format("{:<14} failed: {}\n", label, c.error);
      continue;
    }
    row.lensmodel = c.lensmodel;
    row.nparams = c.nparams;
    row.median_s = Median(times);
    row.min_s = *std::min_element(times.begin(), times.end());
    row.solve_s = Median(solves);
    row.residual_rms_px = c.rms_px;
    row.truth = CompareWithTruth(o.camera, set, detections, result, c, options.distance_mm);
    const TruthComparison& t = row.truth;
    log << fmt::format(
               "{:<14} {:>6} {:>9.2f} {:>9.2f} {:>9.4f} {:>10.4f} {:>10.4f} {:>11.4f} {:>7}/{:<3} "
               "{:>9.4f} {:>5}/{:<3}\n",
               label, row.nparams, row.median_s, row.solve_s, row.residual_rms_px, t.rms_px,
               t.observed_rms_px, t.confident_rms_px, t.confident_points, t.points + t.no_sigma,
               t.rms_sigma_px, t.within_3sigma, t.points)
        << std::flush;
    rows.push_back(std::move(row));
  }
  std::vector<double> cost, error;
  for (const Row& r : rows) {
    cost.push_back(r.median_s);
    error.push_back(r.truth.rms_px);
  }
  const std::vector<bool> front = ParetoFront(cost, error);
  log << "Pareto front (median time, error over the imager):";
  for (size_t i = 0; i < rows.size(); ++i) {
    rows[i].pareto = front[i];
    if (front[i])
      log << fmt::format(" [{} {:.2f} s, {:.4f} px]", rows[i].label, rows[i].median_s, rows[i].truth.rms_px);
  }
  log << "\n";
  log << "err px: recovered - truth RMS over the 16x12 grid of the imager (at 1 m); obs: grid points near "
         "observed corners; conf: where the model's reported sigma < 0.1 px; sigma: reported, RMS over the "
         "grid\n";

  std::string one_line_title = title;
  std::replace(one_line_title.begin(), one_line_title.end(), '\n', ';');
  const fs::path csv = dir / "calibrate_bench.csv", png = dir / "calibrate_bench.png";
  WriteFileAtomic(
      csv,
      Csv(rows, fmt::format("# {}\n# command: curvecheck bench calibrate --runs {} --views {} --seed {}{}\n",
                            one_line_title, a.runs, a.views, a.seed, a.quick ? " --quick" : "")));
  const fs::path gp =
      WriteGnuplotChart(png, ChartScript(csv.filename().string(), title), ChartSize{1300, 850});
  log << fmt::format("wrote {}, {} and {}\n", csv.string(), png.string(), gp.string());
}

}  // namespace curvecheck::experiments
