#include "experiments/bench_render.h"

#include <fmt/format.h>

#include <algorithm>

#include "core/correction.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/stats.h"
#include "experiments/machine_info.h"
#include "render/mapping_error.h"
#include "render/renderer.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;

struct Row {
  MethodOptions method;
  double median_ms = 0, min_ms = 0, upload_ms = 0;
  MappingError error;
  bool pareto = false;
};

std::vector<MethodOptions> Settings(const Monitor& m, bool quick) {
  std::vector<MethodOptions> out;
  MethodOptions o;
  out.push_back(o);  // exact analytic
  for (int ss : quick ? std::vector<int>{2} : std::vector<int>{2, 4}) {
    o.antialiasing = AntiAliasing::kSupersample;
    o.supersample = ss;
    out.push_back(o);
  }
  o = MethodOptions();
  o.method = Method::kNone;
  out.push_back(o);
  o.method = Method::kStrips;
  for (int n : quick ? std::vector<int>{8, 64} : std::vector<int>{8, 16, 32, 64, 128, 256}) {
    o.strips = n;
    out.push_back(o);
  }
  o = MethodOptions();
  o.method = Method::kWarp;
  for (double s : quick ? std::vector<double>{1} : std::vector<double>{1, 1.25, 2}) {
    for (WarpFilter f : {WarpFilter::kBilinear, WarpFilter::kCubic}) {
      o.warp_scale = s;
      o.warp_filter = f;
      out.push_back(o);
    }
  }
  o.warp_scale = 1;
  o.warp_filter = WarpFilter::kCubic;
  for (int spacing : quick ? std::vector<int>{64} : std::vector<int>{256, 64, 16}) {
    o.warp_grid_cols = (m.width_px + spacing - 1) / spacing;
    o.warp_grid_rows = (m.height_px + spacing - 1) / spacing;
    out.push_back(o);
  }
  o = MethodOptions();
  o.method = Method::kMesh;
  o.mesh_subdivision = MeshSubdivision::kUniform;
  for (int level : quick ? std::vector<int>{4} : std::vector<int>{1, 4, 16, 64}) {
    o.mesh_level = level;
    out.push_back(o);
  }
  for (auto [sub, tol] :
       quick ? std::vector<std::pair<MeshSubdivision, double>>{{MeshSubdivision::kExtended, 0.05}}
             : std::vector<std::pair<MeshSubdivision, double>>{{MeshSubdivision::kPerez, 0.05},
                                                               {MeshSubdivision::kExtended, 0.2},
                                                               {MeshSubdivision::kExtended, 0.05},
                                                               {MeshSubdivision::kExtended, 0.01}}) {
    o.mesh_subdivision = sub;
    o.mesh_tolerance_px = tol;
    out.push_back(o);
  }
  return out;
}

// Marks the settings that no other setting beats in both time and worst error.
void MarkParetoFront(std::vector<Row>& rows) {
  std::vector<double> t, e;
  for (const Row& r : rows) {
    t.push_back(r.median_ms);
    e.push_back(r.error.max_px);
  }
  const std::vector<bool> front = ParetoFront(t, e);
  for (size_t i = 0; i < rows.size(); ++i) rows[i].pareto = front[i];
}

std::string Csv(const std::vector<Row>& rows, const std::string& header) {
  std::string s = header;
  s += "method,setting,median_ms,min_ms,upload_ms,rms_px,p99_px,max_px,missing_pixels,pareto\n";
  for (const Row& r : rows) {
    s +=
        fmt::format("{},\"{}\",{:.3f},{:.3f},{:.3f},{:.6g},{:.6g},{:.6g},{},{}\n",
                    MethodName(r.method.method), r.method.Label(), r.median_ms, r.min_ms, r.upload_ms,
                    r.error.rms_px, r.error.p99_px, r.error.max_px, r.error.missing_pixels, r.pareto ? 1 : 0);
  }
  return s;
}

// gnuplot script: worst mapping error against median render time, log-log, one colour per method, every point
// labelled (a method that cannot reach an accuracy shows where it stays), the Pareto front as a line.
std::string GnuplotScript(const std::string& csv, const std::string& title) {
  return fmt::format(R"(set datafile separator ','
set title {title}
set logscale xy
set xlabel 'median render time per frame (ms), device set-up excluded'
set ylabel 'worst mapping error vs exact (display px)'
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set key outside right top
set format y '%g'
set arrow from graph 0, first 0.02 to graph 1, first 0.02 nohead dt 2 lc rgb '#888888'
set label 'placement target 0.02 px' at graph 0.01, first 0.025 tc rgb '#666666'
lowclip(y) = (y > 1e-5 ? y : 1e-5)
plot \
  for [m in "exact none strips warp mesh"] '{csv}' skip 1 using (strcol(1) eq m ? $3 : 1/0):(lowclip($8)) with points pt 7 ps 1.5 title m, \
  '{csv}' skip 1 using 3:(lowclip($8)):2 with labels offset 0.8,0.6 left font ',8' notitle, \
  '< grep ",1$" {csv} | sort -t, -k3 -g' using 3:(lowclip($8)) with lines lw 2 lc rgb '#cc0000' title 'Pareto front'
)",
                     fmt::arg("title", GnuplotString(title)), fmt::arg("csv", csv));
}

}  // namespace

void BenchRenderOptions::Check() const { CheckCount(runs, 1, 100, "--runs"); }

void RunBenchRender(const Monitor& monitor, const Eigen::Vector3d& viewpoint_in_screen,
                    const PatternSpec& spec, const BenchRenderOptions& a, const fs::path& dir,
                    std::ostream& log) {
  a.Check();
  const Pattern pattern = BuildPattern(spec, monitor, viewpoint_in_screen, TangentPlaneAtCentre(monitor));

  Renderer renderer;
  const std::string machine = DescribeMachine();
  const Eigen::Vector3d& v = viewpoint_in_screen;
  const std::string title =
      fmt::format("{} ({}x{}), viewpoint ({:g}, {:g}, {:g}) mm ({:.1f} mm from the screen centre), {} on {}; "
                  "median of {} runs\n{}",
                  monitor.name, monitor.width_px, monitor.height_px, v.x(), v.y(), v.z(),
                  (v - ScreenCentreInScreen(monitor)).norm(),
                  PatternKindName(pattern.spec.kind), renderer.device_name(), a.runs, machine);
  log << title << "\n";
  log << fmt::format("{:<38} {:>10} {:>10} {:>10} {:>10} {:>10}\n", "setting", "median ms", "min ms",
                     "rms px", "p99 px", "max px");
  std::vector<Row> rows;
  for (const MethodOptions& method : Settings(monitor, a.quick)) {
    RenderOptions options;
    options.method = method;
    Row row;
    row.method = method;
    try {
      renderer.Render(monitor, viewpoint_in_screen, pattern, options);  // warm-up: pipelines, caches
      std::vector<double> times, uploads;
      for (int i = 0; i < a.runs; ++i) {
        RenderTiming t;
        renderer.Render(monitor, viewpoint_in_screen, pattern, options, &t);
        times.push_back(t.render_ms);
        uploads.push_back(t.upload_ms);
      }
      row.median_ms = Median(times);
      row.min_ms = *std::min_element(times.begin(), times.end());
      row.upload_ms = Median(uploads);
      const CoordinateImage coords =
          renderer.RenderCoordinates(monitor, viewpoint_in_screen, pattern, options);
      row.error = MeasureMappingError(monitor, viewpoint_in_screen, pattern, coords);
    } catch (const Error& e) {
      log << fmt::format("{:<38} refused: {}\n", method.Label(), e.what());
      continue;
    }
    log << fmt::format("{:<38} {:>10.1f} {:>10.1f} {:>10.4f} {:>10.4f} {:>10.4f}\n", method.Label(),
                       row.median_ms, row.min_ms, row.error.rms_px, row.error.p99_px, row.error.max_px);
    rows.push_back(row);
  }
  MarkParetoFront(rows);
  log << fmt::format("device set-up (instance, device, pipelines): {:.1f} ms\nPareto front:",
                     renderer.setup_ms());
  for (const Row& r : rows) {
    if (r.pareto)
      log << fmt::format(" [{} {:.1f} ms, {:.3g} px]", r.method.Label(), r.median_ms, r.error.max_px);
  }
  log << "\n";

  const fs::path csv = dir / "render_bench.csv", png = dir / "render_bench.png", gp = dir / "render_bench.gp";
  std::string one_line_title = title;
  std::replace(one_line_title.begin(), one_line_title.end(), '\n', ';');
  WriteFileAtomic(
      csv, Csv(rows, fmt::format("# {}\n# device set-up {:.1f} ms\n", one_line_title, renderer.setup_ms())));
  WriteGnuplotChart(png, GnuplotScript(csv.filename().string(), title), {1400, 900});
  log << fmt::format("wrote {}, {} and {}\n", csv.string(), png.string(), gp.string());
}

}  // namespace curvecheck::experiments
