#include "experiments/bench_render.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>

#include "core/correction.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/file_io.h"
#include "core/flip.h"
#include "core/gnuplot.h"
#include "core/image_io.h"
#include "core/stats.h"
#include "core/viewing.h"
#include "pattern/texture.h"
#include "experiments/machine_info.h"
#include "render/mapping_error.h"
#include "render/renderer.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The FLIP axis (issue 21; thesis 3.3, 5.2): every setting renders a textured plane for a viewer on the centre line
// at each of these distances from the screen centre, and is compared with the reference of that configuration.
constexpr double kFlipDistancesMm[] = {1000, 250};
constexpr int kFlipDistances = 2;
// The reference: the exact method with 16 x 16 rays per pixel (a box filter of the pixel square to 1/32 of the
// contrast at an edge; the thesis's references use 8 samples per pixel, 3.3).
constexpr int kReferenceSupersample = 16;
// Texture cells of 2 display pixels at the screen centre (the tangent plane touches the screen there, so a cell
// of 2 pitches is 2 px wide there and smaller toward the edges, where the plane lies behind the curved screen).
constexpr double kTextureCellPx = 2;
constexpr uint32_t kTextureSeed = 21;

struct Row {
  MethodOptions method;
  double median_ms = 0, min_ms = 0, upload_ms = 0;
  MappingError error;
  bool pareto = false;
  // Per FLIP distance: mean FLIP against the reference (NaN if the method refused the view) and the render time
  // of that one frame (ms).
  double flip[kFlipDistances] = {kNaN, kNaN};
  double flip_ms[kFlipDistances] = {kNaN, kNaN};
  bool flip_pareto[kFlipDistances] = {false, false};
};

// One FLIP configuration: viewpoint, its pixels per degree, the textured pattern and its reference image.
struct FlipConfig {
  double distance_mm = 0;
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
  double ppd = 0;
  Pattern pattern;
  cv::Mat reference;  // CV_8UC1 code values
  std::shared_ptr<FlipEvaluator> flip;  // against the reference
};

cv::Mat AsMat(const GrayImage& image) {
  return cv::Mat(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.pixels.data())).clone();
}

std::string Slug(const std::string& label) {
  std::string s;
  for (char c : label) s += std::isalnum(static_cast<unsigned char>(c)) || c == '.' ? c : '_';
  return s;
}

// Settings whose FLIP and mapping-error maps are written (the figures the thesis discusses: the warp at the
// native scale and at its optima, the two tessellation heuristics, and the baseline).
bool WritesMaps(const std::string& label) {
  for (const char* l : {"warp s=1 bilinear per-fragment", "warp s=2 bilinear per-fragment",
                        "warp s=1 cubic per-fragment", "warp s=1.25 cubic per-fragment",
                        "mesh perez 256px tol 0.05", "mesh extended 256px tol 0.05", "strips 32", "none"})
    if (label == l) return true;
  return false;
}

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
  // The render-scale sweep of the thesis (Fig 5.7, 1x .. 3x), and below native.
  for (double s : quick ? std::vector<double>{1} : std::vector<double>{0.75, 1, 1.25, 1.5, 2, 2.5, 3}) {
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
  for (int d = 0; d < kFlipDistances; ++d) {
    std::vector<double> ft, fe;
    for (const Row& r : rows) {
      ft.push_back(r.flip_ms[d]);
      fe.push_back(r.flip[d]);
    }
    const std::vector<bool> ff = ParetoFront(ft, fe);
    for (size_t i = 0; i < rows.size(); ++i) rows[i].flip_pareto[d] = ff[i];
  }
}

std::string CsvNumber(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : ""; }

// The column names come first (what CSV readers take as the header); the provenance lines (`footer`, each
// starting with '#') follow the data, where gnuplot and the project's readers skip them as comments.
std::string Csv(const std::vector<Row>& rows, const std::string& footer) {
  std::string s = "method,setting,median_ms,min_ms,upload_ms,rms_px,p99_px,max_px,missing_pixels,flip_mean_100cm,"
       "flip_mean_25cm,render_ms_100cm,render_ms_25cm,flip_pareto_100cm,flip_pareto_25cm,pareto\n";
  for (const Row& r : rows) {
    s += fmt::format("{},\"{}\",{:.3f},{:.3f},{:.3f},{:.6g},{:.6g},{:.6g},{},{},{},{},{},{},{},{}\n",
                     MethodName(r.method.method), r.method.Label(), r.median_ms, r.min_ms, r.upload_ms,
                     r.error.rms_px, r.error.p99_px, r.error.max_px, r.error.missing_pixels, CsvNumber(r.flip[0]),
                     CsvNumber(r.flip[1]), CsvNumber(r.flip_ms[0]), CsvNumber(r.flip_ms[1]),
                     r.flip_pareto[0] ? 1 : 0, r.flip_pareto[1] ? 1 : 0, r.pareto ? 1 : 0);
  }
  return s + footer;
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

// gnuplot script: mean FLIP against the frame's render time, one colour per method, at both viewing distances
// (filled: 100 cm, open: 25 cm), each distance's Pareto front as a line.
std::string FlipGnuplotScript(const std::string& csv, const std::string& title) {
  return fmt::format(R"(set datafile separator ','
set title {title}
set logscale xy
set format y '%g'
set xlabel 'render time of the frame (ms), device set-up excluded'
set ylabel 'mean FLIP vs reference (exact, 16x16 rays per pixel), textured plane'
set grid xtics ytics mxtics lc rgb '#dddddd'
set key outside right top
plot \
  for [m in "exact none strips warp mesh"] '{csv}' skip 1 using (strcol(1) eq m ? $12 : 1/0):10 with points pt 7 ps 1.3 title m.' 100 cm', \
  for [m in "exact none strips warp mesh"] '{csv}' skip 1 using (strcol(1) eq m ? $13 : 1/0):11 with points pt 6 ps 1.3 title m.' 25 cm', \
  '{csv}' skip 1 using 12:10:2 with labels offset 0.8,0.5 left font ',7' notitle, \
  '< awk -F, "\$14 == 1" {csv} | sort -t, -k12 -g' using 12:10 with lines lw 2 lc rgb '#cc0000' title 'Pareto front 100 cm', \
  '< awk -F, "\$15 == 1" {csv} | sort -t, -k13 -g' using 13:11 with lines lw 2 dt 2 lc rgb '#cc0000' title 'Pareto front 25 cm'
)",
                     fmt::arg("title", GnuplotString(title)), fmt::arg("csv", csv));
}

// The warp's render-scale sweep alone (thesis Fig 5.7): per-fragment warp, one line per filter and distance.
std::string SweepCsv(const std::vector<Row>& rows) {
  std::string s = "scale,filter,flip_mean_100cm,flip_mean_25cm,render_ms_100cm,render_ms_25cm\n";
  for (WarpFilter f : {WarpFilter::kBilinear, WarpFilter::kCubic}) {
    for (const Row& r : rows) {
      const MethodOptions& m = r.method;
      if (m.method != Method::kWarp || m.warp_grid_cols != 0 || m.warp_filter != f) continue;
      s += fmt::format("{:g},{},{},{},{},{}\n", m.warp_scale, f == WarpFilter::kCubic ? "cubic" : "bilinear",
                       CsvNumber(r.flip[0]), CsvNumber(r.flip[1]), CsvNumber(r.flip_ms[0]), CsvNumber(r.flip_ms[1]));
    }
  }
  return s + "# mean FLIP of the per-fragment warp by render scale (rows of render_bench.csv)\n";
}

std::string SweepGnuplotScript(const std::string& csv, const std::string& title) {
  return fmt::format(R"(set datafile separator ','
set title {title}
set xlabel 'render scale of the first pass (x display size per axis)'
set ylabel 'mean FLIP vs reference, textured plane'
set logscale y
set format y '%g'
set grid xtics ytics lc rgb '#dddddd'
set key outside right top
plot \
  '< grep ",bilinear," {csv}' using 1:3 with linespoints pt 7 lw 2 title 'bilinear 100 cm', \
  '< grep ",cubic," {csv}' using 1:3 with linespoints pt 5 lw 2 title 'cubic 100 cm', \
  '< grep ",bilinear," {csv}' using 1:4 with linespoints pt 6 dt 2 title 'bilinear 25 cm', \
  '< grep ",cubic," {csv}' using 1:4 with linespoints pt 4 dt 2 title 'cubic 25 cm'
)",
                     fmt::arg("title", GnuplotString(title)), fmt::arg("csv", csv));
}

FlipConfig MakeFlipConfig(Renderer& renderer, const Monitor& monitor, const PatternSpec& spec, double distance_mm) {
  FlipConfig c;
  c.distance_mm = distance_mm;
  c.viewpoint = ViewpointFromScreenCentre(monitor, distance_mm, Eigen::Vector2d::Zero());
  c.ppd = ViewerPixelsPerDegree(monitor, c.viewpoint);
  c.pattern = BuildPattern(spec, monitor, c.viewpoint, TangentPlaneAtCentre(monitor));
  c.pattern.cells = MakeTextureCells(c.pattern.cells, kTextureCellPx * monitor.pixel_pitch_mm(), kTextureSeed);
  RenderOptions reference;
  reference.method.antialiasing = AntiAliasing::kSupersample;
  reference.method.supersample = kReferenceSupersample;
  c.reference = AsMat(renderer.Render(monitor, c.viewpoint, c.pattern, reference));
  c.flip = std::make_shared<FlipEvaluator>(c.reference, c.ppd);
  return c;
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
  log << fmt::format("{:<38} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}\n", "setting", "median ms", "min ms",
                     "rms px", "p99 px", "max px", "FLIP 100cm", "FLIP 25cm");
  std::vector<FlipConfig> flip_configs;
  for (double d : kFlipDistancesMm) flip_configs.push_back(MakeFlipConfig(renderer, monitor, spec, d));
  const fs::path maps = dir / "maps";
  fs::create_directories(maps);
  for (const FlipConfig& c : flip_configs) {
    log << fmt::format("FLIP at {:g} cm: viewpoint ({:g}, {:g}, {:g}) mm, {:.1f} px/deg at the nearest screen point; "
                       "textured plane {} x {} cells of {:.3f} mm; reference exact ss{}\n",
                       c.distance_mm / 10, c.viewpoint.x(), c.viewpoint.y(), c.viewpoint.z(), c.ppd,
                       c.pattern.cells.width, c.pattern.cells.height, c.pattern.cells.cell_mm, kReferenceSupersample);
    WritePng8(maps / fmt::format("reference_{:g}cm.png", c.distance_mm / 10), c.reference.cols, c.reference.rows, 1,
              c.reference.data);
  }
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
    const bool maps_wanted = WritesMaps(method.Label());
    if (maps_wanted) {
      WriteHeatmapPng(maps / (Slug(method.Label()) + "_mapping_error.png"), monitor.width_px, monitor.height_px,
                      row.error.map_px, std::max(1e-3, row.error.max_finite_px));
    }
    std::string flip_text;
    for (int d = 0; d < kFlipDistances; ++d) {
      const FlipConfig& c = flip_configs[d];
      try {
        RenderTiming t;
        const cv::Mat image = AsMat(renderer.Render(monitor, c.viewpoint, c.pattern, options, &t));
        const FlipResult f = c.flip->Compare(image);
        row.flip[d] = f.mean;
        row.flip_ms[d] = t.render_ms;
        if (maps_wanted) {
          const std::vector<float> values(f.error.begin<float>(), f.error.end<float>());
          WriteHeatmapPng(maps / fmt::format("{}_flip_{:g}cm.png", Slug(method.Label()), c.distance_mm / 10),
                          monitor.width_px, monitor.height_px, values, 1.0);
        }
        flip_text += fmt::format(" {:>10.4f}", f.mean);
      } catch (const Error& e) {
        flip_text += fmt::format(" {:>10}", "refused");
      }
    }
    log << fmt::format("{:<38} {:>10.1f} {:>10.1f} {:>10.4f} {:>10.4f} {:>10.4f}{}\n", method.Label(),
                       row.median_ms, row.min_ms, row.error.rms_px, row.error.p99_px, row.error.max_px, flip_text);
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
  for (int d = 0; d < kFlipDistances; ++d) {
    log << fmt::format("FLIP Pareto front at {:g} cm:", kFlipDistancesMm[d] / 10);
    for (const Row& r : rows) {
      if (r.flip_pareto[d])
        log << fmt::format(" [{} {:.1f} ms, {:.4f}]", r.method.Label(), r.flip_ms[d], r.flip[d]);
    }
    log << "\n";
  }

  const fs::path csv = dir / "render_bench.csv", png = dir / "render_bench.png", gp = dir / "render_bench.gp";
  std::string one_line_title = title;
  std::replace(one_line_title.begin(), one_line_title.end(), '\n', ';');
  WriteFileAtomic(
      csv, Csv(rows, fmt::format("# {}\n# device set-up {:.1f} ms\n# flip_mean_*: mean LDR FLIP (core/flip.h) of a textured "
                            "plane rendered for a viewer on the centre line {} cm from the screen centre, at {} px/deg, "
                            "against the exact method with {}x{} rays per pixel; render_ms_*: that frame's render "
                            "time; empty: the method refused the view\n",
                            one_line_title, renderer.setup_ms(),
                            fmt::format("{:g} / {:g}", kFlipDistancesMm[0] / 10, kFlipDistancesMm[1] / 10),
                            fmt::format("{:.1f} / {:.1f}", flip_configs[0].ppd, flip_configs[1].ppd),
                            kReferenceSupersample, kReferenceSupersample)));
  WriteGnuplotChart(png, GnuplotScript(csv.filename().string(), title), {1400, 900});
  const fs::path flip_png = dir / "render_bench_flip.png";
  WriteGnuplotChart(flip_png, FlipGnuplotScript(csv.filename().string(), title), {1400, 900});
  const fs::path sweep_csv = dir / "render_scale_sweep.csv";
  WriteFileAtomic(sweep_csv, SweepCsv(rows));
  WriteGnuplotChart(dir / "render_scale_sweep.png", SweepGnuplotScript(sweep_csv.filename().string(), title),
                    {1200, 800});
  log << fmt::format("wrote {}, {} and {}; {} (time against FLIP) and FLIP / mapping-error maps in {}\n",
                     csv.string(), png.string(), gp.string(), flip_png.string(), maps.string());
}

}  // namespace curvecheck::experiments
