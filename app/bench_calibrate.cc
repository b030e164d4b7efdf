// `curvecheck bench calibrate`: lens-model speed against accuracy (issue 7 item 2c).
//
// The set: the synthetic camera photographs a flat monitor showing a checkerboard through a known lens
// (StrongOpencv8Lens, 640x480: an OPENCV8 truth that OPENCV4 cannot absorb), from the choreography of
// calibrate/truth_comparison.h; the corners are detected once. Each lens model is then calibrated alone (no model
// choice, no cross-validation) --runs times with the same detections. Per model: the median wall time of the
// calibration (mrcal's seeding, solve and uncertainty, the Python start included) and of mrcal's solve alone; the
// recovered model against the truth (CompareWithTruth: RMS px over the imager's 16x12 grid, over the observed
// grid points, and where the model reports sigma < 0.1 px); the reported uncertainty (RMS over the grid) and the
// fraction of grid points within 3 sigma. Solves are deterministic, so the runs differ in time only.
#include "app/bench_calibrate.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "app/bench_util.h"
#include "app/machine_info.h"
#include "calibrate/calibrate.h"
#include "calibrate/truth_comparison.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct BenchCalibrateArgs {
  int runs = 3;
  int views = 30;
  uint64_t seed = 7;
  std::vector<int> splined_nx = {8, 12, 16};
  bool quick = false;
  std::string output = "bench-calibrate";
};

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
    s += fmt::format("{},{},{},{:.4f},{:.4f},{:.4f},{:.5f},{:.5f},{:.5f},{:.5f},{},{},{:.5f},{},{}\n", r.label,
                     r.lensmodel, r.nparams, r.median_s, r.min_s, r.solve_s, r.residual_rms_px, t.rms_px,
                     t.observed_rms_px, t.confident_rms_px, t.confident_points, t.points + t.no_sigma,
                     t.rms_sigma_px, t.within_3sigma, r.pareto ? 1 : 0);
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

int RunBenchCalibrate(const BenchCalibrateArgs& a) {
  if (a.runs < 1 || a.runs > 50) throw Error("--runs", fmt::format("{} is out of range", a.runs), "use 1..50");
  if (a.views < 6 || a.views > 200) throw Error("--views", fmt::format("{} is out of range", a.views), "use 6..200");
  const fs::path dir = a.output;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw Error(dir.string(), "cannot create the output folder", "choose a writable path");

  SyntheticBoardOptions o;
  o.camera = StrongOpencv8Lens();
  o.views = a.views;
  o.seed = a.seed;
  const std::string machine = DescribeMachine();
  const std::string title = fmt::format(
      "bench calibrate: {} views of a synthetic flat board (seed {}), true lens {} {}x{} (StrongOpencv8Lens); "
      "median of {} runs\n{}",
      o.views, o.seed, o.camera.lensmodel, o.camera.width, o.camera.height, a.runs, machine);
  std::cout << title << "\n" << std::flush;
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
    models.emplace_back(fmt::format("splined {}x{}", nx, m.substr(m.find("Ny=") + 3, m.find("_fov") - m.find("Ny=") - 3)), m);
  }
  std::cout << fmt::format("{:<14} {:>6} {:>9} {:>9} {:>9} {:>10} {:>10} {:>11} {:>11} {:>9} {:>9}\n", "model",
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
      std::cout << fmt::format("{:<14} failed: {}\n", label, c.error);
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
    std::cout << fmt::format("{:<14} {:>6} {:>9.2f} {:>9.2f} {:>9.4f} {:>10.4f} {:>10.4f} {:>11.4f} {:>7}/{:<3} "
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
  std::cout << "Pareto front (median time, error over the imager):";
  for (size_t i = 0; i < rows.size(); ++i) {
    rows[i].pareto = front[i];
    if (front[i]) std::cout << fmt::format(" [{} {:.2f} s, {:.4f} px]", rows[i].label, rows[i].median_s, rows[i].truth.rms_px);
  }
  std::cout << "\n";
  std::cout << "err px: recovered - truth RMS over the 16x12 grid of the imager (at 1 m); obs: grid points near "
               "observed corners; conf: where the model's reported sigma < 0.1 px; sigma: reported, RMS over the grid\n";

  std::string one_line_title = title;
  std::replace(one_line_title.begin(), one_line_title.end(), '\n', ';');
  const fs::path csv = dir / "calibrate_bench.csv", png = dir / "calibrate_bench.png";
  WriteFileAtomic(csv, Csv(rows, fmt::format("# {}\n# command: curvecheck bench calibrate --runs {} --views {} --seed {}{}\n",
                                             one_line_title, a.runs, a.views, a.seed, a.quick ? " --quick" : "")));
  const fs::path gp = WriteGnuplotChart(png, ChartScript(csv.filename().string(), title), ChartSize{1300, 850});
  std::cout << fmt::format("wrote {}, {} and {}\n", csv.string(), png.string(), gp.string());
  return 0;
}

}  // namespace

void AddBenchCalibrateCommand(CLI::App& bench, std::function<int()>& run) {
  auto args = std::make_shared<BenchCalibrateArgs>();
  CLI::App* cmd = bench.add_subcommand(
      "calibrate", "Lens models on a synthetic set with a known lens: calibration time vs error against the truth");
  cmd->add_option("--runs", args->runs, "Timed calibrations per lens model (median reported)")->capture_default_str();
  cmd->add_option("--views", args->views, "Photos in the synthetic set")->capture_default_str();
  cmd->add_option("--seed", args->seed, "Seed of the set's poses and noise")->capture_default_str();
  cmd->add_option("-o,--output", args->output, "Output folder")->capture_default_str();
  cmd->add_flag("--quick", args->quick, "12 views and one splined density (for smoke tests)");
  cmd->callback([&run, args] {
    if (args->quick) {
      args->views = std::min(args->views, 12);
      args->splined_nx = {8};
    }
    run = [args] { return RunBenchCalibrate(*args); };
  });
}

}  // namespace curvecheck::app
