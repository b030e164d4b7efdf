#include "experiments/sweep.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/error.h"
#include "core/file_io.h"
#include "core/stats.h"
#include "core/stopwatch.h"
#include "experiments/machine_info.h"
#include "experiments/scene_lookup.h"
#include "experiments/shards.h"
#include "experiments/sweep_table.h"
#include "experiments/trial.h"
#include "experiments/trial_outcome.h"
#include "render/method.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Sweep {
  SweepOptions options;
  SyntheticScene base;  // camera already scaled
  fs::path scratch;
  AnalyzeOptions analyze;
  int points_per_method = 1;

  std::mutex render_mutex;
  std::unique_ptr<Renderer> renderer;
  std::deque<std::pair<std::string, std::shared_ptr<const TrialDisplay>>> cache;  // most recent first
};

// The display for (method, viewpoint, pattern): rendered under the lock, or from the cache (render_ms 0,
// cached true). Throws what RenderTrialDisplay throws (a pattern that does not fit, a method that refuses the
// view).
std::shared_ptr<const TrialDisplay> Display(Sweep& sw, const std::string& method,
                                            const Eigen::Vector3d& viewpoint, const PatternSpec& spec,
                                            double* render_ms, bool* cached) {
  const std::string key =
      fmt::format("{} {:.9g} {:.9g} {:.9g} {} {} {:.9g} {:.9g}", method, viewpoint.x(), viewpoint.y(),
                  viewpoint.z(), spec.cols, spec.rows, spec.square_mm, spec.margin);
  std::lock_guard<std::mutex> lock(sw.render_mutex);
  for (const auto& [k, display] : sw.cache) {
    if (k == key) {
      *cached = true;
      *render_ms = 0;
      return display;
    }
  }
  const Stopwatch watch;
  if (!sw.renderer) sw.renderer = std::make_unique<Renderer>();
  RenderOptions options;
  options.method.method = ParseMethod(method, "--method");
  auto display = std::make_shared<const TrialDisplay>(
      RenderTrialDisplay(*sw.renderer, sw.base.monitor, viewpoint, spec, options));
  *render_ms = watch.Ms();
  *cached = false;
  sw.cache.emplace_front(key, display);
  if (sw.cache.size() > 4) sw.cache.pop_back();
  return display;
}

// What a point's analysis says, as sweep.csv's columns.
struct PointResult {
  TrialOutcome outcome = TrialOutcome::kOk;
  std::string detail, chosen, fit_status = "none", truth_in;
  bool verification_pass = false;
  double p95 = kNaN, rms = kNaN, radius = kNaN, sigma = kNaN, lo = kNaN, hi = kNaN;
  double photo_ms = kNaN, detect_ms = kNaN, verify_ms = kNaN, fit_ms = kNaN;
  int features = 0;

  // The first failure that applies is the point's.
  void Fail(TrialOutcome o, const std::string& why) {
    if (outcome != TrialOutcome::kOk) return;
    outcome = o;
    detail = why;
  }
};

void Classify(const TrialAnalysis& t, double true_radius, double /*tolerance_display_px: applied by the analysis*/, PointResult& p) {
  const AnalysisResult& r = t.analysis;
  const PhotoAnalysis& photo = r.photos.front();
  p.photo_ms = t.photo_ms;
  p.detect_ms = photo.detection.time_ms;
  p.verify_ms = photo.verify_ms;
  p.fit_ms = r.fit_ms;
  p.features = static_cast<int>(photo.detection.features.size());
  if (!photo.used) {
    p.Fail(OutcomeOfRejection(photo), photo.rejected);
  } else {
    p.verification_pass = r.verification.pass;
    p.p95 = r.verification.p95_display_px;
    p.rms = r.verification.rms_display_px;
    if (r.verification.verdict == Verdict::kFail) {
      p.Fail(TrialOutcome::kVerificationFailed, r.verification.verdict_reason);
    } else if (r.verification.verdict == Verdict::kInconclusive) {
      p.Fail(TrialOutcome::kVerificationInconclusive, r.verification.verdict_reason);
    }
  }
  if (!r.fit) {
    if (photo.used) {
      p.fit_status = "failed";
      p.Fail(OutcomeOfFitFailure(r.fit_failure_kind), r.fit_failure);
    }
    return;
  }
  p.chosen = r.fit->Chosen().model;
  const ModelFit* cyl = CylinderCandidate(r);
  if (!cyl) {
    p.fit_status = "failed";
    p.Fail(TrialOutcome::kFitFailed, "no cylinder candidate (model list or too few features)");
    return;
  }
  if (cyl->radius_mm) {
    p.radius = *cyl->radius_mm;
    p.sigma = cyl->radius_sigma_mm.value_or(kNaN);
    p.lo = cyl->radius_ci95_mm[0];
    p.hi = cyl->radius_ci95_mm[1];
    p.truth_in = true_radius >= p.lo && true_radius <= p.hi ? "1" : "0";
  }
  if (!cyl->converged) {
    p.fit_status = "failed";
    p.Fail(TrialOutcome::kFitFailed, cyl->condition_note);
  } else if (cyl->ill_conditioned || !cyl->radius_mm) {
    p.fit_status = "ill_conditioned";
    p.Fail(TrialOutcome::kFitIllConditioned,
           cyl->condition_note.empty()
               ? fmt::format("flat inside the 95% interval (R > {:.0f} mm)", cyl->radius_lower_bound_mm)
               : cyl->condition_note);
  } else {
    p.fit_status = "ok";
  }
}

// One grid point, as its sweep.csv row.
std::vector<std::string> RunPoint(Sweep& sw, int index) {
  const Stopwatch point_watch;
  const SweepOptions& o = sw.options;
  const std::string method = o.methods[static_cast<size_t>(index / sw.points_per_method)];
  std::vector<double> values(o.factors.size());
  int rest = index % sw.points_per_method;
  for (size_t f = o.factors.size(); f-- > 0;) {
    values[f] = o.factors[f].Value(rest % o.factors[f].count);
    rest /= o.factors[f].count;
  }
  PatternSpec spec;
  spec.cols = o.cols;
  spec.rows = o.rows;
  SweepPoint point = MakeSweepPoint(sw.base, spec, o.factors, values);
  SyntheticScene& s = point.scene;
  s.sensor.seed = static_cast<uint64_t>(o.seed + index);

  PointResult p;
  bool cached = false;
  double render_ms = kNaN;
  const double true_radius = s.truth.curvature_per_mm != 0 ? 1 / s.truth.curvature_per_mm : INFINITY;
  const fs::path pattern_json = sw.scratch / fmt::format("point-{}.pattern.json", index);
  try {
    std::shared_ptr<const TrialDisplay> display;
    try {
      display = Display(sw, method, point.viewpoint_in_screen, point.spec, &render_ms, &cached);
      WriteFileAtomic(pattern_json, display->PatternJson().dump() + "\n");
    } catch (const Error& e) {
      p.Fail(TrialOutcome::kRenderRefused, e.what());
    }
    if (p.outcome == TrialOutcome::kOk) {
      const TrialAnalysis t = PhotographAndAnalyse(
          s, display->image, {fmt::format("point-{}", index), pattern_json}, "scaled camera", sw.analyze);
      Classify(t, true_radius, o.tolerance_display_px, p);
    }
  } catch (const std::exception& e) {
    p.outcome = TrialOutcome::kError;
    p.detail = e.what();
  }
  std::error_code ec;
  fs::remove(pattern_json, ec);
  // The scratch path depends on the output folder: keep it out of the row, so that shards written to other
  // folders give the same rows.
  for (size_t at = p.detail.find(pattern_json.string()); at != std::string::npos;
       at = p.detail.find(pattern_json.string(), at)) {
    p.detail.replace(at, pattern_json.string().size(), "pattern.json");
  }

  std::vector<std::string> row = {std::to_string(index), method};
  for (double v : values) row.push_back(Cell(v));
  const double err = p.radius - true_radius;
  const bool ok = p.outcome == TrialOutcome::kOk;
  for (const std::string& c : {std::to_string(o.seed + index),
                               std::string(ok ? "1" : "0"),
                               std::string(TrialOutcomeName(p.outcome)),
                               std::string(p.verification_pass ? "1" : "0"),
                               Cell(p.p95),
                               Cell(p.rms),
                               std::to_string(p.features),
                               p.chosen,
                               p.fit_status,
                               // Radii of ~1000 mm to 1e-5 mm, as the error column beside them (6 digits
                               // had left 0.01 mm, and radius - truth disagreeing with radius_error_mm).
                               Cell(p.radius, 9),
                               Cell(p.sigma),
                               Cell(p.lo, 9),
                               Cell(p.hi, 9),
                               Cell(true_radius),
                               Cell(err),
                               Cell(err / p.sigma),
                               p.truth_in,
                               Cell(cached ? 0.0 : render_ms),
                               Cell(p.photo_ms),
                               Cell(p.detect_ms),
                               Cell(p.verify_ms),
                               Cell(p.fit_ms),
                               Cell(point_watch.Ms()),
                               CellText(p.detail)}) {
    row.push_back(c);
  }
  return row;
}

nlohmann::json GridJson(const Sweep& sw) {
  const SweepOptions& o = sw.options;
  nlohmann::json factors = nlohmann::json::array();
  for (const SweepFactor& f : o.factors) {
    factors.push_back({{"name", f.name},
                       {"start", f.start},
                       {"stop", f.stop},
                       {"count", f.count},
                       {"meaning", FindFactor(f.name).meaning}});
  }
  return {{"factors", factors},
          {"methods", o.methods},
          {"scene", o.scene},
          {"camera_scale", o.camera_scale},
          {"seed", o.seed},
          {"models", o.models},
          {"board", {o.cols, o.rows}},
          {"tolerance_display_px", o.tolerance_display_px},
          {"points", sw.points_per_method * static_cast<int>(o.methods.size())}};
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
void WriteOutputs(const fs::path& out, SweepTable& table, nlohmann::json meta, const std::string& head,
                  std::ostream& log) {
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
  log << "\n" << summary << "\nwrote " << (out / "sweep.csv").string() << ", sweep.json, sweep.txt";
  for (const fs::path& c : charts) log << ", " << c.filename().string();
  log << "\n";
}

}  // namespace

void SweepOptions::Check() const {
  if (!(camera_scale > 0 && camera_scale <= 1)) {
    throw Error("--scale", fmt::format("is {}", camera_scale), "give 0 < scale <= 1");
  }
  if (jobs < 1 || jobs > 256) throw Error("--jobs", fmt::format("is {}", jobs), "give 1 to 256 workers");
  if (!(tolerance_display_px > 0)) throw Error("--tolerance", "must be positive", "give display px, e.g. 0.5");
  if (seed < 0) throw Error("--seed", "must be 0 or more", "");
  // 2 squares is the smallest checkerboard; 1000 across a 5120-px display leaves 5 px squares, below what the
  // detectors find, and bounds the feature count a point allocates.
  RequireInRange("--cols", "the number of squares across", cols, 2, 1000, "give 2 to 1000, e.g. 32");
  RequireInRange("--rows", "the number of squares down", rows, 2, 1000, "give 2 to 1000, e.g. 9");
  Shard{shard_index, shard_count}.Check();
  AnalyzeOptions analyze;
  analyze.fit.models = ParseScreenModels(models, "--models");
  analyze.Check("--models");
}

void RunSweep(const SweepOptions& o, const fs::path& out, std::ostream& log) {
  o.Check();
  auto sw = std::make_unique<Sweep>();
  sw->options = o;
  sw->analyze.fit.models = ParseScreenModels(o.models, "--models");
  sw->analyze.verify.tolerance_display_px = o.tolerance_display_px;
  sw->base = FindScene(o.scene, "--scene");
  sw->base.camera = ScaledCamera(sw->base.camera, o.camera_scale);
  sw->scratch = out / fmt::format(".sweep-scratch-{}", o.shard_index);
  fs::create_directories(sw->scratch);
  for (const SweepFactor& f : o.factors) sw->points_per_method *= f.count;
  const int total = sw->points_per_method * static_cast<int>(o.methods.size());
  std::vector<int> mine;
  for (int k = 0; k < total; ++k) {
    if (Shard{o.shard_index, o.shard_count}.Has(k)) mine.push_back(k);
  }

  std::string grid_text;
  for (const SweepFactor& f : o.factors) {
    grid_text += fmt::format("{}{} = {:g}..{:g} ({} values)", grid_text.empty() ? "" : " x ", f.name, f.start,
                             f.stop, f.count);
  }
  const std::string machine = DescribeMachine();
  const std::string head = fmt::format(
      "{}\n{}\nsweep: {}; methods {}; scene {} ({}), camera {} scaled to {} x {} px; {} points, shard {}/{} "
      "runs {} "
      "on {} worker thread(s)\n",
      o.command_line, machine, grid_text, fmt::join(o.methods, ","), o.scene, sw->base.monitor.name,
      sw->base.camera.lensmodel, sw->base.camera.width, sw->base.camera.height, total, o.shard_index,
      o.shard_count, mine.size(), o.jobs);
  log << head << std::flush;

  SweepTable table;
  std::vector<std::string> names;
  for (const SweepFactor& f : o.factors) names.push_back(f.name);
  table.header = SweepColumns(names);
  table.rows.resize(mine.size());
  std::atomic<size_t> next{0};
  std::atomic<int> done{0};
  std::mutex log_mutex;
  const Stopwatch wall;
  const auto cell = [&](const std::vector<std::string>& row, const char* column) {
    return row[static_cast<size_t>(table.Col(column))];
  };
  const auto work = [&] {
    for (size_t k = next++; k < mine.size(); k = next++) {
      table.rows[k] = RunPoint(*sw, mine[k]);
      const std::vector<std::string>& row = table.rows[k];
      std::string values;
      for (size_t f = 0; f < names.size(); ++f) values += fmt::format(" {}={}", names[f], row[2 + f]);
      const int d = ++done;
      std::lock_guard<std::mutex> lock(log_mutex);
      log << fmt::format("[{}/{}] #{} {}{}: {} p95 {} px, R {} +- {} mm, {} ms\n", d, mine.size(), mine[k],
                         row[1], values,
                         cell(row, "success") == "1" ? std::string("ok") : cell(row, "reason"),
                         cell(row, "verification_p95_display_px"), cell(row, "radius_mm"),
                         cell(row, "radius_sigma_mm"), cell(row, "point_ms"))
          << std::flush;
    }
  };
  std::vector<std::thread> pool;
  for (int j = 1; j < o.jobs; ++j) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  const double wall_s = wall.Seconds();
  std::error_code ec;
  fs::remove_all(sw->scratch, ec);

  std::vector<double> point_ms;
  for (size_t r = 0; r < table.rows.size(); ++r) point_ms.push_back(table.Num(r, "point_ms"));
  const std::string timing = fmt::format(
      "{} points in {:.1f} s wall on {} worker(s): {:.2f} s per point; median point "
      "latency {:.0f} ms\n",
      mine.size(), wall_s, o.jobs, mine.empty() ? 0.0 : wall_s / mine.size(), Median(point_ms));
  log << "\n" << timing;
  nlohmann::json meta = {
      {"format", "curvecheck.sweep/1"},
      {"command", o.command_line},
      {"machine", machine},
      {"grid", GridJson(*sw)},
      {"shard", {{"index", o.shard_index}, {"count", o.shard_count}, {"points", mine.size()}}},
      {"jobs", o.jobs},
      {"wall_s", wall_s}};
  WriteOutputs(out, table, meta, head + timing, log);
}

const ShardFiles& SweepShardFiles() {
  static const ShardFiles files{"sweep.json",      "sweep.csv", "curvecheck.sweep/1", "curvecheck sweep",
                                "sweep",           "same factors, methods, scene, scale, seed, models",
                                {"method", "reason"},
                                "/rows"};
  return files;
}

void MergeSweeps(const std::vector<fs::path>& dirs, const fs::path& out, const std::string& command_line,
                 std::ostream& log) {
  MergedShards merged = ReadShards(dirs, SweepShardFiles());
  const nlohmann::json& grid = merged.grid;
  SweepTable& table = merged.table;
  const nlohmann::json& from = merged.merged_from;
  const int total = grid.at("points").get<int>();
  const int missing = total - static_cast<int>(table.rows.size());
  const std::string head = fmt::format(
      "{}\nmerged {} folders: {} of {} points{}\n", command_line, dirs.size(), table.rows.size(), total,
      missing > 0 ? fmt::format(" ({} missing: merge the remaining shards for the full grid)", missing)
                  : std::string());
  log << head;
  nlohmann::json meta = {{"format", "curvecheck.sweep/1"},
                         {"command", command_line},
                         {"grid", grid},
                         {"merged_from", from},
                         {"missing_points", missing}};
  WriteOutputs(out, table, meta, head, log);
}

}  // namespace curvecheck::experiments
