#include "experiments/bench_verdict.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/file_io.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "core/stopwatch.h"
#include "experiments/machine_info.h"
#include "experiments/scene_lookup.h"
#include "experiments/sweep_table.h"
#include "experiments/trial.h"
#include "experiments/true_correction_error.h"
#include "experiments/verdict_tally.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

enum class Case { kCorrect, kOffset, kRadius };
constexpr Case kCases[] = {Case::kCorrect, Case::kOffset, Case::kRadius};
const char* CaseName(Case c) {
  switch (c) {
    case Case::kCorrect: return "correct";
    case Case::kOffset: return "offset";
    case Case::kRadius: return "radius";
  }
  return "";
}

// The rows of the confusion matrix.
enum class Truth { kCorrect, kWrong, kWithinTolerance };
const char* TruthName(Truth t) {
  switch (t) {
    case Truth::kCorrect: return "correct";
    case Truth::kWrong: return "wrong";
    case Truth::kWithinTolerance: return "within_tolerance";
  }
  return "";
}

struct Trial {
  int index = 0;
  double distance_mm = 0, scale = 0;
  std::string view;
  Case kase = Case::kCorrect;
  int trial = 0;
  uint64_t seed = 0;
  double offset_direction_deg = kNaN;
  Eigen::Vector3d camera = Eigen::Vector3d::Zero(), stated_viewpoint = Eigen::Vector3d::Zero();
  double true_radius_mm = kNaN;
  int camera_width = 0, camera_height = 0;
  // The truth.
  double true_p95 = kNaN, true_max = kNaN;
  int true_features = 0;
  Truth truth = Truth::kCorrect;
  // The verification.
  VerdictColumn verdict = VerdictColumn::kNone;
  double e = kNaN, u = kNaN, ratio = kNaN, raw_p95 = kNaN, raw_rms = kNaN, noise_px = kNaN, display_per_camera = kNaN;
  int features = 0, field_degree = -1;
  std::string detail;
  double render_ms = 0, photo_ms = kNaN, detect_ms = kNaN, verify_ms = kNaN, trial_ms = 0;
};

// A rendering and its pattern.json on disk, for one stated viewpoint.
struct ShownPattern {
  Eigen::Vector3d viewpoint;
  std::shared_ptr<const TrialDisplay> display;  // null when the renderer refused
  std::string refusal;
  fs::path pattern_json;
};

class Displays {
 public:
  Displays(const Monitor& monitor, const PatternSpec& spec, fs::path scratch)
      : monitor_(monitor), spec_(spec), scratch_(std::move(scratch)) {}
  // The rendering for `viewpoint` (exact method), from the last few or rendered now (*render_ms its time).
  const ShownPattern& Get(const Eigen::Vector3d& viewpoint, double* render_ms) {
    *render_ms = 0;
    for (const ShownPattern& s : cache_) {
      if ((s.viewpoint - viewpoint).norm() < 1e-9) return s;
    }
    const Stopwatch watch;
    ShownPattern s;
    s.viewpoint = viewpoint;
    try {
      if (!renderer_) renderer_ = std::make_unique<Renderer>();
      s.display = std::make_shared<const TrialDisplay>(RenderTrialDisplay(*renderer_, monitor_, viewpoint, spec_));
      s.pattern_json = scratch_ / fmt::format("display-{}.pattern.json", count_++);
      WriteFileAtomic(s.pattern_json, s.display->PatternJson().dump() + "\n");
    } catch (const Error& e) {
      s.display.reset();
      s.refusal = e.what();
    }
    *render_ms = watch.Ms();
    cache_.push_front(std::move(s));
    if (cache_.size() > 6) {
      std::error_code ec;
      fs::remove(cache_.back().pattern_json, ec);
      cache_.pop_back();
    }
    return cache_.front();
  }

 private:
  Monitor monitor_;
  PatternSpec spec_;
  fs::path scratch_;
  std::unique_ptr<Renderer> renderer_;
  std::deque<ShownPattern> cache_;
  int count_ = 0;
};

VerdictColumn ColumnOf(Verdict v) {
  switch (v) {
    case Verdict::kPass: return VerdictColumn::kPass;
    case Verdict::kFail: return VerdictColumn::kFail;
    case Verdict::kInconclusive: return VerdictColumn::kInconclusive;
  }
  return VerdictColumn::kNone;
}

// Runs one trial (its geometry already set: camera, case, seed) and fills the truth and the verdict.
void RunTrial(const SyntheticScene& base, const BenchVerdictOptions& o, const Pose& screen_from_cam,
              Displays& displays, const AnalyzeOptions& analyze, Trial& t) {
  const Stopwatch watch;
  SyntheticScene scene = base;
  scene.camera = ScaledCamera(base.camera, t.scale);
  t.camera_width = scene.camera.width;
  t.camera_height = scene.camera.height;
  scene.screen_from_cam = screen_from_cam;
  scene.sensor.seed = t.seed;
  if (t.kase == Case::kRadius) scene.truth.curvature_per_mm = 1 / o.wrong_radius_mm;
  t.truth = t.kase == Case::kCorrect ? Truth::kCorrect : Truth::kWrong;  // until the true error is known
  t.true_radius_mm = scene.truth.curvature_per_mm != 0 ? 1 / scene.truth.curvature_per_mm : INFINITY;
  try {
    const ShownPattern& shown = displays.Get(t.stated_viewpoint, &t.render_ms);
    if (!shown.display) {
      t.detail = "render refused: " + shown.refusal;
      t.trial_ms = watch.Ms();
      return;
    }
    const TrueCorrectionError truth = MeasureTrueCorrectionError(scene, shown.display->pattern);
    t.true_p95 = truth.p95_display_px;
    t.true_max = truth.max_display_px;
    t.true_features = truth.features;
    t.truth = t.kase == Case::kCorrect                    ? Truth::kCorrect
              : t.true_p95 > o.tolerance_display_px ? Truth::kWrong
                                                          : Truth::kWithinTolerance;
    const TrialAnalysis a = PhotographAndAnalyse(scene, shown.display->image,
                                                 {fmt::format("trial-{}", t.index), shown.pattern_json},
                                                 "scaled camera", analyze);
    t.photo_ms = a.photo_ms;
    const PhotoAnalysis& p = a.analysis.photos.front();
    t.detect_ms = p.detection.time_ms;
    t.verify_ms = p.verify_ms;
    t.features = static_cast<int>(p.verification.features.size());
    if (!p.used) {
      t.detail = p.rejected;
    } else {
      const Verification& v = p.verification;
      t.verdict = ColumnOf(v.verdict);
      t.e = v.error_p95_display_px;
      t.u = v.expanded_uncertainty_display_px;
      t.ratio = v.tolerance_ratio;
      t.raw_p95 = v.p95_display_px;
      t.raw_rms = v.rms_display_px;
      t.noise_px = v.noise_px;
      t.display_per_camera = v.display_px_per_camera_px;
      t.field_degree = v.field_degree;
      t.detail = v.verdict_reason;
    }
  } catch (const std::exception& e) {
    t.verdict = VerdictColumn::kNone;
    t.detail = std::string("error: ") + e.what();
  }
  t.trial_ms = watch.Ms();
}

std::vector<std::string> CsvHeader() {
  return {"index",        "distance_mm",      "view",          "case",          "scale",
          "trial",        "seed",             "camera_px",     "offset_direction_deg",
          "camera_x_mm",  "camera_y_mm",      "camera_z_mm",   "stated_viewpoint_x_mm",
          "stated_viewpoint_y_mm",            "stated_viewpoint_z_mm",           "true_radius_mm",
          "true_error_p95_display_px",        "true_error_max_display_px",       "true_features",
          "truth",        "verdict",          "e_display_px",  "U_display_px",  "T_over_U",
          "raw_p95_display_px",               "raw_rms_display_px",              "noise_px",
          "display_px_per_camera_px",         "field_degree",  "features",      "render_ms",
          "photo_ms",     "detect_ms",        "verify_ms",     "trial_ms",      "detail"};
}

std::vector<std::string> CsvRow(const Trial& t) {
  return {std::to_string(t.index),
          Cell(t.distance_mm),
          t.view,
          CaseName(t.kase),
          Cell(t.scale),
          std::to_string(t.trial),
          std::to_string(t.seed),
          fmt::format("{}x{}", t.camera_width, t.camera_height),
          Cell(t.offset_direction_deg),
          Cell(t.camera.x()),
          Cell(t.camera.y()),
          Cell(t.camera.z()),
          Cell(t.stated_viewpoint.x()),
          Cell(t.stated_viewpoint.y()),
          Cell(t.stated_viewpoint.z()),
          Cell(t.true_radius_mm),
          Cell(t.true_p95),
          Cell(t.true_max),
          std::to_string(t.true_features),
          TruthName(t.truth),
          VerdictColumnName(t.verdict),
          Cell(t.e),
          Cell(t.u),
          Cell(t.ratio),
          Cell(t.raw_p95),
          Cell(t.raw_rms),
          Cell(t.noise_px),
          Cell(t.display_per_camera),
          std::to_string(t.field_degree),
          std::to_string(t.features),
          Cell(t.render_ms),
          Cell(t.photo_ms),
          Cell(t.detect_ms),
          Cell(t.verify_ms),
          Cell(t.trial_ms),
          CellText(t.detail)};
}

json TrialJson(const Trial& t) {
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  const auto vec = [](const Eigen::Vector3d& v) { return json{v.x(), v.y(), v.z()}; };
  return {{"index", t.index},
          {"distance_mm", t.distance_mm},
          {"view", t.view},
          {"case", CaseName(t.kase)},
          {"scale", t.scale},
          {"trial", t.trial},
          {"seed", t.seed},
          {"camera_px", {t.camera_width, t.camera_height}},
          {"offset_direction_deg", num(t.offset_direction_deg)},
          {"camera_mm", vec(t.camera)},
          {"stated_viewpoint_mm", vec(t.stated_viewpoint)},
          {"true_radius_mm", num(t.true_radius_mm)},
          {"true_error_p95_display_px", num(t.true_p95)},
          {"true_error_max_display_px", num(t.true_max)},
          {"true_features", t.true_features},
          {"truth", TruthName(t.truth)},
          {"verdict", VerdictColumnName(t.verdict)},
          {"e_display_px", num(t.e)},
          {"U_display_px", num(t.u)},
          {"T_over_U", num(t.ratio)},
          {"raw_p95_display_px", num(t.raw_p95)},
          {"raw_rms_display_px", num(t.raw_rms)},
          {"noise_px", num(t.noise_px)},
          {"display_px_per_camera_px", num(t.display_per_camera)},
          {"field_degree", t.field_degree},
          {"features", t.features},
          {"ms", {{"render", t.render_ms}, {"photo", num(t.photo_ms)}, {"detect", num(t.detect_ms)},
                  {"verify", num(t.verify_ms)}, {"trial", t.trial_ms}}},
          {"detail", t.detail}};
}

std::string Join(const std::vector<std::string>& cells) {
  std::string s;
  for (size_t i = 0; i < cells.size(); ++i) s += (i ? "," : "") + cells[i];
  return s + "\n";
}

// The counts of a set of trials: one row per truth (wrong split by case), and the rates.
struct Tally {
  VerdictCounts correct, wrong_offset, wrong_radius, within;
  std::vector<double> wrong_true_p95, u, trial_ms;
  // Trials with e, U and the true error: whether [e - U, e + U] holds the true error (U is a 95% expanded
  // uncertainty: it should, 90-98% of the time; metrology.md section 1). Correct ones apart: their truth is
  // exactly 0, while a wrong one's true p95 and the verification's e are estimates of one error by two routes
  // (display-px Jacobians of the true geometry against those of the rendering), which can differ by a few %.
  int covered_correct = 0, with_e_correct = 0, covered_other = 0, with_e_other = 0;

  void Add(const Trial& t) {
    trial_ms.push_back(t.trial_ms);
    if (std::isfinite(t.u)) u.push_back(t.u);
    if (std::isfinite(t.e) && std::isfinite(t.u) && std::isfinite(t.true_p95)) {
      const bool covered = std::abs(t.e - t.true_p95) <= t.u;
      (t.truth == Truth::kCorrect ? covered_correct : covered_other) += covered ? 1 : 0;
      ++(t.truth == Truth::kCorrect ? with_e_correct : with_e_other);
    }
    switch (t.truth) {
      case Truth::kCorrect: correct.Add(t.verdict); break;
      case Truth::kWrong:
        (t.kase == Case::kOffset ? wrong_offset : wrong_radius).Add(t.verdict);
        wrong_true_p95.push_back(t.true_p95);
        break;
      case Truth::kWithinTolerance: within.Add(t.verdict); break;
    }
  }
  VerdictCounts Wrong() const {
    VerdictCounts w = wrong_offset;
    w.Add(wrong_radius);
    return w;
  }
  json ToJson() const {
    const auto counts = [](const VerdictCounts& c) {
      return json{{"pass", c.pass}, {"fail", c.fail}, {"inconclusive", c.inconclusive}, {"none", c.none}};
    };
    const auto rate = [](int k, int n) {
      const BinomialInterval ci = WilsonInterval(k, n);
      return json{{"k", k}, {"n", n}, {"rate", n > 0 ? json(double(k) / n) : json(nullptr)},
                  {"wilson95", {ci.lo, ci.hi}}};
    };
    const VerdictCounts w = Wrong();
    return {{"correct", counts(correct)},
            {"wrong_offset", counts(wrong_offset)},
            {"wrong_radius", counts(wrong_radius)},
            {"within_tolerance", counts(within)},
            {"false_fail_on_correct", rate(correct.fail, correct.Verdicts())},
            {"false_pass_on_wrong", rate(w.pass, w.Verdicts())},
            {"inconclusive_on_correct", rate(correct.inconclusive, correct.Verdicts())},
            {"inconclusive_on_wrong", rate(w.inconclusive, w.Verdicts())},
            {"e_pm_U_holds_true_error_correct", rate(covered_correct, with_e_correct)},
            {"e_pm_U_holds_true_error_perturbed", rate(covered_other, with_e_other)},
            {"median_U_display_px", u.empty() ? json(nullptr) : json(Median(u))},
            {"median_trial_ms", Median(trial_ms)}};
  }
};

std::string MatrixText(const Tally& t, const BenchVerdictOptions& o) {
  std::string s = fmt::format("{:<46} {:>6} {:>6} {:>13} {:>11} {:>6}\n", "truth \\ verdict", "pass", "fail",
                              "inconclusive", "no verdict", "total");
  const auto row = [&](const std::string& name, const VerdictCounts& c) {
    s += fmt::format("{:<46} {:>6} {:>6} {:>13} {:>11} {:>6}\n", name, c.pass, c.fail, c.inconclusive, c.none,
                     c.Total());
  };
  row("correct", t.correct);
  row(fmt::format("wrong: viewpoint misstated by {:g} mm", o.offset_mm), t.wrong_offset);
  row(fmt::format("wrong: true R {:g} mm, rendered for nominal", o.wrong_radius_mm), t.wrong_radius);
  if (t.within.Total() > 0) row("perturbed, but true error <= T", t.within);
  const VerdictCounts w = t.Wrong();
  s += fmt::format("false-fail rate on correct: {}   (target <= 5%)\n",
                   RateText(t.correct.fail, t.correct.Verdicts()));
  s += fmt::format("false-pass rate on wrong:   {}   (target <= 5%)\n", RateText(w.pass, w.Verdicts()));
  s += fmt::format("inconclusive: correct {}, wrong {}\n", RateText(t.correct.inconclusive, t.correct.Verdicts()),
                   RateText(w.inconclusive, w.Verdicts()));
  s += fmt::format("e +- U holds the true error (95% expanded uncertainty: expect 90-98%): correct {}, perturbed {}\n",
                   RateText(t.covered_correct, t.with_e_correct), RateText(t.covered_other, t.with_e_other));
  return s;
}

}  // namespace

void BenchVerdictOptions::Check() const {
  if (scales.empty()) throw Error("--scales", "is empty", "give e.g. 0.25,0.5,1");
  for (double s : scales) {
    if (!(s > 0 && s <= 1)) throw Error("--scales", fmt::format("{} is outside (0, 1]", s), "give e.g. 0.25,0.5,1");
  }
  if (distances_mm.empty()) throw Error("--distances", "is empty", "give mm, e.g. 1000,2000,3000");
  for (double d : distances_mm) {
    if (!(d >= 300 && d <= 20000)) {
      throw Error("--distances", fmt::format("{} mm is outside 300..20000 mm", d),
                  "give the camera's distance from the screen centre in mm, e.g. 1000,2000,3000");
    }
  }
  if (views.empty()) throw Error("--views", "is empty", "give on-axis, off-axis or both");
  for (const std::string& v : views) {
    if (v != "on-axis" && v != "off-axis") {
      throw Error("--views", fmt::format("'{}' is not a view", v), "give on-axis, off-axis or both");
    }
  }
  CheckCount(trials, 1, 10000, "--trials");
  if (seed < 0) throw Error("--seed", "must be 0 or more", "");
  if (!(offset_mm > 0) || !(wrong_radius_mm > 0) || !(tolerance_display_px > 0)) {
    throw Error("bench verdict", "the offset, the wrong radius and the tolerance must be positive", "");
  }
  if (!(std::abs(off_axis_yaw_deg) < 80 && std::abs(off_axis_pitch_deg) < 80)) {
    throw Error("bench verdict", "the off-axis angles must be within +-80 deg", "");
  }
}

void RunBenchVerdict(const BenchVerdictOptions& o, const fs::path& out, std::ostream& log) {
  o.Check();
  const SyntheticScene base = FindScene(o.scene, "--scene");
  const Monitor& m = base.monitor;
  const Eigen::Vector3d centre = ScreenCentreInScreen(m);
  PatternSpec spec;
  spec.cols = o.cols;
  spec.rows = o.rows;
  AnalyzeOptions analyze;
  analyze.fit_screen = false;
  analyze.verify.tolerance_display_px = o.tolerance_display_px;
  const fs::path scratch = out / ".verdict-scratch";
  fs::create_directories(scratch);
  Displays displays(m, spec, scratch);

  const std::string machine = DescribeMachine();
  const int n_trials = static_cast<int>(o.distances_mm.size() * o.views.size() * std::size(kCases) *
                                        o.scales.size()) * o.trials;
  const std::string head = fmt::format(
      "{}\n{}\nbench verdict: scene {} ({}), camera {} {}x{} scaled by {}; distances {} mm; views {} "
      "(off axis: yaw {:g} deg, pitch {:g} deg around the screen centre); {}x{} board; cases correct, viewpoint "
      "misstated by {:g} mm, true R {:g} mm; {} trials per cell, {} trials; seed {}; T = {:g} display px\n",
      o.command_line, machine, o.scene, m.name, base.camera.lensmodel, base.camera.width, base.camera.height, fmt::join(o.scales, ","),
      fmt::join(o.distances_mm, ","), fmt::join(o.views, ","), o.off_axis_yaw_deg, o.off_axis_pitch_deg, o.cols,
      o.rows, o.offset_mm, o.wrong_radius_mm, o.trials, n_trials, o.seed, o.tolerance_display_px);
  log << head << std::flush;

  std::vector<Trial> trials;
  const Stopwatch wall;
  int index = 0;
  for (double distance : o.distances_mm) {
    for (const std::string& view : o.views) {
      const bool off = view == "off-axis";
      const Eigen::Vector3d direction =
          Eigen::AngleAxisd((off ? o.off_axis_yaw_deg : 0) * M_PI / 180, Eigen::Vector3d::UnitY()) *
          (Eigen::AngleAxisd(-(off ? o.off_axis_pitch_deg : 0) * M_PI / 180, Eigen::Vector3d::UnitX()) *
           Eigen::Vector3d::UnitZ());
      const Eigen::Vector3d camera = centre + distance * direction;
      const Pose screen_from_cam = ScreenFromCamLookAt(camera, centre, Eigen::Vector3d::UnitY());
      const Eigen::Matrix3d axes = screen_from_cam.RotationMatrix();
      const Eigen::Vector3d right = axes.col(0), up = -axes.col(1);  // camera y points down
      for (Case kase : kCases) {
        for (double scale : o.scales) {
          for (int k = 0; k < o.trials; ++k, ++index) {
            Trial t;
            t.index = index;
            t.distance_mm = distance;
            t.view = view;
            t.kase = kase;
            t.scale = scale;
            t.trial = k;
            t.seed = static_cast<uint64_t>(o.seed + index);
            t.camera = camera;
            t.stated_viewpoint = camera;
            if (kase == Case::kOffset) {
              t.offset_direction_deg = 90.0 * (k % 4);
              const double a = t.offset_direction_deg * M_PI / 180;
              t.stated_viewpoint = camera + o.offset_mm * (std::cos(a) * right + std::sin(a) * up);
            }
            RunTrial(base, o, screen_from_cam, displays, analyze, t);
            log << fmt::format(
                       "[{}/{}] {:g} mm {} {} scale {:g} #{}: truth {} (true p95 {:.3f}), verdict {} (e {:.3f}, U "
                       "{:.3f}, raw p95 {:.3f}){}; {:.0f} ms\n",
                       index + 1, n_trials, distance, view, CaseName(kase), scale, k, TruthName(t.truth),
                       t.true_p95, VerdictColumnName(t.verdict), t.e, t.u, t.raw_p95,
                       t.verdict == VerdictColumn::kNone ? " - " + t.detail : "", t.trial_ms)
                << std::flush;
            trials.push_back(std::move(t));
          }
        }
      }
    }
  }
  const double wall_s = wall.Seconds();
  std::error_code ec;
  fs::remove_all(scratch, ec);

  // Tallies: overall, per scale x distance.
  Tally all;
  std::map<std::pair<double, double>, Tally> cells;
  std::map<double, std::vector<double>> ms_per_scale;
  for (const Trial& t : trials) {
    all.Add(t);
    cells[{t.scale, t.distance_mm}].Add(t);
    ms_per_scale[t.scale].push_back(t.trial_ms);
  }
  std::string summary = "\nconfusion matrix, all trials:\n" + MatrixText(all, o);
  summary += fmt::format("\n{:>5} {:>8}  {:<32} {:>5}  {:<32} {:>5} {:>11} {:>9} {:>9}\n", "scale", "dist mm",
                         "false fail on correct [95%]", "inc", "false pass on wrong [95%]", "inc",
                         "wrong e_true", "median U", "covered");
  json per_cell = json::array();
  for (const auto& [key, t] : cells) {
    const VerdictCounts w = t.Wrong();
    summary += fmt::format("{:>5g} {:>8g}  {:<32} {:>5}  {:<32} {:>5} {:>11} {:>9} {:>9}\n", key.first, key.second,
                           RateText(t.correct.fail, t.correct.Verdicts()), t.correct.inconclusive,
                           RateText(w.pass, w.Verdicts()), w.inconclusive,
                           t.wrong_true_p95.empty() ? std::string("-")
                                                    : fmt::format("{:.2f}-{:.2f}",
                                                                  *std::min_element(t.wrong_true_p95.begin(),
                                                                                    t.wrong_true_p95.end()),
                                                                  *std::max_element(t.wrong_true_p95.begin(),
                                                                                    t.wrong_true_p95.end())),
                           t.u.empty() ? std::string("-") : fmt::format("{:.3f}", Median(t.u)),
                           fmt::format("{}/{}", t.covered_correct + t.covered_other,
                                       t.with_e_correct + t.with_e_other));
    json c = t.ToJson();
    c["scale"] = key.first;
    c["distance_mm"] = key.second;
    per_cell.push_back(std::move(c));
  }
  summary += "(inc: inconclusive; wrong e_true: range of the wrong trials' true error p95, display px; U: the "
             "verification's expanded uncertainty, display px; covered: trials whose e +- U holds the true error)\n";
  std::string per_scale;
  for (const auto& [scale, ms] : ms_per_scale) {
    per_scale += fmt::format("{}{:g}: {:.2f} s", per_scale.empty() ? "" : ", ", scale, Median(ms) / 1000);
  }
  summary += fmt::format("\n{} trials in {:.1f} s wall: {:.2f} s per trial; median per trial by scale: {}\n",
                         trials.size(), wall_s, trials.empty() ? 0.0 : wall_s / trials.size(), per_scale);
  log << summary;

  std::string csv = Join(CsvHeader());
  json rows = json::array();
  for (const Trial& t : trials) {
    csv += Join(CsvRow(t));
    rows.push_back(TrialJson(t));
  }
  const json meta = {
      {"format", "curvecheck.bench.verdict/1"},
      {"command", o.command_line},
      {"machine", machine},
      {"options",
       {{"scene", o.scene},
        {"scales", o.scales},
        {"distances_mm", o.distances_mm},
        {"views", o.views},
        {"off_axis_yaw_deg", o.off_axis_yaw_deg},
        {"off_axis_pitch_deg", o.off_axis_pitch_deg},
        {"trials_per_cell", o.trials},
        {"seed", o.seed},
        {"offset_mm", o.offset_mm},
        {"wrong_radius_mm", o.wrong_radius_mm},
        {"tolerance_display_px", o.tolerance_display_px},
        {"board", {o.cols, o.rows}}}},
      {"wall_s", wall_s},
      {"summary", all.ToJson()},
      {"per_scale_distance", per_cell},
      {"trials", rows}};
  WriteFileAtomic(out / "verdict_bench.csv", csv);
  WriteFileAtomic(out / "verdict_bench.json", meta.dump(1) + "\n");
  WriteFileAtomic(out / "verdict_bench.txt", head + summary);
  log << fmt::format("wrote {}, verdict_bench.json, verdict_bench.txt\n", (out / "verdict_bench.csv").string());
}

}  // namespace curvecheck::experiments
