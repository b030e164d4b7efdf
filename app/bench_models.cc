// `curvecheck bench models`: speed against accuracy of the screen models (issue 7 item 2d).
//
// For each true screen (scenes default, radius-8pct, lean-1deg, bulge-2mm: a nominal 1000R panel that is a
// cylinder, a cylinder of another radius, a cylinder with its axis tilted, a cylinder with a 2 mm bump) and each
// seed, the true surface points of a 63 x 17 feature grid are projected through the scene's lens with Gaussian
// noise (--noise px per coordinate; no image, no detector: this isolates the model). Each model is then fitted
// ALONE (no selection, no held-out folds), and scored by:
//   - fit time (median over the seeds; one photo);
//   - radius error: RMS over the seeds of R_fit - R_true (models without a radius number: no entry);
//   - surface error: RMS over the features of the distance, in the camera frame, between the fitted surface
//     point (model surface, deviation field included, placed by the fitted camera pose) and the true surface
//     point. The camera frame removes the gauge (the fitted centre frame is arbitrary up to the pose), so this is
//     the error of the shape the user would be shown, bulges included; averaged (RMS) over the seeds.
// The whole selection (every model, 5 held-out folds) also runs once per scene, to show which model it picks.
// Writes models_bench.csv and models_bench.png (+ .gp): two panels, time vs radius error and time vs surface
// error, log-log, one colour per scene, the Pareto front of each scene as a line.
#include "app/bench_models.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <random>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_test_util.h"
#include "analysis/screen_model.h"
#include "app/bench_util.h"
#include "app/machine_info.h"
#include "synth/synthetic_camera.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/screen_geometry.h"
#include "datasets/dataset_files.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct BenchModelsArgs {
  std::string scenes_dir;  // empty: the embedded scenes, written under the output folder
  std::string scenes = "default,radius-8pct,lean-1deg,bulge-2mm";
  int seeds = 5;
  int grid_cols = 63, grid_rows = 17;
  double noise_px = 0.1;
  std::string output = "bench-out";
};

struct Row {
  std::string scene, model;
  int parameters = 0, features = 0, fits = 0;
  double median_ms = 0;
  double radius_rms_error_mm = NAN, radius_mean_sigma_mm = NAN;
  double surface_rms_mm = NAN, surface_max_mm = NAN;
  bool chosen_by_selection = false;
  bool pareto_radius = false, pareto_surface = false;
};

std::vector<std::string> SplitComma(const std::string& s) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= s.size()) {
    const size_t end = std::min(s.find(',', start), s.size());
    if (end > start) out.push_back(s.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

// The fitted surface point of `fit` at display coordinates uv, in the fitted camera's frame.
Eigen::Vector3d FittedPointInCamera(const Monitor& nominal, const ModelFit& fit, ScreenModelKind kind,
                                    const DeviationBasis* basis, const Eigen::Vector2d& uv) {
  const double s = 0.5 * uv.x() * nominal.width_mm, y = -0.5 * uv.y() * nominal.height_mm;
  Eigen::Vector3d normal;
  Eigen::Vector3d p = CoreScreenPoint<double>(kind, fit.shape.data(), s, y, 0.5 * nominal.width_mm, &normal);
  if (basis) {
    const Eigen::VectorXd w = basis->Weights(uv);
    const int core = CoreParameterCount(kind);
    double d = 0;
    for (int i = 0; i < w.size(); ++i) d += w[i] * fit.shape[static_cast<size_t>(core + i)];
    p += d * normal;
  }
  const CameraEstimate& cam = fit.cameras.at(0);
  return cam.centre_from_cam.transpose() * (p - cam.position_in_centre_mm);
}

std::string Csv(const std::vector<Row>& rows, const std::string& header) {
  std::string s = header;
  s += "scene,model,parameters,features,fits,median_ms,radius_rms_error_mm,radius_mean_sigma_mm,surface_rms_mm,"
       "surface_max_mm,chosen_by_selection,pareto_radius,pareto_surface\n";
  const auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string(); };
  for (const Row& r : rows) {
    s += fmt::format("{},{},{},{},{},{:.3f},{},{},{},{},{},{},{}\n", r.scene, r.model, r.parameters, r.features,
                     r.fits, r.median_ms, num(r.radius_rms_error_mm), num(r.radius_mean_sigma_mm),
                     num(r.surface_rms_mm), num(r.surface_max_mm), r.chosen_by_selection ? 1 : 0,
                     r.pareto_radius ? 1 : 0, r.pareto_surface ? 1 : 0);
  }
  return s;
}

// Two panels; columns: 6 time, 7 radius error, 9 surface error, 12/13 Pareto flags.
std::string ChartScript(const std::string& title, const std::vector<std::string>& scenes) {
  std::string radius, surface;
  for (size_t i = 0; i < scenes.size(); ++i) {
    const std::string q = GnuplotString(scenes[i]);
    radius += fmt::format(
        "  'models_bench.csv' skip 2 using (strcol(1) eq {q} && strcol(7) ne '' ? $6 : 1/0):7 with points pt 7 ps 1.4 "
        "lc {c} title {q}, \\\n"
        "  '< grep \"^{s},.*,1,[01]$\" models_bench.csv | sort -t, -k6 -g' using 6:7 with lines lw 2 lc {c} notitle, "
        "\\\n",
        fmt::arg("q", q), fmt::arg("s", scenes[i]), fmt::arg("c", i + 1));
    surface += fmt::format(
        "  'models_bench.csv' skip 2 using (strcol(1) eq {q} ? $6 : 1/0):9 with points pt 7 ps 1.4 lc {c} title {q}, "
        "\\\n"
        "  '< grep \"^{s},.*,1$\" models_bench.csv | sort -t, -k6 -g' using 6:9 with lines lw 2 lc {c} notitle, \\\n",
        fmt::arg("q", q), fmt::arg("s", scenes[i]), fmt::arg("c", i + 1));
  }
  return fmt::format(R"(set datafile separator ','
set multiplot layout 1,2 title {title}
set logscale xy
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set key top right font ',9'
set xlabel 'fit time, one photo (ms, median)'
set ylabel 'radius error vs truth, RMS over seeds (mm)'
set title 'radius'
plot \
{radius}  'models_bench.csv' skip 2 using (strcol(7) ne '' ? $6 : 1/0):7:2 with labels offset 0.8,0.5 left font ',7' notitle
set ylabel 'surface error vs truth, RMS over features (mm)'
set title 'surface (deviation) error'
plot \
{surface}  'models_bench.csv' skip 2 using 6:9:2 with labels offset 0.8,0.5 left font ',7' notitle
unset multiplot
)",
                     fmt::arg("title", GnuplotString(title)), fmt::arg("radius", radius), fmt::arg("surface", surface));
}

int RunBenchModels(const BenchModelsArgs& a) {
  if (a.seeds < 1 || a.seeds > 1000) throw Error("--seeds", fmt::format("{} is out of range", a.seeds), "use 1..1000");
  if (a.grid_cols < 4 || a.grid_rows < 4 || a.grid_cols > 400 || a.grid_rows > 400) {
    throw Error("--grid", fmt::format("{}x{} is out of range", a.grid_cols, a.grid_rows), "use 4..400 per side");
  }
  if (!(a.noise_px > 0 && a.noise_px < 10)) throw Error("--noise", fmt::format("{} px", a.noise_px), "use (0, 10) px");
  const std::vector<std::string> scenes = SplitComma(a.scenes);
  if (scenes.empty()) throw Error("--scenes", "no scene named", "e.g. --scenes default,bulge-2mm");
  const fs::path dir = a.output;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw Error(dir.string(), "cannot create the output folder", "choose a writable path");
  const fs::path scenes_dir =
      a.scenes_dir.empty() ? WriteDatasetFiles(dir / "datasets") / "scenes" : fs::path(a.scenes_dir);
  const std::string machine = DescribeMachine();
  std::cout << fmt::format("bench models: {}; {}x{} features, noise {} px per coordinate, {} seeds per case\n",
                           machine, a.grid_cols, a.grid_rows, a.noise_px, a.seeds);
  std::cout << fmt::format("{:<12} {:<28} {:>6} {:>10} {:>14} {:>12} {:>13} {:>12}  {}\n", "scene", "model", "params",
                           "median ms", "radius err mm", "mean sigma", "surface mm", "surface max", "");
  std::vector<Row> rows;
  for (const std::string& name : scenes) {
    const fs::path path = scenes_dir / (name + ".yaml");
    if (!fs::exists(path)) {
      throw Error(path.string(), "scene file does not exist",
                  "name an embedded scene (default, radius-8pct, lean-1deg, bulge-2mm, ...) or pass --scenes-dir");
    }
    const SyntheticScene scene = LoadScene(path);
    const Monitor& nominal = scene.monitor;
    const std::vector<Eigen::Vector2d> grid = testing::DisplayGrid(nominal, a.grid_cols, a.grid_rows);
    const double r_true = scene.truth.curvature_per_mm != 0 ? 1 / scene.truth.curvature_per_mm : INFINITY;
    std::vector<PhotoObservations> photos;
    for (int seed = 0; seed < a.seeds; ++seed) {
      std::mt19937_64 rng(7000 + static_cast<uint64_t>(seed));
      photos.push_back(testing::Observe(scene, grid, a.noise_px, rng, testing::SceneSurface(scene)));
    }
    // True points in the camera frame, per feature of the first seed's observations (all seeds see the same).
    const PhotoObservations& ref = photos[0];
    std::vector<Eigen::Vector2d> uv;
    std::vector<Eigen::Vector3d> truth_cam;
    for (const Eigen::Vector2d& px : ref.display_px) {
      uv.push_back(UvFromDisplayPx(nominal, px));
      truth_cam.push_back(scene.screen_from_cam.transpose() *
                          (TrueSurfacePointInScreen(scene, uv.back()) - scene.camera_position_in_screen));
    }
    FitOptions all_models;
    const ScreenFitResult selection = FitScreen(nominal, scene.camera, {photos[0]}, all_models);
    for (ScreenModelKind kind : AllScreenModels()) {
      Row row;
      row.scene = name;
      row.model = ScreenModelName(kind);
      row.features = static_cast<int>(ref.ids.size());
      row.chosen_by_selection = selection.Chosen().model == row.model;
      FitOptions o;
      o.models = {row.model};
      o.heldout_folds = 0;
      std::unique_ptr<DeviationBasis> basis;
      if (kind == ScreenModelKind::kCylinderDeviation) {
        // As FitScreen builds it when the deviation model is fitted alone: around the nominal curvature.
        basis = std::make_unique<DeviationBasis>(nominal, nominal.curvature_per_mm, o.deviation_nu, o.deviation_nv);
      }
      std::vector<double> times, radius_err2, sigmas, surface2;
      double surface_max = 0;
      std::string note;
      for (const PhotoObservations& photo : photos) {
        const auto t0 = std::chrono::steady_clock::now();
        const ScreenFitResult r = FitScreen(nominal, scene.camera, {photo}, o);
        times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        if (r.candidates.empty()) {
          note = r.skipped.empty() ? "not fitted" : r.skipped[0];
          break;
        }
        const ModelFit& f = r.Chosen();
        row.parameters = f.parameters;
        ++row.fits;
        if (f.radius_mm && std::isfinite(r_true)) {
          radius_err2.push_back((*f.radius_mm - r_true) * (*f.radius_mm - r_true));
          sigmas.push_back(*f.radius_sigma_mm);
        }
        if (photo.ids.size() != ref.ids.size()) continue;  // same features in every seed (noise only differs)
        double sum2 = 0;
        for (size_t i = 0; i < uv.size(); ++i) {
          const double e = (FittedPointInCamera(nominal, f, kind, basis.get(), uv[i]) - truth_cam[i]).norm();
          sum2 += e * e;
          surface_max = std::max(surface_max, e);
        }
        surface2.push_back(sum2 / static_cast<double>(uv.size()));
      }
      if (row.fits == 0) {
        std::cout << fmt::format("{:<12} {:<28} skipped: {}\n", name, row.model, note);
        continue;
      }
      const auto rms = [](const std::vector<double>& sq) {
        double s = 0;
        for (double v : sq) s += v;
        return sq.empty() ? NAN : std::sqrt(s / static_cast<double>(sq.size()));
      };
      row.median_ms = Median(times);
      row.radius_rms_error_mm = rms(radius_err2);
      if (!sigmas.empty()) {
        double s = 0;
        for (double v : sigmas) s += v;
        row.radius_mean_sigma_mm = s / static_cast<double>(sigmas.size());
      }
      row.surface_rms_mm = rms(surface2);
      row.surface_max_mm = surface2.empty() ? NAN : surface_max;
      rows.push_back(row);
    }
    // Pareto fronts within the scene.
    std::vector<double> t, er, es;
    std::vector<size_t> index;
    for (size_t i = 0; i < rows.size(); ++i) {
      if (rows[i].scene != name) continue;
      index.push_back(i);
      t.push_back(rows[i].median_ms);
      er.push_back(rows[i].radius_rms_error_mm);
      es.push_back(rows[i].surface_rms_mm);
    }
    const std::vector<bool> fr = ParetoFront(t, er), fs_ = ParetoFront(t, es);
    for (size_t j = 0; j < index.size(); ++j) {
      Row& r = rows[index[j]];
      r.pareto_radius = fr[j];
      r.pareto_surface = fs_[j];
      const auto cell = [](double v, int w) {
        return std::isfinite(v) ? fmt::format("{:>{}.4f}", v, w) : fmt::format("{:>{}}", "-", w);
      };
      std::cout << fmt::format("{:<12} {:<28} {:>6} {:>10.1f} {} {} {} {}  {}{}{}\n", r.scene, r.model, r.parameters,
                               r.median_ms, cell(r.radius_rms_error_mm, 14), cell(r.radius_mean_sigma_mm, 12),
                               cell(r.surface_rms_mm, 13), cell(r.surface_max_mm, 12),
                               r.chosen_by_selection ? "[selection's choice] " : "",
                               r.pareto_radius ? "[front: radius] " : "", r.pareto_surface ? "[front: surface]" : "");
    }
    std::cout << fmt::format("{:<12} truth R {:.1f} mm; selection: {} ({})\n", name, r_true, selection.Chosen().model,
                             selection.choice_reason);
  }

  const std::string title = fmt::format("screen models: fit time vs accuracy ({}x{} features, {} px noise, {} seeds); {}",
                                        a.grid_cols, a.grid_rows, a.noise_px, a.seeds, machine);
  WriteFileAtomic(dir / "models_bench.csv", Csv(rows, fmt::format("# curvecheck bench models; {}\n", machine)));
  WriteGnuplotChart(dir / "models_bench.png", ChartScript(title, scenes), {1600, 700});
  std::cout << fmt::format("wrote {}, {} and {}\n", (dir / "models_bench.csv").string(),
                           (dir / "models_bench.png").string(), (dir / "models_bench.gp").string());
  return 0;
}

}  // namespace

void AddBenchModelsCommand(CLI::App& bench, std::function<int()>& run) {
  auto args = std::make_shared<BenchModelsArgs>();
  CLI::App* cmd = bench.add_subcommand(
      "models", "Every screen model on several true screens: fit time vs radius error and surface error; CSV + chart");
  cmd->add_option("--scenes", args->scenes, "Comma-separated scene names (files in --scenes-dir)")
      ->capture_default_str();
  cmd->add_option("--scenes-dir", args->scenes_dir, "Folder of the scene YAML files (default: the embedded datasets/scenes)");
  cmd->add_option("--seeds", args->seeds, "Noise seeds per case (times: median over them)")->capture_default_str();
  cmd->add_option("--noise", args->noise_px, "Detection noise, px per coordinate")->capture_default_str();
  cmd->add_option("--grid-cols", args->grid_cols, "Features across the width")->capture_default_str();
  cmd->add_option("--grid-rows", args->grid_rows, "Features down the height")->capture_default_str();
  cmd->add_option("-o,--output", args->output, "Output folder")->capture_default_str();
  cmd->callback([&run, args] { run = [args] { return RunBenchModels(*args); }; });
}

}  // namespace curvecheck::app
