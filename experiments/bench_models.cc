#include "experiments/bench_models.h"

#include <fmt/format.h>

#include <cmath>
#include <random>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_test_util.h"
#include "analysis/screen_model.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "core/stopwatch.h"
#include "experiments/machine_info.h"
#include "experiments/scene_lookup.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;

struct Row {
  std::string scene, model;
  int parameters = 0, features = 0, fits = 0;
  double median_ms = 0;
  double radius_rms_error_mm = NAN, radius_mean_sigma_mm = NAN;
  double surface_rms_mm = NAN, surface_max_mm = NAN;
  bool chosen_by_selection = false;
  bool pareto_radius = false, pareto_surface = false;
};

// The scene `name`: <scenes_dir>/<name>.yaml, or the embedded scene when scenes_dir is empty.
SyntheticScene LoadNamedScene(const std::string& scenes_dir, const std::string& name) {
  if (scenes_dir.empty()) return LoadEmbeddedScene(name, "--scenes");
  const fs::path path = fs::path(scenes_dir) / (name + ".yaml");
  if (!fs::exists(path)) {
    throw Error(
        path.string(), "scene file does not exist",
        "name an embedded scene (default, radius-8pct, lean-1deg, bulge-2mm, ...) or pass --scenes-dir");
  }
  return LoadScene(path);
}

std::string Csv(const std::vector<Row>& rows, const std::string& header) {
  std::string s = header;
  s += "scene,model,parameters,features,fits,median_ms,radius_rms_error_mm,radius_mean_sigma_mm,surface_rms_"
       "mm,"
       "surface_max_mm,chosen_by_selection,pareto_radius,pareto_surface\n";
  const auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string(); };
  for (const Row& r : rows) {
    s += fmt::format("{},{},{},{},{},{:.3f},{},{},{},{},{},{},{}\n", r.scene, r.model, r.parameters,
                     r.features, r.fits, r.median_ms, num(r.radius_rms_error_mm), num(r.radius_mean_sigma_mm),
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
        "  'models_bench.csv' skip 2 using (strcol(1) eq {q} && strcol(7) ne '' ? $6 : 1/0):7 with points pt "
        "7 ps 1.4 "
        "lc {c} title {q}, \\\n"
        "  '< grep \"^{s},.*,1,[01]$\" models_bench.csv | sort -t, -k6 -g' using 6:7 with lines lw 2 lc {c} "
        "notitle, "
        "\\\n",
        fmt::arg("q", q), fmt::arg("s", scenes[i]), fmt::arg("c", i + 1));
    surface += fmt::format(
        "  'models_bench.csv' skip 2 using (strcol(1) eq {q} ? $6 : 1/0):9 with points pt 7 ps 1.4 lc {c} "
        "title {q}, "
        "\\\n"
        "  '< grep \"^{s},.*,1$\" models_bench.csv | sort -t, -k6 -g' using 6:9 with lines lw 2 lc {c} "
        "notitle, \\\n",
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
                     fmt::arg("title", GnuplotString(title)), fmt::arg("radius", radius),
                     fmt::arg("surface", surface));
}

}  // namespace

void BenchModelsOptions::Check() const {
  CheckCount(seeds, 1, 1000, "--seeds");
  if (grid_cols < 4 || grid_rows < 4 || grid_cols > 400 || grid_rows > 400) {
    throw Error("--grid", fmt::format("{}x{} is out of range", grid_cols, grid_rows), "use 4..400 per side");
  }
  if (!(noise_px > 0 && noise_px < 10)) throw Error("--noise", fmt::format("{} px", noise_px), "use (0, 10) px");
  if (scenes.empty()) throw Error("--scenes", "no scene named", "e.g. --scenes default,bulge-2mm");
}

void RunBenchModels(const BenchModelsOptions& a, const fs::path& dir, std::ostream& log) {
  a.Check();
  const std::string machine = DescribeMachine();
  log << fmt::format("bench models: {}; {}x{} features, noise {} px per coordinate, {} seeds per case\n",
                     machine, a.grid_cols, a.grid_rows, a.noise_px, a.seeds);
  log << fmt::format("{:<12} {:<28} {:>6} {:>10} {:>14} {:>12} {:>13} {:>12}  {}\n", "scene", "model",
                     "params", "median ms", "radius err mm", "mean sigma", "surface mm", "surface max", "");
  std::vector<Row> rows;
  for (const std::string& name : a.scenes) {
    const SyntheticScene scene = LoadNamedScene(a.scenes_dir, name);
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
      truth_cam.push_back(scene.screen_from_cam.Inverse() * TrueSurfacePointInScreen(scene, uv.back()));
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
      o.models = {kind};
      o.heldout_folds = 0;
      std::vector<double> times, radius_err, sigmas, surface_err;
      double surface_max = 0;
      std::string note;
      for (const PhotoObservations& photo : photos) {
        const Stopwatch watch;
        const ScreenFitResult r = FitScreen(nominal, scene.camera, {photo}, o);
        times.push_back(watch.Ms());
        if (r.candidates.empty()) {
          note = r.skipped.empty() ? "not fitted" : r.skipped[0];
          break;
        }
        const ModelFit& f = r.Chosen();
        row.parameters = f.parameters;
        ++row.fits;
        if (f.radius_mm && std::isfinite(r_true)) {
          radius_err.push_back(*f.radius_mm - r_true);
          sigmas.push_back(*f.radius_sigma_mm);
        }
        if (photo.ids.size() != ref.ids.size()) continue;  // same features in every seed (noise only differs)
        const std::vector<Eigen::Vector3d> fitted = FittedSurfacePointsInCamera(nominal, f, 0, uv, o);
        for (size_t i = 0; i < uv.size(); ++i) {
          surface_err.push_back((fitted[i] - truth_cam[i]).norm());
          surface_max = std::max(surface_max, surface_err.back());
        }
      }
      if (row.fits == 0) {
        log << fmt::format("{:<12} {:<28} skipped: {}\n", name, row.model, note);
        continue;
      }
      row.median_ms = Median(times);
      row.radius_rms_error_mm = radius_err.empty() ? NAN : Rms(radius_err);
      if (!sigmas.empty()) {
        double s = 0;
        for (double v : sigmas) s += v;
        row.radius_mean_sigma_mm = s / static_cast<double>(sigmas.size());
      }
      row.surface_rms_mm = surface_err.empty() ? NAN : Rms(surface_err);
      row.surface_max_mm = surface_err.empty() ? NAN : surface_max;
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
      log << fmt::format(
          "{:<12} {:<28} {:>6} {:>10.1f} {} {} {} {}  {}{}{}\n", r.scene, r.model, r.parameters, r.median_ms,
          cell(r.radius_rms_error_mm, 14), cell(r.radius_mean_sigma_mm, 12), cell(r.surface_rms_mm, 13),
          cell(r.surface_max_mm, 12), r.chosen_by_selection ? "[selection's choice] " : "",
          r.pareto_radius ? "[front: radius] " : "", r.pareto_surface ? "[front: surface]" : "");
    }
    log << fmt::format("{:<12} truth R {:.1f} mm; selection: {} ({})\n", name, r_true,
                       selection.Chosen().model, selection.choice_reason);
  }

  const std::string title =
      fmt::format("screen models: fit time vs accuracy ({}x{} features, {} px noise, {} seeds); {}",
                  a.grid_cols, a.grid_rows, a.noise_px, a.seeds, machine);
  WriteFileAtomic(dir / "models_bench.csv",
                  Csv(rows, fmt::format("# curvecheck bench models; {}\n", machine)));
  WriteGnuplotChart(dir / "models_bench.png", ChartScript(title, a.scenes), {1600, 700});
  log << fmt::format("wrote {}, {} and {}\n", (dir / "models_bench.csv").string(),
                     (dir / "models_bench.png").string(), (dir / "models_bench.gp").string());
}

}  // namespace curvecheck::experiments
