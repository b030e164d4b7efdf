// `curvecheck sweep` (issue 7 items 3-4): stability sweeps. One or two factors of the scene vary over a grid; at
// each point the pattern is rendered for the stated viewpoint by a correction method, the synthetic camera
// photographs the (true) monitor showing it, and the photo is analysed from pixels (detect, verify, fit). Each
// point records success, the failure reason, the verification p95 (display px), the cylinder radius against
// the truth with its sigma, and the time of each stage; per method a failure map and the boundaries as text.
//
// Determinism: point k of the grid (methods outermost, then factor 1, then factor 2) always uses noise seed
// `--seed` + k, and nothing else is random, so a shard (`--shard i/n`: the points k with k mod n = i - 1)
// computes exactly the rows of an unsharded run, and `sweep merge` puts them back together.
//
// Parallelism: points run on --jobs worker threads; the Vulkan renderer is one instance shared by the workers
// and serialised by a mutex (lavapipe itself uses every core for a frame), with the last few renders cached
// because most factors do not change the rendered image.
#include "app/sweep_command.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Geometry>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "analysis/pipeline.h"
#include "app/bench_util.h"
#include "app/cli.h"
#include "app/machine_info.h"
#include "app/output_paths.h"
#include "app/sweep_table.h"
#include "synth/synthetic_camera.h"
#include "core/correction.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/screen_geometry.h"
#include "datasets/dataset_files.h"
#include "render/method.h"
#include "pattern/pattern_json.h"
#include "render/renderer.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct FactorInfo {
  const char* name;
  const char* alias;
  double lo, hi;  // allowed values (inclusive)
  const char* meaning;
};

// The factors a sweep can vary. Geometry factors move the camera around the screen centre (it keeps looking at
// it); the pattern is rendered for the camera's position unless viewpoint_offset_mm separates the two.
constexpr FactorInfo kFactors[] = {
    {"yaw_deg", "yaw", -85, 85,
     "camera moved horizontally around the screen centre at the same distance (positive: to the right), looking "
     "at the centre"},
    {"pitch_deg", "pitch", -85, 85, "camera moved vertically around the screen centre (positive: up)"},
    {"distance_mm", "distance", 100, 100000, "camera distance from the screen centre"},
    {"defocus_px", "defocus", 0, 50, "Gaussian PSF sigma in px of the (scaled) camera; 0 = sharp"},
    {"noise_x", "noise", 0, 1000,
     "sensor noise multiplier: shot and read noise relative to the signal times x (full well / x^2, read noise / "
     "x); 0 = noiseless"},
    {"exposure", "exposure", 0.001, 100, "scene radiance multiplier (optics.exposure)"},
    {"fill_factor", "fill", 0.05, 1, "emitting fraction of a display pixel along each axis (moire)"},
    {"square_px", "square", 8, 2000,
     "checkerboard square edge, display px at the screen centre; the board spans about 90% of the display"},
    {"coverage", "coverage", 0.15, 1, "fraction of the display's width and height the fitted board may span"},
    {"radius_ratio", "radius", 0.2, 5, "true radius / nominal: rendered for the nominal, photographed with the true"},
    {"viewpoint_offset_mm", "viewpoint_offset", -3000, 3000,
     "camera moved sideways (x) from the viewpoint the pattern was rendered for, still looking at the centre"},
};

const FactorInfo& FindFactor(const std::string& name) {
  for (const FactorInfo& f : kFactors) {
    if (name == f.name || name == f.alias) return f;
  }
  std::string known;
  for (const FactorInfo& f : kFactors) known += fmt::format("{}{} ({})", known.empty() ? "" : ", ", f.name, f.alias);
  throw Error("--factor", fmt::format("'{}' is not a sweep factor", name), "give one of: " + known);
}

double ParseNumber(const std::string& text, const std::string& what) {
  size_t used = 0;
  double v = kNaN;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v)) {
    throw Error("--factor", fmt::format("{} '{}' is not a finite number", what, text), "write NAME=start:stop:count");
  }
  return v;
}

// NAME=start:stop:count, or NAME=value.
SweepFactor ParseFactor(const std::string& text) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos) {
    throw Error("--factor", fmt::format("'{}' has no '='", text), "write NAME=start:stop:count, e.g. yaw=0:40:5");
  }
  const FactorInfo& info = FindFactor(text.substr(0, eq));
  SweepFactor f;
  f.name = info.name;
  std::vector<std::string> parts;
  std::stringstream ss(text.substr(eq + 1));
  for (std::string p; std::getline(ss, p, ':');) parts.push_back(p);
  if (parts.size() == 1) {
    f.start = f.stop = ParseNumber(parts[0], "value");
  } else if (parts.size() == 3) {
    f.start = ParseNumber(parts[0], "start");
    f.stop = ParseNumber(parts[1], "stop");
    const double count = ParseNumber(parts[2], "count");
    if (!(count >= 1 && count <= 1000 && count == std::floor(count))) {
      throw Error("--factor", fmt::format("{}: count {} is not a whole number from 1 to 1000", f.name, parts[2]), "");
    }
    f.count = static_cast<int>(count);
  } else {
    throw Error("--factor", fmt::format("'{}' is not start:stop:count", text), "write e.g. yaw=0:40:5");
  }
  for (double v : {f.start, f.stop}) {
    if (v < info.lo || v > info.hi) {
      throw Error("--factor", fmt::format("{} = {:g} is outside {:g}..{:g}", f.name, v, info.lo, info.hi),
                  fmt::format("sweep {} ({}) within that range", f.name, info.meaning));
    }
  }
  return f;
}

struct SweepArgs {
  std::vector<std::string> factors;
  std::string method = "exact";
  std::string scene = "default";
  double scale = 0.25;
  int jobs = 1;
  std::string shard = "1/1";
  std::string output = "sweep";
  int64_t seed = 1;
  std::string models = "flat,cylinder";
  int cols = 32, rows = 9;
  double tolerance = 0.5;
};

struct MergeArgs {
  std::vector<std::string> dirs;
  std::string output;
};

std::vector<std::string> Split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string p; std::getline(ss, p, sep);) {
    if (!p.empty()) out.push_back(p);
  }
  return out;
}

std::pair<int, int> ParseShard(const std::string& text) {
  const std::vector<std::string> p = Split(text, '/');
  int i = 0, n = 0;
  try {
    if (p.size() == 2) i = std::stoi(p[0]), n = std::stoi(p[1]);
  } catch (const std::exception&) {
    n = 0;
  }
  if (n < 1 || i < 1 || i > n || fmt::format("{}/{}", i, n) != text) {
    throw Error("--shard", fmt::format("'{}' is not i/n with 1 <= i <= n", text), "write e.g. --shard 2/4");
  }
  return {i, n};
}

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string ReasonOfRejection(const std::string& why) {
  if (why.find("pattern not found") != std::string::npos) return "not_found";
  if (why.find("ambiguous orientation") != std::string::npos) return "ambiguous_orientation";
  if (why.find("different pattern") != std::string::npos) return "ambiguous_ids";
  if (why.find("usable features") != std::string::npos || why.find("only ") != std::string::npos) {
    return "too_few_features";
  }
  return "rejected";
}

struct Sweep {
  SweepArgs args;
  std::vector<SweepFactor> factors;
  std::vector<std::string> methods;
  SyntheticScene base;  // camera already scaled
  fs::path scratch;
  AnalyzeOptions analyze;
  int points_per_method = 1;

  std::mutex render_mutex;
  std::unique_ptr<Renderer> renderer;
  std::deque<std::pair<std::string, std::shared_ptr<const Image8>>> cache;  // most recent first
  std::mutex print_mutex;
};

// The display image for (method, viewpoint, pattern): rendered under the lock, or from the cache. Throws what
// the renderer throws (a method that refuses the view).
std::shared_ptr<const Image8> DisplayImage(Sweep& sw, const std::string& method, const Eigen::Vector3d& viewpoint,
                                           const PatternSpec& spec, const Pattern& pattern, double* render_ms,
                                           bool* cached) {
  const std::string key = fmt::format("{} {:.9g} {:.9g} {:.9g} {} {} {:.9g} {:.9g}", method, viewpoint.x(),
                                      viewpoint.y(), viewpoint.z(), spec.cols, spec.rows, spec.square_mm, spec.margin);
  std::lock_guard<std::mutex> lock(sw.render_mutex);
  for (const auto& [k, image] : sw.cache) {
    if (k == key) {
      *cached = true;
      *render_ms = 0;
      return image;
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  if (!sw.renderer) sw.renderer = std::make_unique<Renderer>();
  RenderOptions options;
  options.method.method = ParseMethod(method, "--method");
  const GrayImage gray = sw.renderer->Render(sw.base.monitor, viewpoint, pattern, options);
  auto image = std::make_shared<Image8>();
  image->width = gray.width;
  image->height = gray.height;
  image->channels = 1;
  image->pixels = gray.pixels;
  *render_ms = MsSince(t0);
  *cached = false;
  sw.cache.emplace_front(key, image);
  if (sw.cache.size() > 4) sw.cache.pop_back();
  return image;
}

// One grid point, as its sweep.csv row.
std::vector<std::string> RunPoint(Sweep& sw, int index) {
  const auto t_point = std::chrono::steady_clock::now();
  const std::string method = sw.methods[static_cast<size_t>(index / sw.points_per_method)];
  std::vector<double> values(sw.factors.size());
  int rest = index % sw.points_per_method;
  for (size_t f = sw.factors.size(); f-- > 0;) {
    values[f] = sw.factors[f].Value(rest % sw.factors[f].count);
    rest /= sw.factors[f].count;
  }

  SyntheticScene s = sw.base;
  s.sensor.seed = static_cast<uint64_t>(sw.args.seed + index);
  const Monitor& m = s.monitor;
  PatternSpec spec;
  spec.cols = sw.args.cols;
  spec.rows = sw.args.rows;
  const Eigen::Vector3d centre = ScreenCentreInScreen(m);
  Eigen::Vector3d offset = s.camera_position_in_screen - centre;
  double sideways_mm = 0, yaw = 0, pitch = 0;
  bool moved = false;
  for (size_t f = 0; f < values.size(); ++f) {
    const std::string& name = sw.factors[f].name;
    const double v = values[f];
    if (name == "yaw_deg") yaw = v, moved = true;
    if (name == "pitch_deg") pitch = v, moved = true;
    if (name == "distance_mm") offset = offset.normalized() * v, moved = true;
    if (name == "viewpoint_offset_mm") sideways_mm = v, moved = true;
    if (name == "defocus_px") {
      s.optics.blur = v > 0 ? "gaussian" : "none";
      s.optics.blur_px = v;
    }
    if (name == "noise_x") {
      if (v == 0) {
        s.sensor.noise = false;
      } else {
        s.sensor.full_well_e /= v * v;
        s.sensor.read_noise_e /= v;
      }
    }
    if (name == "exposure") s.optics.exposure = v;
    if (name == "fill_factor") s.display.fill_factor = v;
    if (name == "radius_ratio") s.truth.curvature_per_mm = m.curvature_per_mm / v;
    if (name == "square_px") {
      spec.square_mm = v * m.pixel_pitch_mm();
      spec.cols = std::max(2, static_cast<int>(std::floor(0.9 * m.width_px / v)));
      spec.rows = std::max(2, static_cast<int>(std::floor(0.9 * m.height_px / v)));
    }
    if (name == "coverage") spec.margin = 0.5 * (1 - v);
  }
  // Pitch first (about x), then yaw (about y): the camera stays at its distance from the centre.
  offset = Eigen::AngleAxisd(yaw * M_PI / 180, Eigen::Vector3d::UnitY()) *
           (Eigen::AngleAxisd(-pitch * M_PI / 180, Eigen::Vector3d::UnitX()) * offset);
  const Eigen::Vector3d viewpoint = centre + offset;
  if (moved) {
    s.camera_position_in_screen = viewpoint + Eigen::Vector3d(sideways_mm, 0, 0);
    s.screen_from_cam = ScreenFromCamLookAt(s.camera_position_in_screen, centre, Eigen::Vector3d::UnitY());
  }

  std::string reason, detail, chosen, fit_status = "none";
  bool verification_pass = false, cached = false;
  double p95 = kNaN, rms = kNaN, radius = kNaN, sigma = kNaN, lo = kNaN, hi = kNaN;
  double render_ms = kNaN, photo_ms = kNaN, detect_ms = kNaN, verify_ms = kNaN, fit_ms = kNaN;
  int features = 0;
  std::string truth_in;
  const double true_radius = s.truth.curvature_per_mm != 0 ? 1 / s.truth.curvature_per_mm : INFINITY;
  const fs::path pattern_json = sw.scratch / fmt::format("point-{}.pattern.json", index);
  try {
    std::shared_ptr<const Image8> display;
    try {
      const Pattern pattern = BuildPattern(spec, m, viewpoint, TangentPlaneAtCentre(m));
      display = DisplayImage(sw, method, viewpoint, spec, pattern, &render_ms, &cached);
      RenderOptions ro;
      ro.method.method = ParseMethod(method, "--method");
      WriteFileAtomic(pattern_json, PatternToJson(pattern, m, viewpoint, ro.method.ToJson()).dump() + "\n");
    } catch (const Error& e) {
      reason = "render_refused";
      detail = e.what();
    }
    if (reason.empty()) {
      auto t0 = std::chrono::steady_clock::now();
      const SyntheticPhoto photo = RenderSyntheticPhoto(s, *display);
      photo_ms = MsSince(t0);
      const AnalysisResult r = AnalyzeImages(s.camera, "scaled camera", {{fmt::format("point-{}", index), pattern_json}},
                                             {PhotoToMat(photo)}, sw.analyze);
      const PhotoAnalysis& p = r.photos.front();
      detect_ms = p.detection.time_ms;
      verify_ms = p.verify_ms;
      fit_ms = r.fit_ms;
      features = static_cast<int>(p.detection.features.size());
      if (!p.used) {
        reason = ReasonOfRejection(p.rejected);
        detail = p.rejected;
      } else {
        verification_pass = r.verification.pass;
        p95 = r.verification.p95_display_px;
        rms = r.verification.rms_display_px;
        if (!verification_pass) {
          reason = "verification_failed";
          detail = fmt::format("p95 {:.3f} display px > {:g}", p95, sw.args.tolerance);
        }
      }
      if (r.fit) {
        chosen = r.fit->Chosen().model;
        const ModelFit* cyl = nullptr;
        for (const ModelFit& c : r.fit->candidates) {
          if (c.model == "cylinder") cyl = &c;
        }
        if (!cyl) {
          fit_status = "failed";
          if (reason.empty()) reason = "fit_failed", detail = "no cylinder candidate (model list or too few features)";
        } else {
          if (cyl->radius_mm) {
            radius = *cyl->radius_mm;
            sigma = cyl->radius_sigma_mm.value_or(kNaN);
            lo = cyl->radius_ci95_mm[0];
            hi = cyl->radius_ci95_mm[1];
            truth_in = true_radius >= lo && true_radius <= hi ? "1" : "0";
          }
          if (!cyl->converged) {
            fit_status = "failed";
            if (reason.empty()) reason = "fit_failed", detail = cyl->condition_note;
          } else if (cyl->ill_conditioned || !cyl->radius_mm) {
            fit_status = "ill_conditioned";
            if (reason.empty()) {
              reason = "fit_ill_conditioned";
              detail = cyl->condition_note.empty()
                           ? fmt::format("flat inside the 95% interval (R > {:.0f} mm)", cyl->radius_lower_bound_mm)
                           : cyl->condition_note;
            }
          } else {
            fit_status = "ok";
          }
        }
      } else if (p.used) {
        fit_status = "failed";
        if (reason.empty()) {
          reason = r.fit_failure.find("features") != std::string::npos ? "too_few_features" : "fit_failed";
          detail = r.fit_failure;
        }
      }
    }
  } catch (const std::exception& e) {
    reason = "error";
    detail = e.what();
  }
  std::error_code ec;
  fs::remove(pattern_json, ec);
  // The scratch path depends on the output folder: keep it out of the row, so that shards written to other
  // folders give the same rows.
  for (size_t at = detail.find(pattern_json.string()); at != std::string::npos;
       at = detail.find(pattern_json.string(), at)) {
    detail.replace(at, pattern_json.string().size(), "pattern.json");
  }

  std::vector<std::string> row = {std::to_string(index), method};
  for (double v : values) row.push_back(Cell(v));
  const double err = radius - true_radius;
  for (const std::string& c :
       {std::to_string(sw.args.seed + index), std::string(reason.empty() ? "1" : "0"), reason,
        std::string(verification_pass ? "1" : "0"), Cell(p95), Cell(rms), std::to_string(features), chosen, fit_status,
        Cell(radius), Cell(sigma), Cell(lo), Cell(hi), Cell(true_radius), Cell(err), Cell(err / sigma), truth_in,
        Cell(cached ? 0.0 : render_ms), Cell(photo_ms), Cell(detect_ms), Cell(verify_ms),
        Cell(fit_ms), Cell(MsSince(t_point)), CellText(detail)}) {
    row.push_back(c);
  }
  return row;
}

nlohmann::json GridJson(const Sweep& sw, const std::vector<std::string>& models) {
  nlohmann::json factors = nlohmann::json::array();
  for (const SweepFactor& f : sw.factors) {
    factors.push_back({{"name", f.name}, {"start", f.start}, {"stop", f.stop}, {"count", f.count},
                       {"meaning", FindFactor(f.name).meaning}});
  }
  return {{"factors", factors},
          {"methods", sw.methods},
          {"scene", sw.args.scene},
          {"camera_scale", sw.args.scale},
          {"seed", sw.args.seed},
          {"models", models},
          {"board", {sw.args.cols, sw.args.rows}},
          {"tolerance_display_px", sw.args.tolerance},
          {"points", sw.points_per_method * static_cast<int>(sw.methods.size())}};
}

std::vector<SweepFactor> FactorsFromGrid(const nlohmann::json& grid) {
  std::vector<SweepFactor> factors;
  for (const auto& f : grid.at("factors")) {
    SweepFactor x;
    x.name = f.at("name").get<std::string>();
    x.start = f.at("start").get<double>();
    x.stop = f.at("stop").get<double>();
    x.count = f.at("count").get<int>();
    factors.push_back(x);
  }
  return factors;
}

// Writes sweep.csv, sweep.json, sweep.txt and the charts into `out`; prints the summary. `meta` is sweep.json
// without the outcome counts.
void WriteOutputs(const fs::path& out, SweepTable& table, nlohmann::json meta, const std::string& head) {
  const nlohmann::json& grid = meta.at("grid");
  const std::vector<SweepFactor> factors = FactorsFromGrid(grid);
  const std::vector<std::string> methods = grid.at("methods").get<std::vector<std::string>>();
  const double tolerance = grid.at("tolerance_display_px").get<double>();
  std::sort(table.rows.begin(), table.rows.end(),
            [](const auto& a, const auto& b) { return std::stol(a[0]) < std::stol(b[0]); });
  std::map<std::string, int> outcomes;
  for (size_t r = 0; r < table.rows.size(); ++r) {
    const std::string reason = table.Str(r, "reason");
    ++outcomes[reason.empty() ? "ok" : reason];
  }
  meta["outcomes"] = outcomes;
  meta["rows"] = table.rows.size();
  const std::string summary = SweepSummary(table, factors, methods, tolerance);
  WriteFileAtomic(out / "sweep.csv", table.ToCsv());
  WriteFileAtomic(out / "sweep.json", meta.dump(1) + "\n");
  const std::vector<fs::path> charts = WriteSweepCharts(table, factors, methods, tolerance, out);
  WriteFileAtomic(out / "sweep.txt", head + "\n" + summary);
  std::cout << "\n" << summary << "\nwrote " << (out / "sweep.csv").string() << ", sweep.json, sweep.txt";
  for (const fs::path& c : charts) std::cout << ", " << c.filename().string();
  std::cout << "\n";
}

void CheckOutputs(const fs::path& out, const std::vector<fs::path>& inputs) {
  for (const char* name : {"sweep.csv", "sweep.json", "sweep.txt"}) CheckNotAnInput(out / name, inputs);
}

int RunSweep(const SweepArgs& a) {
  auto sw = std::make_unique<Sweep>();
  sw->args = a;
  if (a.factors.empty() || a.factors.size() > 2) {
    throw Error("--factor", fmt::format("{} factors given", a.factors.size()),
                "give one or two, e.g. --factor yaw=0:40:5 --factor distance=800:2000:4");
  }
  for (const std::string& f : a.factors) sw->factors.push_back(ParseFactor(f));
  if (sw->factors.size() == 2 && sw->factors[0].name == sw->factors[1].name) {
    throw Error("--factor", "the same factor twice", "give two different factors");
  }
  if (a.method == "all") {
    sw->methods = {"exact", "none", "strips", "warp", "mesh"};
  } else {
    for (const std::string& m : Split(a.method, ',')) sw->methods.push_back(MethodName(ParseMethod(m, "--method")));
  }
  if (sw->methods.empty()) throw Error("--method", "no method given", "give exact, none, strips, warp, mesh or all");
  if (!(a.scale > 0 && a.scale <= 1)) throw Error("--scale", fmt::format("is {}", a.scale), "give 0 < scale <= 1");
  if (a.jobs < 1 || a.jobs > 256) throw Error("--jobs", fmt::format("is {}", a.jobs), "give 1 to 256 workers");
  if (!(a.tolerance > 0)) throw Error("--tolerance", "must be positive", "give display px, e.g. 0.5");
  if (a.seed < 0) throw Error("--seed", "must be 0 or more", "");
  const auto [shard_i, shard_n] = ParseShard(a.shard);
  const std::vector<std::string> models = Split(a.models, ',');
  sw->analyze.fit.models = models;
  sw->analyze.verify.tolerance_display_px = a.tolerance;
  sw->analyze.Check("--models");

  const fs::path out = a.output;
  std::vector<fs::path> inputs;
  std::error_code ec;
  if (fs::exists(a.scene, ec)) inputs.emplace_back(a.scene);
  PrepareOutputDir(out, "-o");
  CheckOutputs(out, inputs);
  sw->scratch = out / fmt::format(".sweep-scratch-{}", shard_i);
  fs::create_directories(sw->scratch);
  fs::path scene_path = a.scene;
  if (!fs::exists(scene_path, ec)) {
    WriteDatasetFiles(sw->scratch / "datasets");
    scene_path = sw->scratch / "datasets" / "scenes" / (a.scene + ".yaml");
    if (!fs::exists(scene_path, ec)) {
      throw Error("--scene", fmt::format("'{}' is neither a file nor an embedded scene", a.scene),
                  "give a scene YAML or a name from datasets/scenes/ (default, off-axis, radius-8pct, ...)");
    }
  }
  sw->base = LoadScene(scene_path);
  sw->base.camera = ScaledCamera(sw->base.camera, a.scale);
  sw->points_per_method = 1;
  for (const SweepFactor& f : sw->factors) sw->points_per_method *= f.count;
  const int total = sw->points_per_method * static_cast<int>(sw->methods.size());
  std::vector<int> mine;
  for (int k = 0; k < total; ++k) {
    if (k % shard_n == shard_i - 1) mine.push_back(k);
  }

  std::string grid_text;
  for (const SweepFactor& f : sw->factors) {
    grid_text += fmt::format("{}{} = {:g}..{:g} ({} values)", grid_text.empty() ? "" : " x ", f.name, f.start, f.stop,
                             f.count);
  }
  const std::string head = fmt::format(
      "{}\n{}\nsweep: {}; methods {}; scene {} ({}), camera {} scaled to {} x {} px; {} points, shard {}/{} runs {} "
      "on {} worker thread(s)\n",
      CommandLine(), DescribeMachine(), grid_text, fmt::join(sw->methods, ","), a.scene, sw->base.monitor.name,
      sw->base.camera.lensmodel, sw->base.camera.width, sw->base.camera.height, total, shard_i, shard_n, mine.size(),
      a.jobs);
  std::cout << head << std::flush;

  SweepTable table;
  std::vector<std::string> names;
  for (const SweepFactor& f : sw->factors) names.push_back(f.name);
  table.header = SweepColumns(names);
  table.rows.resize(mine.size());
  std::atomic<size_t> next{0};
  std::atomic<int> done{0};
  const auto t_all = std::chrono::steady_clock::now();
  const auto work = [&] {
    for (size_t k = next++; k < mine.size(); k = next++) {
      table.rows[k] = RunPoint(*sw, mine[k]);
      const std::vector<std::string>& row = table.rows[k];
      std::string values;
      for (size_t f = 0; f < names.size(); ++f) values += fmt::format(" {}={}", names[f], row[2 + f]);
      const int d = ++done;
      std::lock_guard<std::mutex> lock(sw->print_mutex);
      std::cout << fmt::format("[{}/{}] #{} {}{}: {} p95 {} px, R {} +- {} mm, {} ms\n", d, mine.size(), mine[k],
                               row[1], values, row[static_cast<size_t>(table.Col("success"))] == "1"
                                                   ? std::string("ok")
                                                   : row[static_cast<size_t>(table.Col("reason"))],
                               row[static_cast<size_t>(table.Col("verification_p95_display_px"))],
                               row[static_cast<size_t>(table.Col("radius_mm"))],
                               row[static_cast<size_t>(table.Col("radius_sigma_mm"))],
                               row[static_cast<size_t>(table.Col("point_ms"))])
                << std::flush;
    }
  };
  std::vector<std::thread> pool;
  for (int j = 1; j < a.jobs; ++j) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  const double wall_s = MsSince(t_all) / 1000;
  fs::remove_all(sw->scratch, ec);

  std::vector<double> point_ms;
  for (size_t r = 0; r < table.rows.size(); ++r) point_ms.push_back(table.Num(r, "point_ms"));
  const std::string timing = fmt::format("{} points in {:.1f} s wall on {} worker(s): {:.2f} s per point; median point "
                                         "latency {:.0f} ms\n",
                                         mine.size(), wall_s, a.jobs, mine.empty() ? 0.0 : wall_s / mine.size(),
                                         Median(point_ms));
  std::cout << "\n" << timing;
  nlohmann::json meta = {{"format", "curvecheck.sweep/1"},
                         {"command", CommandLine()},
                         {"machine", DescribeMachine()},
                         {"grid", GridJson(*sw, models)},
                         {"shard", {{"index", shard_i}, {"count", shard_n}, {"points", mine.size()}}},
                         {"jobs", a.jobs},
                         {"wall_s", wall_s}};
  WriteOutputs(out, table, meta, head + timing);
  return 0;
}

// The folders to merge: each given folder with a sweep.json, or, for a folder without one, its subfolders that
// have one.
std::vector<fs::path> ShardDirs(const std::vector<std::string>& dirs) {
  std::vector<fs::path> found;
  std::error_code ec;
  for (const std::string& d : dirs) {
    if (fs::exists(fs::path(d) / "sweep.json", ec)) {
      found.emplace_back(d);
      continue;
    }
    std::vector<fs::path> sub;
    if (fs::is_directory(d, ec)) {
      for (const auto& e : fs::directory_iterator(d, ec)) {
        if (e.is_directory() && fs::exists(e.path() / "sweep.json", ec)) sub.push_back(e.path());
      }
    }
    if (sub.empty()) {
      throw Error(d, "holds no sweep.json, nor do its subfolders", "give the output folders of `curvecheck sweep`");
    }
    std::sort(sub.begin(), sub.end());
    found.insert(found.end(), sub.begin(), sub.end());
  }
  return found;
}

int RunMerge(const MergeArgs& a) {
  const std::vector<fs::path> dirs = ShardDirs(a.dirs);
  const fs::path out = a.output;
  std::vector<fs::path> inputs;
  for (const fs::path& d : dirs) {
    for (const char* name : {"sweep.csv", "sweep.json", "sweep.txt"}) inputs.push_back(d / name);
  }
  PrepareOutputDir(out, "-o");
  CheckOutputs(out, inputs);
  nlohmann::json grid;
  fs::path first;
  SweepTable table;
  std::map<long, fs::path> owner;
  nlohmann::json from = nlohmann::json::array();
  for (const fs::path& d : dirs) {
    const fs::path json_path = d / "sweep.json";
    nlohmann::json meta;
    try {
      meta = nlohmann::json::parse(ReadFileToString(json_path));
    } catch (const nlohmann::json::exception& e) {
      throw Error(json_path.string(), std::string("is not valid JSON: ") + e.what(), "give sweep outputs, unedited");
    }
    if (meta.value("format", "") != "curvecheck.sweep/1" || !meta.contains("grid")) {
      throw Error(json_path.string(), "is not a curvecheck.sweep/1 file", "give the output folders of `curvecheck sweep`");
    }
    if (first.empty()) {
      grid = meta["grid"];
      first = d;
    } else if (meta["grid"] != grid) {
      std::string what;
      for (const auto& [key, value] : grid.items()) {
        if (!meta["grid"].contains(key) || meta["grid"][key] != value) {
          what += fmt::format("{}{}: {} here, {} in {}", what.empty() ? "" : "; ", key,
                              meta["grid"].contains(key) ? meta["grid"][key].dump() : "missing", value.dump(),
                              first.string());
        }
      }
      throw Error(json_path.string(), "is a shard of a different sweep (" + what + ")",
                  "merge only the shards of one sweep command (same factors, methods, scene, scale, seed, models)");
    }
    const fs::path csv_path = d / "sweep.csv";
    SweepTable t = SweepTable::FromCsv(ReadFileToString(csv_path), csv_path.string());
    if (table.header.empty()) table.header = t.header;
    if (t.header != table.header) {
      throw Error(csv_path.string(), "has other columns than " + (first / "sweep.csv").string(),
                  "merge only the shards of one sweep command");
    }
    for (auto& row : t.rows) {
      const long index = std::stol(row[0]);
      const auto [it, inserted] = owner.emplace(index, d);
      if (!inserted) {
        throw Error(csv_path.string(), fmt::format("point {} is also in {}: the shards overlap", index, it->second.string()),
                    "merge each shard once (--shard i/n with the same n, each i once)");
      }
      table.rows.push_back(std::move(row));
    }
    from.push_back(d.string());
  }
  const int total = grid.at("points").get<int>();
  const int missing = total - static_cast<int>(table.rows.size());
  const std::string head =
      fmt::format("{}\nmerged {} folders: {} of {} points{}\n", CommandLine(), dirs.size(), table.rows.size(), total,
                  missing > 0 ? fmt::format(" ({} missing: merge the remaining shards for the full grid)", missing)
                              : std::string());
  std::cout << head;
  nlohmann::json meta = {{"format", "curvecheck.sweep/1"},
                         {"command", CommandLine()},
                         {"grid", grid},
                         {"merged_from", from},
                         {"missing_points", missing}};
  WriteOutputs(out, table, meta, head);
  return 0;
}

}  // namespace

void AddSweepCommand(CLI::App& app, std::function<int()>& run) {
  auto a = std::make_shared<SweepArgs>();
  auto m = std::make_shared<MergeArgs>();
  std::string factor_help = "NAME=start:stop:count (or NAME=value), once or twice. Factors:";
  for (const FactorInfo& f : kFactors) factor_help += fmt::format("\n  {} ({}): {}", f.name, f.alias, f.meaning);
  CLI::App* cmd = app.add_subcommand(
      "sweep", "Stability sweep: vary one or two scene factors over a grid; render, photograph (synthetic camera) and "
               "analyse each point; failure maps per method. `sweep merge` joins shards");
  cmd->add_option("--factor", a->factors, factor_help);
  cmd->add_option("--method", a->method, "exact|none|strips|warp|mesh, a comma list, or all")->capture_default_str();
  cmd->add_option("--scene", a->scene, "Scene YAML, or the name of an embedded scene")->capture_default_str();
  cmd->add_option("--scale", a->scale, "Camera imager scale (0 < s <= 1; 0.25: 1500 x 1000 px for the default)")
      ->capture_default_str();
  cmd->add_option("--jobs,-j", a->jobs, "Worker threads over the points")->capture_default_str();
  cmd->add_option("--shard", a->shard, "Run only shard i of n (points k with k mod n = i - 1)")->capture_default_str();
  cmd->add_option("--seed", a->seed, "Noise seed of point 0 (point k uses seed + k)")->capture_default_str();
  cmd->add_option("--models", a->models, "Screen models to fit, comma-separated")->capture_default_str();
  cmd->add_option("--cols", a->cols, "Checkerboard squares across")->capture_default_str();
  cmd->add_option("--rows", a->rows, "Checkerboard squares down")->capture_default_str();
  cmd->add_option("--tolerance", a->tolerance, "Verification tolerance, display px (p95)")->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Output folder")->capture_default_str();
  CLI::App* merge = cmd->add_subcommand("merge", "Merge sweep shards (folders, or one folder holding them) into one");
  merge->add_option("dirs", m->dirs, "Shard output folders, or a folder whose subfolders are shards")->required();
  merge->add_option("-o,--output", m->output, "Output folder of the merged sweep")->required();
  merge->callback([&run, m] { run = [m] { return RunMerge(*m); }; });
  cmd->callback([&run, a, merge] {
    if (!merge->parsed()) run = [a] { return RunSweep(*a); };
  });
}

}  // namespace curvecheck::app
