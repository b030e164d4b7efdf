#include "experiments/bench_validity.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <random>

#include "analysis/pipeline.h"
#include "core/config.h"
#include "core/error.h"
#include "core/path_check.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "core/stopwatch.h"
#include "datasets/dataset_files.h"
#include "experiments/detection_errors.h"
#include "experiments/machine_info.h"
#include "experiments/scene_lookup.h"
#include "experiments/sweep_table.h"
#include "experiments/trial.h"
#include "experiments/trial_outcome.h"
#include "experiments/validity_stats.h"
#include "synth/lens_misfit.h"
#include "synth/true_monitor.h"

namespace curvecheck::experiments {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr const char* kFormat = "curvecheck.bench.validity/1";
// Significant digits of the measured and true values in validity_trials.csv, from which every statistic is
// computed: a camera 1500 mm away with a 0.01 mm sigma needs more than the table's usual 6.
constexpr int kDigits = 10;
const char* const kAxes[] = {"x", "y", "z"};
const char* const kFrames[] = {"centre", "axis"};

// The scene `name_or_path` (scene_lookup.h FindScene) with `overrides` applied through LoadScene, the one
// reader of overrides. An embedded scene has no file for LoadScene to read, so it and the camera model it
// names are copied, in their datasets/ layout, into a private temporary folder that is removed on return.
// TODO(merge): an overrides argument of FindScene (experiments/scene_lookup.h) would make this copy
// unnecessary.
SyntheticScene LoadSceneWithOverrides(const std::string& name_or_path,
                                      const std::vector<std::string>& overrides) {
  std::error_code ec;
  if (overrides.empty()) return FindScene(name_or_path, "--scene");
  if (ClassifyPath(name_or_path) == PathKind::kLinkLoop) RequireFile(name_or_path);
  if (fs::exists(name_or_path, ec)) return LoadScene(name_or_path, overrides);
  if (!IsEmbeddedScene(name_or_path)) return FindScene(name_or_path, "--scene");  // throws the lookup's error
  const std::string scene_file = "scenes/" + name_or_path + ".yaml";
  const std::string text = DatasetFileText(scene_file);
  const std::string model = ConfigMap::Parse(text, "embedded " + scene_file).Map("camera").String("model");
  const std::string camera_file = (fs::path("scenes") / model).lexically_normal().generic_string();
  const TempFolder folder("curvecheck_validity_scene", "the scene with overrides");
  folder.Subfolder(fs::path(scene_file).parent_path());
  folder.Subfolder(fs::path(camera_file).parent_path());
  WriteFileAtomic(folder.path() / scene_file, text);
  WriteFileAtomic(folder.path() / camera_file, DatasetFileText(camera_file));
  return LoadScene(folder.path() / scene_file, overrides);
}

// The grid's axes in canonical order (outermost first) and the index arithmetic over them.
struct Grid {
  std::vector<double> scales, distances_mm, yaws_deg, radius_factors;
  std::vector<std::string> realism;
  int trials = 1;

  int Cells() const {
    return static_cast<int>(scales.size() * distances_mm.size() * yaws_deg.size() * realism.size() *
                            radius_factors.size());
  }
  struct Cell {
    int index = 0;
    double scale = 0, distance_mm = 0, yaw_deg = 0, radius_factor = 1;
    std::string realism;
    std::string Label() const {
      return fmt::format("{:g}/{:g}/{:g}/{}/{:g}", scale, distance_mm, yaw_deg, realism, radius_factor);
    }
  };
  Cell CellAt(int c) const {
    Cell cell;
    cell.index = c;
    int rest = c;
    cell.radius_factor = radius_factors[static_cast<size_t>(rest % radius_factors.size())];
    rest /= static_cast<int>(radius_factors.size());
    cell.realism = realism[static_cast<size_t>(rest % realism.size())];
    rest /= static_cast<int>(realism.size());
    cell.yaw_deg = yaws_deg[static_cast<size_t>(rest % yaws_deg.size())];
    rest /= static_cast<int>(yaws_deg.size());
    cell.distance_mm = distances_mm[static_cast<size_t>(rest % distances_mm.size())];
    rest /= static_cast<int>(distances_mm.size());
    cell.scale = scales[static_cast<size_t>(rest)];
    return cell;
  }

  json ToJson() const {
    return {{"scales", scales},   {"distances_mm", distances_mm},     {"yaws_deg", yaws_deg},
            {"realism", realism}, {"radius_factors", radius_factors}, {"trials_per_cell", trials}};
  }
  static Grid FromJson(const json& g) {
    Grid grid;
    grid.scales = g.at("scales").get<std::vector<double>>();
    grid.distances_mm = g.at("distances_mm").get<std::vector<double>>();
    grid.yaws_deg = g.at("yaws_deg").get<std::vector<double>>();
    grid.realism = g.at("realism").get<std::vector<std::string>>();
    grid.radius_factors = g.at("radius_factors").get<std::vector<double>>();
    grid.trials = g.at("trials_per_cell").get<int>();
    return grid;
  }
};

Grid GridOf(const BenchValidityOptions& o) {
  return {o.scales, o.distances_mm, o.yaws_deg, o.radius_factors, o.realism, o.trials};
}

// validity_trials.csv's columns.
std::vector<std::string> TrialColumns() {
  std::vector<std::string> c = {"index",
                                "cell",
                                "scale",
                                "distance_mm",
                                "yaw_deg",
                                "realism",
                                "radius_factor",
                                "trial",
                                "seed",
                                "camera_px",
                                "jitter_x_mm",
                                "jitter_y_mm",
                                "jitter_z_mm",
                                "jitter_aim_x_deg",
                                "jitter_aim_y_deg",
                                "jitter_aim_z_deg",
                                "true_pitch_scale",
                                "reason",
                                "verification_verdict",
                                "features",
                                "chosen_model",
                                "true_radius_mm",
                                "radius_mm",
                                "radius_sigma_mm",
                                "radius_ci95_lo_mm",
                                "radius_ci95_hi_mm",
                                "radius_ci68_lo_mm",
                                "radius_ci68_hi_mm",
                                "radius_in68",
                                "radius_in95",
                                "det_rms_px",
                                "det_smooth_px",
                                "det_smooth_beyond_noise_px",
                                "smooth_bias_px",
                                "sys_rms_px",
                                "sys_smooth_px",
                                "sys_signature_rest_px",
                                "sys_cell_signature_rest_px",
                                "sys_shift_mm",
                                "smooth_share_mm",
                                "locking_share_mm",
                                "noise_share_mm",
                                "noise_independent",
                                "noise_z_min",
                                "noise_z_max"};
  for (const char* f : kFrames) {
    for (const char* what :
         {"true_cam_{}_{}_mm", "cam_{}_{}_mm", "cam_{}_{}_sigma_mm", "cam_{}_{}_k95", "cam_{}_{}_k68"}) {
      for (const char* a : kAxes) c.push_back(fmt::format(fmt::runtime(what), f, a));
    }
  }
  for (const char* name : {"render_ms", "photo_ms", "detect_ms", "fit_ms", "trial_ms", "detail"})
    c.push_back(name);
  return c;
}

struct Bench {
  BenchValidityOptions options;
  Grid grid;
  std::map<std::string, SyntheticScene> scenes;  // per realism level, overrides applied
  PatternSpec spec;
  fs::path scratch;
  fs::path results;  // BenchValidityOptions::keep_results: where the trials' result.json go; empty: not kept
  std::unique_ptr<Renderer> renderer;
};

// The detector's errors on a trial's photo: each unflagged feature's id, detected position, and that position
// less its true image (the detector's own error, without the lens's).
struct FeatureErrors {
  std::vector<std::string> ids;
  std::vector<Eigen::Vector2d> at, err;
  DetectionErrors Summary(const SyntheticScene& scene) const {
    return DetectionErrorsOf(at, err, std::vector<int>(at.size(), 0), scene.camera.width, scene.camera.height);
  }
};
FeatureErrors ErrorsAgainstTruth(const TrueImages& truth, const Pattern& pattern, const Detection& detection) {
  std::map<std::string, Eigen::Vector2d> display_px;
  for (const Feature& f : pattern.features) {
    if (f.display_px) display_px.emplace(f.id, *f.display_px);
  }
  FeatureErrors e;
  for (const DetectedFeature& f : detection.features) {
    const auto it = display_px.find(f.id);
    if (!f.flag.empty() || it == display_px.end()) continue;
    if (const std::optional<Eigen::Vector2d> q = truth.Of(it->second)) {
      e.ids.push_back(f.id);
      e.at.push_back(f.px);
      e.err.push_back(f.px - *q);
    }
  }
  return e;
}

// What the detector's systematic error did to the radius (BenchValidityOptions::detector_effect). The trial's
// display is photographed again without sensor noise (everything else alike: optics, colour filter array and
// demosaicing, JPEG, quantization) and detected as the analysis detects; each feature's error there against the
// truth is the detector's deterministic error at that geometry: pixel-locking, smooth bias, whatever else. The
// trial's observations as the analysis built them (FitObservationsOf: the verification's features, less their
// pixel-locking estimate under --correct-pixel-locking) are fitted as they are and less that error; the shift is
// the chosen model's radius from the first less that from the second (after the analysis's own pixel-locking
// correction, so what the correction leaves). The budget's row 2 (detector systematic) is to cover it: its two
// parts, the smooth bias b's share and the pixel-locking correction's uncertainty, are given beside it.
struct DetectorEffect {
  DetectionErrors systematic;  // of the noise-free photo's detections
  double shift_mm = kNaN, smooth_share_mm = kNaN, locking_share_mm = kNaN;
  // The budget's detection-noise row, u(R): the part of the detector's error that neighbouring corners do not share
  // stands there (row 2 bounds only what they share), so rows 1 and 2 together are what is to cover the shift.
  double noise_share_mm = kNaN;
};
DetectorEffect DetectorEffectOf(const SyntheticScene& scene, const TrialDisplay& display, const PhotoInput& input,
                                const TrueImages& truth, const AnalysisResult& r, const AnalyzeOptions& a) {
  DetectorEffect e;
  const PhotoAnalysis& photo = r.photos.front();
  if (!photo.used || !r.fit) return e;
  const ModelFit& chosen = r.fit->Chosen();
  if (!chosen.converged || !chosen.radius_mm) return e;
  SyntheticScene quiet = scene;
  quiet.sensor.noise = false;
  AnalyzeOptions detect_only = a;
  detect_only.fit_screen = false;
  const TrialAnalysis q = PhotographAndAnalyse(quiet, display.image, input, "scaled camera", detect_only);
  const FeatureErrors errors = ErrorsAgainstTruth(truth, display.pattern, q.analysis.photos.front().detection);
  e.systematic = errors.Summary(scene);
  std::map<std::string, Eigen::Vector2d> systematic;
  for (size_t i = 0; i < errors.ids.size(); ++i) systematic.emplace(errors.ids[i], errors.err[i]);
  // Both fits on the analysis's observations (FitObservationsOf) of the features the noise-free photo also gave.
  const PhotoObservations all = FitObservationsOf(photo, a);
  PhotoObservations obs, less;
  obs.photo = less.photo = all.photo;
  for (size_t i = 0; i < all.ids.size(); ++i) {
    const auto it = systematic.find(all.ids[i]);
    if (it == systematic.end()) continue;
    for (PhotoObservations* p : {&obs, &less}) {
      p->ids.push_back(all.ids[i]);
      p->display_px.push_back(all.display_px[i]);
      p->detected_px.push_back(p == &obs ? all.detected_px[i] : Eigen::Vector2d(all.detected_px[i] - it->second));
    }
  }
  FitOptions o = a.fit;
  o.detection_noise_px = r.fit->detection_noise_px;
  const auto radius = [&](const PhotoObservations& p) -> std::optional<double> {
    try {
      const ScreenFitResult f = FitScreen(r.monitor, r.camera, {p}, o);
      for (const ModelFit& m : f.candidates) {
        if (m.model == chosen.model && m.converged) return m.radius_mm;
      }
    } catch (const Error&) {
    }
    return std::nullopt;
  };
  const std::optional<double> as_is = radius(obs), without = radius(less);
  if (as_is && without) e.shift_mm = *as_is - *without;
  const double k2 = chosen.curvature_per_mm * chosen.curvature_per_mm;
  e.smooth_share_mm = chosen.budget.smooth_share_curvature_per_mm / k2;
  e.locking_share_mm = chosen.budget.pixel_locking_share_curvature_per_mm / k2;
  for (const BudgetComponent& c : chosen.budget.components) {
    if (c.name == "detection noise") e.noise_share_mm = c.curvature_per_mm / k2;
  }
  return e;
}

// One trial, as its validity_trials.csv row.
std::vector<std::string> RunTrial(Bench& b, int index, std::string* line) {
  const Stopwatch watch;
  const BenchValidityOptions& o = b.options;
  const Grid::Cell cell = b.grid.CellAt(index / o.trials);
  const int k = index % o.trials;
  const uint64_t seed = static_cast<uint64_t>(o.seed + index);
  const SyntheticScene& base = b.scenes.at(cell.realism);
  SyntheticScene scene = base;
  scene.camera = ScaledCamera(base.camera, cell.scale);
  scene.sensor.seed = seed;
  scene.imaging.lens_seed = seed;  // a different lens (misfit) per trial: coverage over lenses, not one lens
  scene.truth.curvature_per_mm = base.monitor.curvature_per_mm / cell.radius_factor;
  const double true_radius = 1 / scene.truth.curvature_per_mm;

  // The camera: on its circle around the screen centre, looking at it, then jittered (seeded by the trial's
  // seed).
  const Eigen::Vector3d centre = ScreenCentreInScreen(base.monitor);
  const Eigen::Vector3d placed =
      centre + cell.distance_mm * (Eigen::AngleAxisd(cell.yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()) *
                                   Eigen::Vector3d::UnitZ());
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> position_noise(0, o.jitter_mm), aim_noise(0, o.jitter_deg);
  Eigen::Vector3d jitter, aim_deg;
  for (int i = 0; i < 3; ++i) jitter[i] = position_noise(rng);
  for (int i = 0; i < 3; ++i) aim_deg[i] = aim_noise(rng);
  // Drawn after the pose so that the poses of a seed stay those of the benches before the pitch was drawn.
  const double pitch_tolerance = PitchToleranceFromPercent(o.pitch_tolerance_percent, "--pitch-tolerance");
  scene.truth.pitch_scale = 1 + std::uniform_real_distribution<double>(-pitch_tolerance, pitch_tolerance)(rng);
  const Eigen::Vector3d position = placed + jitter;
  const Eigen::Matrix3d looking =
      ScreenFromCamLookAt(placed, centre, Eigen::Vector3d::UnitY()).RotationMatrix();
  const Eigen::Vector3d aim_rad = aim_deg * M_PI / 180;
  const Eigen::Matrix3d turn = AngleAxisFromVector(aim_rad).toRotationMatrix();
  scene.screen_from_cam = Pose(looking * turn, position);  // turn: in the camera frame

  // The truth of the camera position in the true screen's centre and axis frames.
  const Eigen::Vector3d true_centre = centre + scene.truth.translation_mm;
  Eigen::Vector3d truth[2];
  truth[0] = scene.truth.Rotation().transpose() * (position - true_centre);
  truth[1] = truth[0] - Eigen::Vector3d(0, 0, true_radius);

  TrialOutcome outcome = TrialOutcome::kOk;
  std::string detail, verdict, chosen;
  int features = 0;
  double render_ms = kNaN, photo_ms = kNaN, detect_ms = kNaN, fit_ms = kNaN;
  double radius = kNaN, sigma = kNaN, lo = kNaN, hi = kNaN, lo68 = kNaN, hi68 = kNaN;
  double smooth_bias_px = kNaN;  // the budget's b (FitOptions::smooth_bias_px: stated or scaled by the scatter)
  // The detection-noise row's independence test (UncertaintyBudget::NoiseIndependence): "1", "0" or "" (not
  // tested), and its most negative and most positive z.
  std::string noise_independent;
  double noise_z_min = kNaN, noise_z_max = kNaN;
  DetectionErrors detection_errors;
  DetectorEffect detector_effect;
  Eigen::Vector3d estimate[2], estimate_sigma[2], coverage_factor[2], coverage_factor68[2];
  for (int f = 0; f < 2; ++f) {
    estimate[f] = estimate_sigma[f] = coverage_factor[f] = coverage_factor68[f] = Eigen::Vector3d::Constant(kNaN);
  }
  const fs::path pattern_json = b.scratch / fmt::format("trial-{}.pattern.json", index);
  try {
    std::unique_ptr<TrialDisplay> display;
    const Stopwatch render_watch;
    try {
      if (!b.renderer) b.renderer = std::make_unique<Renderer>();
      display =
          std::make_unique<TrialDisplay>(RenderTrialDisplay(*b.renderer, base.monitor, position, b.spec));
      WriteFileAtomic(pattern_json, display->PatternJson().dump() + "\n");
    } catch (const Error& e) {
      outcome = TrialOutcome::kRenderRefused;
      detail = e.what();
    }
    render_ms = render_watch.Ms();
    if (display) {
      const AnalyzeOptions analyze_options = [&] {
        AnalyzeOptions a;
        a.correct_pixel_locking = o.correct_pixel_locking;
        a.fit.pixel_locking_prior_px = o.pixel_locking_prior_px;
        // The tolerance the true pitch was drawn within, as analyze --pitch-tolerance.
        a.fit.pitch_tolerance_relative = pitch_tolerance;
        // The lens's misfit as its calibration would state it (at this imager).
        const LensMisfit lens(scene.imaging, scene.camera.width, scene.camera.height);
        if (o.lens_misfit_stated > 0 && lens.active()) {
          a.fit.stated_lens_misfit_px = o.lens_misfit_stated * lens.rms_px();
          a.fit.stated_lens_misfit_length_px = scene.imaging.lens_misfit_length * scene.camera.width;
          a.fit.stated_lens_misfit_source =
              fmt::format("the true lens's misfit x {:g}, as its calibration would state it", o.lens_misfit_stated);
        }
        return a;
      }();
      const TrialAnalysis t = PhotographAndAnalyse(scene, display->image,
                                                   {fmt::format("trial-{}", index), pattern_json}, "scaled camera",
                                                   analyze_options);
      const AnalysisResult& r = t.analysis;
      if (!b.results.empty()) {
        WriteFileAtomic(b.results / fmt::format("trial-{}.result.json", index),
                        ResultJson(r, fmt::format("bench validity trial {} (seed {})", index, seed)).dump(1) + "\n");
      }
      const PhotoAnalysis& photo = r.photos.front();
      photo_ms = t.photo_ms;
      detect_ms = photo.detection.time_ms;
      fit_ms = r.fit_ms;
      features = static_cast<int>(photo.detection.features.size());
      const TrueImages truth_images(scene);
      detection_errors = ErrorsAgainstTruth(truth_images, display->pattern, photo.detection).Summary(scene);
      if (o.detector_effect) {
        detector_effect = DetectorEffectOf(scene, *display, {fmt::format("trial-{}", index), pattern_json},
                                           truth_images, r, analyze_options);
      }
      if (!photo.used) {
        outcome = OutcomeOfRejection(photo);
        detail = photo.rejected;
      } else {
        verdict = VerdictName(r.verification.verdict);
        if (!r.fit) {
          outcome = OutcomeOfFitFailure(r.fit_failure_kind);
          detail = r.fit_failure;
        }
      }
      if (r.fit) {
        const ModelFit& m = r.fit->Chosen();
        chosen = m.model;
        if (m.budget.computed) smooth_bias_px = m.budget.systematic_bound_px;
        if (const UncertaintyBudget::NoiseIndependence& ni = m.budget.noise_independence; ni.tested) {
          noise_independent = ni.independent ? "1" : "0";
          const Eigen::Array22d z = ni.z.array();
          noise_z_min = z.isFinite().select(z, kInf).minCoeff();
          noise_z_max = z.isFinite().select(z, -kInf).maxCoeff();
        }
        if (!m.converged) {
          outcome = TrialOutcome::kFitFailed;
          detail = "the chosen model did not converge: " + m.condition_note;
        } else if (!m.radius_mm || !m.radius_sigma_mm) {
          outcome = TrialOutcome::kFitIllConditioned;
          detail = m.condition_note.empty() ? fmt::format("the chosen model ({}) gives no radius", m.model)
                                            : m.condition_note;
        } else {
          radius = *m.radius_mm;
          sigma = *m.radius_sigma_mm;
          lo = m.radius_ci95_mm[0];
          hi = m.radius_ci95_mm[1];
          lo68 = m.radius_ci68_mm[0];
          hi68 = m.radius_ci68_mm[1];
          if (!m.cameras.empty()) {
            const CameraEstimate& c = m.cameras.front();
            estimate[0] = c.position_in_centre_mm;
            estimate_sigma[0] = c.position_in_centre_sigma_mm;
            estimate[1] = c.position_in_screen_mm;
            estimate_sigma[1] = c.position_in_screen_sigma_mm;
            if (m.budget.computed) {
              coverage_factor[0] = m.budget.position_factor.centre;
              coverage_factor[1] = m.budget.position_factor.axis;
              coverage_factor68[0] = m.budget.position_factor68.centre;
              coverage_factor68[1] = m.budget.position_factor68.axis;
            }
          }
        }
      }
    }
  } catch (const std::exception& e) {
    outcome = TrialOutcome::kError;
    detail = e.what();
  }
  std::error_code ec;
  fs::remove(pattern_json, ec);
  // The scratch path depends on the output folder: keep it out of the row, so that shards give the same rows.
  for (size_t at = detail.find(pattern_json.string()); at != std::string::npos;
       at = detail.find(pattern_json.string(), at)) {
    detail.replace(at, pattern_json.string().size(), "pattern.json");
  }
  const IntervalSample rs{radius, true_radius, sigma, lo, hi, lo68, hi68};
  std::vector<std::string> row = {
      std::to_string(index),    std::to_string(cell.index),
      Cell(cell.scale),         Cell(cell.distance_mm),
      Cell(cell.yaw_deg),       cell.realism,
      Cell(cell.radius_factor), std::to_string(k),
      std::to_string(seed),     fmt::format("{}x{}", scene.camera.width, scene.camera.height)};
  for (int i = 0; i < 3; ++i) row.push_back(Cell(jitter[i], kDigits));
  for (int i = 0; i < 3; ++i) row.push_back(Cell(aim_deg[i], kDigits));
  row.push_back(Cell(scene.truth.pitch_scale, 9));
  for (const std::string& c :
       {std::string(TrialOutcomeName(outcome)), verdict, std::to_string(features), chosen,
        Cell(true_radius, kDigits), Cell(radius, kDigits), Cell(sigma, kDigits), Cell(lo, kDigits),
        Cell(hi, kDigits), Cell(lo68, kDigits), Cell(hi68, kDigits), rs.Valid() ? std::string(rs.In68() ? "1" : "0") : "",
        rs.Valid() ? std::string(rs.In95() ? "1" : "0") : "", Cell(detection_errors.rms_px, kDigits),
        Cell(detection_errors.smooth_rms_px, kDigits), Cell(detection_errors.smooth_beyond_noise_px, kDigits),
        Cell(smooth_bias_px, kDigits),
        Cell(detector_effect.systematic.rms_px, kDigits), Cell(detector_effect.systematic.smooth_rms_px, kDigits),
        Cell(detector_effect.systematic.signature_remainder_px, kDigits),
        Cell(detector_effect.systematic.cell_signature_remainder_px, kDigits),
        Cell(detector_effect.shift_mm, kDigits), Cell(detector_effect.smooth_share_mm, kDigits),
        Cell(detector_effect.locking_share_mm, kDigits), Cell(detector_effect.noise_share_mm, kDigits),
        noise_independent, Cell(noise_z_min, kDigits), Cell(noise_z_max, kDigits)}) {
    row.push_back(c);
  }
  for (int f = 0; f < 2; ++f) {
    for (int i = 0; i < 3; ++i) row.push_back(Cell(truth[f][i], kDigits));
    for (int i = 0; i < 3; ++i) row.push_back(Cell(estimate[f][i], kDigits));
    for (int i = 0; i < 3; ++i) row.push_back(Cell(estimate_sigma[f][i], kDigits));
    for (int i = 0; i < 3; ++i) row.push_back(Cell(coverage_factor[f][i], kDigits));
    for (int i = 0; i < 3; ++i) row.push_back(Cell(coverage_factor68[f][i], kDigits));
  }
  const double trial_ms = watch.Ms();
  for (double ms : {render_ms, photo_ms, detect_ms, fit_ms, trial_ms}) row.push_back(Cell(ms));
  row.push_back(CellText(detail));
  *line = fmt::format(
      "{} #{}: R {:.2f} +- {:.2f} mm [{:.1f}, {:.1f}], truth {:.1f} ({:+.2f} sigma){}; {:.0f} ms",
      cell.Label(), k, radius, sigma, lo, hi, true_radius, (radius - true_radius) / sigma,
      outcome == TrialOutcome::kOk ? "" : fmt::format(" - {}: {}", TrialOutcomeName(outcome), detail),
      trial_ms);
  return row;
}

// The statistics of one cell, from its rows of validity_trials.csv.
struct CellStats {
  Grid::Cell cell;
  int trials = 0, ok = 0;
  std::map<std::string, int> failures;  // reason -> count
  CoverageStats radius;
  CoverageStats camera[2][3];  // frame (centre, axis) x axis
  double true_radius_mm = kNaN, median_trial_ms = kNaN;
  bool radius_pass = false, radius_consistent = false, camera_pass = false;
};

CellStats CellOf(const SweepTable& t, const std::vector<size_t>& rows, const Grid::Cell& cell,
                 const ValidityRule& rule) {
  CellStats s;
  s.cell = cell;
  s.trials = static_cast<int>(rows.size());
  std::vector<IntervalSample> radius;
  std::vector<IntervalSample> camera[2][3];
  std::vector<double> ms;
  for (size_t r : rows) {
    ms.push_back(t.Num(r, "trial_ms"));
    s.true_radius_mm = t.Num(r, "true_radius_mm");
    const std::string reason = t.Str(r, "reason");
    if (!reason.empty()) {
      ++s.failures[reason];
      continue;
    }
    ++s.ok;
    // The trial's true pitch scales the whole scene (screen and camera) against the datasheet's that the analysis
    // is given; the images are those of the datasheet's scene scaled by 1 / pitch_scale, so every length it
    // estimates is the truth times 1 / pitch_scale: a known error of mean zero (drawn symmetric within the
    // tolerance; its second-order mean, tolerance^2 / 3, is 3e-7 of the truth at 0.1%), taken out of the bias.
    // An older bench without the column: none.
    const double pitch_scale = t.Col("true_pitch_scale") >= 0 ? t.Num(r, "true_pitch_scale") : 1.0;
    const double scaled_by = std::isfinite(pitch_scale) && pitch_scale > 0 ? 1 / pitch_scale - 1 : 0.0;
    IntervalSample rs{t.Num(r, "radius_mm"),        t.Num(r, "true_radius_mm"),    t.Num(r, "radius_sigma_mm"),
                      t.Num(r, "radius_ci95_lo_mm"), t.Num(r, "radius_ci95_hi_mm"), t.Num(r, "radius_ci68_lo_mm"),
                      t.Num(r, "radius_ci68_hi_mm")};
    rs.known_error = rs.truth * scaled_by;
    radius.push_back(rs);
    for (int f = 0; f < 2; ++f) {
      for (int a = 0; a < 3; ++a) {
        IntervalSample cs = SymmetricSample(t.Num(r, fmt::format("cam_{}_{}_mm", kFrames[f], kAxes[a])),
                                            t.Num(r, fmt::format("true_cam_{}_{}_mm", kFrames[f], kAxes[a])),
                                            t.Num(r, fmt::format("cam_{}_{}_sigma_mm", kFrames[f], kAxes[a])),
                                            t.Num(r, fmt::format("cam_{}_{}_k95", kFrames[f], kAxes[a])),
                                            t.Num(r, fmt::format("cam_{}_{}_k68", kFrames[f], kAxes[a])));
        cs.known_error = cs.truth * scaled_by;  // both frames' origins scale with the screen
        camera[f][a].push_back(cs);
      }
    }
  }
  s.radius = SummariseCoverage(radius);
  s.radius_pass = rule.Holds(s.radius);
  s.radius_consistent = rule.CoverageConsistent(s.radius);
  s.camera_pass = true;
  for (int f = 0; f < 2; ++f) {
    for (int a = 0; a < 3; ++a) {
      s.camera[f][a] = SummariseCoverage(camera[f][a]);
      s.camera_pass = s.camera_pass && rule.Holds(s.camera[f][a]);
    }
  }
  if (!ms.empty()) s.median_trial_ms = Median(ms);
  return s;
}

std::vector<std::string> CellColumns() {
  std::vector<std::string> c = {"cell",          "scale",          "distance_mm", "yaw_deg", "realism",
                                "radius_factor", "true_radius_mm", "trials",      "ok",      "failures"};
  const auto stats = [&c](const std::string& p) {
    for (const char* s : {"n", "bias_sigma", "bias_sigma_se", "net_bias_sigma", "net_bias_sigma_se", "scatter_ratio",
                          "mean_error_mm", "sd_error_mm",
                          "mean_sigma_mm", "cov68_k", "cov68", "cov68_lo", "cov68_hi", "cov95_k", "cov95",
                          "cov95_lo", "cov95_hi"}) {
      c.push_back(p + s);
    }
  };
  stats("radius_");
  c.insert(c.end(), {"radius_pass", "radius_cov95_consistent"});
  for (const char* f : kFrames) {
    for (const char* a : kAxes) stats(fmt::format("cam_{}_{}_", f, a));
  }
  c.insert(c.end(), {"camera_pass", "median_trial_ms"});
  return c;
}

std::vector<std::string> CellRow(const CellStats& s) {
  std::string failures;
  for (const auto& [reason, n] : s.failures)
    failures += fmt::format("{}{} {}", failures.empty() ? "" : "; ", n, reason);
  std::vector<std::string> row = {std::to_string(s.cell.index),
                                  Cell(s.cell.scale),
                                  Cell(s.cell.distance_mm),
                                  Cell(s.cell.yaw_deg),
                                  s.cell.realism,
                                  Cell(s.cell.radius_factor),
                                  Cell(s.true_radius_mm),
                                  std::to_string(s.trials),
                                  std::to_string(s.ok),
                                  CellText(failures)};
  const auto stats = [&row](const CoverageStats& c) {
    for (const std::string& v :
         {std::to_string(c.n), Cell(c.bias_sigma), Cell(c.bias_sigma_se), Cell(c.net_bias_sigma),
          Cell(c.net_bias_sigma_se), Cell(c.scatter_ratio),
          Cell(c.mean_error), Cell(c.sd_error), Cell(c.mean_sigma), std::to_string(c.k68),
          Cell(c.Coverage68()), Cell(c.n > 0 ? c.wilson68.lo : kNaN), Cell(c.n > 0 ? c.wilson68.hi : kNaN),
          std::to_string(c.k95), Cell(c.Coverage95()), Cell(c.n > 0 ? c.wilson95.lo : kNaN),
          Cell(c.n > 0 ? c.wilson95.hi : kNaN)}) {
      row.push_back(v);
    }
  };
  stats(s.radius);
  row.push_back(s.radius_pass ? "1" : "0");
  row.push_back(s.radius_consistent ? "1" : "0");
  for (int f = 0; f < 2; ++f) {
    for (int a = 0; a < 3; ++a) stats(s.camera[f][a]);
  }
  row.push_back(s.camera_pass ? "1" : "0");
  row.push_back(Cell(s.median_trial_ms));
  return row;
}

json CoverageJson(const CoverageStats& c) {
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  return {{"n", c.n},
          {"bias_sigma", num(c.bias_sigma)},
          {"bias_sigma_se", num(c.bias_sigma_se)},
          {"net_bias_sigma", num(c.net_bias_sigma)},
          {"net_bias_sigma_se", num(c.net_bias_sigma_se)},
          {"scatter_ratio", num(c.scatter_ratio)},
          {"mean_error_mm", num(c.mean_error)},
          {"sd_error_mm", num(c.sd_error)},
          {"mean_sigma_mm", num(c.mean_sigma)},
          {"coverage68",
           {{"k", c.k68},
            {"n", c.n},
            {"rate", num(c.Coverage68())},
            {"wilson95", {c.wilson68.lo, c.wilson68.hi}}}},
          {"coverage95",
           {{"k", c.k95},
            {"n", c.n},
            {"rate", num(c.Coverage95())},
            {"wilson95", {c.wilson95.lo, c.wilson95.hi}}}}};
}

json CellJson(const CellStats& s) {
  json camera = json::object();
  for (int f = 0; f < 2; ++f) {
    for (int a = 0; a < 3; ++a) camera[kFrames[f]][kAxes[a]] = CoverageJson(s.camera[f][a]);
  }
  return {{"cell", s.cell.index},
          {"scale", s.cell.scale},
          {"distance_mm", s.cell.distance_mm},
          {"yaw_deg", s.cell.yaw_deg},
          {"realism", s.cell.realism},
          {"radius_factor", s.cell.radius_factor},
          {"true_radius_mm", std::isfinite(s.true_radius_mm) ? json(s.true_radius_mm) : json(nullptr)},
          {"trials", s.trials},
          {"ok", s.ok},
          {"failures", s.failures},
          {"radius", CoverageJson(s.radius)},
          {"radius_pass", s.radius_pass},
          {"radius_cov95_consistent", s.radius_consistent},
          {"camera_position", camera},
          {"camera_pass", s.camera_pass}};
}

std::string Pct(const CoverageStats& c, int k, const BinomialInterval& w) {
  if (c.n == 0) return "-";
  return fmt::format("{:>2}/{:<2} {:3.0f}% [{:2.0f},{:3.0f}]", k, c.n, 100.0 * k / c.n, 100 * w.lo,
                     100 * w.hi);
}

const char* OutcomeText(ValidityRule::Outcome o) {
  switch (o) {
    case ValidityRule::Outcome::kMeets:
      return "ok";
    case ValidityRule::Outcome::kConsistent:
      return "ok?";
    case ValidityRule::Outcome::kFails:
      return "FAIL";
  }
  return "?";
}

// The summary's line for one quantity: its cells' classes against what a method with exactly right intervals
// gives at the same sample counts (validity_stats.h NominalRuleReference).
struct RuleCount : OutcomeCounts {
  std::vector<int> samples;
  void Add(const ValidityRule& rule, const CoverageStats& s) {
    OutcomeCounts::Add(rule.Classify(s));
    samples.push_back(s.n);
  }
  RuleReference Reference(const ValidityRule& rule) const {
    return NominalRuleReference(samples, rule, kReferenceGrids, kReferenceSeed, meets, fails);
  }
  json Json(const RuleReference& ref) const {
    return {{"meets", meets},
            {"consistent", consistent},
            {"fails", fails},
            {"exact_intervals_expect",
             {{"meets", ref.meets},
              {"meets_p05_p95", {ref.meets_p05, ref.meets_p95}},
              {"consistent", ref.consistent},
              {"fails", ref.fails},
              {"p_meets_at_most_observed", ref.p_meets_at_most},
              {"p_fails_at_least_observed", ref.p_fails_at_least},
              {"simulated_grids", ref.grids},
              {"seed", kReferenceSeed}}}};
  }
  static constexpr int kReferenceGrids = 4000;
  static constexpr uint64_t kReferenceSeed = 16;
};

// "meet / consistent / fail" and, from intervals exactly right at the same sample counts, the expected counts
// (full) or only the chances of counts as extreme as these.
std::string ReferenceText(const RuleCount& c, const RuleReference& ref, bool full) {
  if (!full) {
    return fmt::format(
        "{} / {} / {} (exactly right intervals: P(<= {} meeting) = {:.2f}, P(>= {} failing) = {:.2f})",
        c.meets, c.consistent, c.fails, c.meets, ref.p_meets_at_most, c.fails, ref.p_fails_at_least);
  }
  return fmt::format(
      "intervals exactly right (errors N(0, sigma^2)) would give, at these sample counts, {:.1f} meeting it "
      "(90% of grids {}-{}; P(<= {}) = {:.2f}), {:.1f} consistent, {:.1f} failing (P(>= {}) = {:.2f}); {} "
      "simulated grids, seed {}",
      ref.meets, ref.meets_p05, ref.meets_p95, c.meets, ref.p_meets_at_most, ref.consistent, ref.fails,
      c.fails, ref.p_fails_at_least, ref.grids, RuleCount::kReferenceSeed);
}

std::string TableText(const std::vector<CellStats>& cells, const ValidityRule& rule) {
  std::string s = fmt::format(
      "{:>4} {:>5} {:>6} {:>4} {:>4} {:>5} {:>6} {:>22} {:>6} {:>20} {:>20} {:>4}  {:>20} {:>20} {:>4}\n",
      "cell", "scale", "dist", "yaw", "real", "R/Rn", "ok/n", "bias/sig +- se (raw)", "scat", "cov68 [Wilson 95%]",
      "cov95 [Wilson 95%]", "rule", "cam centre: max|b|", "cam axis: max|b|", "cam");
  for (const CellStats& c : cells) {
    const auto cam = [&](int f) {
      double worst_bias = 0, worst_cov = 1;
      int n = 0;
      for (int a = 0; a < 3; ++a) {
        const CoverageStats& x = c.camera[f][a];
        if (x.n == 0) continue;
        n = x.n;
        worst_bias = std::max(worst_bias, std::abs(x.net_bias_sigma));
        worst_cov = std::min(worst_cov, x.Coverage95());
      }
      return n == 0 ? std::string("-") : fmt::format("{:.2f}, cov95 >={:3.0f}%", worst_bias, 100 * worst_cov);
    };
    const CoverageStats& r = c.radius;
    s += fmt::format(
        "{:>4} {:>5g} {:>6g} {:>4g} {:>4} {:>5g} {:>6} {:>22} {:>6} {:>20} {:>20} {:>4}  {:>20} {:>20} "
        "{:>4}\n",
        c.cell.index, c.cell.scale, c.cell.distance_mm, c.cell.yaw_deg, c.cell.realism, c.cell.radius_factor,
        fmt::format("{}/{}", c.ok, c.trials),
        r.n == 0 ? std::string("-")
                 : fmt::format("{:+.2f} +- {:.2f} ({:+.2f})", r.net_bias_sigma, r.net_bias_sigma_se, r.bias_sigma),
        std::isfinite(r.scatter_ratio) ? fmt::format("{:.2f}", r.scatter_ratio) : std::string("-"),
        Pct(r, r.k68, r.wilson68), Pct(r, r.k95, r.wilson95), OutcomeText(rule.Classify(r)), cam(0), cam(1),
        c.camera_pass ? "ok" : "FAIL");
  }
  s += fmt::format(
      "(cell: scale/distance mm/yaw deg/realism/true radius factor in validity.csv; ok/n: trials with a "
      "radius of "
      "n; bias/sig: mean(R - R_true - known) / mean reported sigma, +- its standard error, known = R_true x (1 / "
      "true pitch scale - 1) the trial's own pitch draw, mean zero (raw: mean(R - R_true) / mean sigma); scat: "
      "sd(R) / mean sigma; "
      "cov68: R +- sigma holds the truth; cov95: the reported 95% interval holds it; rule: 95% coverage in "
      "{:.0f}-{:.0f}% and |bias| < {:g} sigma, ok? = fails on the point estimate but the Wilson interval "
      "overlaps "
      "the band; cam: the camera position in the true screen's centre and axis frames, worst coordinate, "
      "same "
      "rule on all six)\n",
      100 * rule.coverage95_lo, 100 * rule.coverage95_hi, rule.max_bias_sigma);
  return s;
}

// validity.png: the 95% coverage per cell (Wilson interval, the band) and the bias in sigmas (standard error,
// the +-0.5 band).
void WriteChart(const std::vector<CellStats>& cells, const ValidityRule& rule, const fs::path& dir) {
  std::string dat = "# cell label cov95 lo hi bias se\n";
  for (const CellStats& c : cells) {
    const CoverageStats& r = c.radius;
    dat += fmt::format("{} {} {} {} {} {} {}\n", c.cell.index, c.cell.Label(), Cell(r.Coverage95()),
                       Cell(r.n > 0 ? r.wilson95.lo : kNaN), Cell(r.n > 0 ? r.wilson95.hi : kNaN),
                       Cell(r.net_bias_sigma), Cell(r.net_bias_sigma_se));
  }
  WriteFileAtomic(dir / "validity.dat", dat);
  const double x0 = -0.5, x1 = cells.empty() ? 0.5 : cells.back().cell.index + 0.5;
  std::string script = fmt::format(
      "set datafile missing 'nan'\nset multiplot layout 2,1 title {}\nset xrange [{}:{}]\nset grid ytics\n"
      "set xtics rotate by 60 right font ',8'\nunset key\n",
      GnuplotString(
          "bench validity: is the radius interval honest? (cells: scale/distance mm/yaw deg/realism/R "
          "factor)"),
      x0, x1);
  script += fmt::format(
      "set title {}\nset ylabel '95% coverage'\nset yrange [0:1.05]\n"
      "set object 1 rect from {},{} to {},{} fc rgb '#c7e9c0' fs solid 0.6 noborder behind\n"
      "plot 'validity.dat' using 1:3:4:5:xtic(2) with yerrorbars pt 7 lc rgb '#2166ac'\n",
      GnuplotString(fmt::format("95% interval coverage per cell, Wilson 95% interval; band {:.0f}-{:.0f}%",
                                100 * rule.coverage95_lo, 100 * rule.coverage95_hi)),
      x0, rule.coverage95_lo, x1, rule.coverage95_hi);
  script += fmt::format(
      "unset object 1\nset title {}\nset ylabel 'bias / sigma'\nset yrange [*:*]\n"
      "set object 2 rect from {},{} to {},{} fc rgb '#c7e9c0' fs solid 0.6 noborder behind\n"
      "plot 'validity.dat' using 1:6:7:xtic(2) with yerrorbars pt 7 lc rgb '#b2182b', 0 lc rgb 'gray'\n"
      "unset multiplot\n",
      GnuplotString(
          fmt::format("bias of the radius in units of the mean reported sigma (the trials' own pitch draws "
                      "taken out), +- its standard error; band +-{:g}",
                      rule.max_bias_sigma)),
      x0, -rule.max_bias_sigma, x1, rule.max_bias_sigma);
  // The script reads validity.dat from the folder it runs in (WriteGnuplotChart runs gnuplot there).
  WriteGnuplotChart(dir / "validity.png", script,
                    ChartSize{std::max(900, 40 * static_cast<int>(cells.size()) + 200), 1000});
}

// The detection-noise row's independence test (noise_independent, noise_z_min, noise_z_max) per cell: how many
// trials passed it, and the medians of the most negative and the most positive z. "" when no trial was tested (a
// bench from before the columns).
std::string NoiseIndependenceLines(const SweepTable& trials) {
  struct Tally {
    std::string what;
    int tested = 0, independent = 0;
    std::vector<double> z_min, z_max;
  };
  std::map<int, Tally> cells;
  for (size_t r = 0; r < trials.rows.size(); ++r) {
    const std::string verdict = trials.Col("noise_independent") >= 0 ? trials.Str(r, "noise_independent") : "";
    if (verdict.empty()) continue;
    Tally& t = cells[static_cast<int>(trials.Num(r, "cell"))];
    t.what = fmt::format("{} x{:g} {:g} mm {:g} deg R x{:g}", trials.Str(r, "realism"), trials.Num(r, "scale"),
                         trials.Num(r, "distance_mm"), trials.Num(r, "yaw_deg"), trials.Num(r, "radius_factor"));
    ++t.tested;
    t.independent += verdict == "1" ? 1 : 0;
    t.z_min.push_back(trials.Num(r, "noise_z_min"));
    t.z_max.push_back(trials.Num(r, "noise_z_max"));
  }
  if (cells.empty()) return "";
  std::string s = fmt::format(
      "the detection-noise row's assumption, independent errors (neighbours' residual correlation, |z| < {:g}): "
      "trials that pass it, and the medians of the most negative and most positive z\n",
      UncertaintyBudget::kNoiseIndependenceZ);
  for (auto& [cell, t] : cells) {
    s += fmt::format("  cell {:>3} ({}): {}/{} pass, z {:+.1f} .. {:+.1f}\n", cell, t.what, t.independent, t.tested,
                     Median(t.z_min), Median(t.z_max));
  }
  return s;
}

// The detector's errors against the truth per realism level (medians over the trials with a radius), beside the
// smooth detector bias b of the budget's row 2: the one value in the budget that no photo measures (by default
// scaled by the detector's measured scatter, FitOptions::smooth_bias_px).
std::string DetectionErrorLines(const SweepTable& trials) {
  std::map<std::string, std::vector<double>> rms, smooth, beyond, bias;
  for (size_t r = 0; r < trials.rows.size(); ++r) {
    if (!trials.Str(r, "reason").empty()) continue;
    const double a = trials.Num(r, "det_rms_px"), b = trials.Num(r, "det_smooth_px"),
                 c = trials.Num(r, "det_smooth_beyond_noise_px");
    if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(c)) continue;  // also a shard from before them
    const std::string realism = trials.Str(r, "realism");
    rms[realism].push_back(a), smooth[realism].push_back(b), beyond[realism].push_back(c);
    // A shard from before the column (2026-12-05) has no b: NaN, left out of the median.
    if (const double d = trials.Num(r, "smooth_bias_px"); std::isfinite(d)) bias[realism].push_back(d);
  }
  std::string s;
  for (auto& [realism, v] : beyond) {
    std::sort(v.begin(), v.end());
    s += fmt::format(
        "detection errors against the truth, realism {} (medians over {} trials with a radius): RMS {:.4f} px; "
        "smooth part (Legendre degree 3) {:.4f} px, beyond the noise's leak {:.4f} px (90% of the trials below "
        "{:.4f}); the budget's smooth detector bias b {}\n",
        realism, v.size(), Median(rms.at(realism)), Median(smooth.at(realism)), Median(v),
        v[static_cast<size_t>(0.9 * static_cast<double>(v.size() - 1))],
        bias[realism].empty() ? std::string("is not in these trials")
                              : fmt::format("{:.4f} px (median over {} trials)", Median(bias[realism]),
                                            bias[realism].size()));
  }
  // --detector-effect: the shift the detector's systematic error caused and row 2's parts, in units of each
  // trial's sigma, per realism level and per realism level and distance. Each RMS carries its standard error by the
  // delta method on the mean of the squares (SE = sd(q) / sqrt(n) / (2 RMS), q the squares; no assumption on their
  // distribution), the ratio its own from the two (their correlation ignored).
  struct Squares {
    std::vector<double> shift, row2, smooth, locking, rows12;
  };
  const auto rms_of = [](const std::vector<double>& q) {
    const double m = std::accumulate(q.begin(), q.end(), 0.0) / static_cast<double>(q.size());
    double v = 0;
    for (const double x : q) v += (x - m) * (x - m);
    v /= std::max<double>(1, static_cast<double>(q.size()) - 1);
    const double r = std::sqrt(m);
    return std::pair<double, double>{r, r > 0 ? std::sqrt(v / static_cast<double>(q.size())) / (2 * r) : kNaN};
  };
  std::map<std::pair<std::string, double>, Squares> effect;  // (realism, distance mm; -1: all distances)
  std::map<std::string, std::vector<double>> sys_smooth, sys_rms, sys_rest, sys_cell_rest;
  for (size_t r = 0; r < trials.rows.size(); ++r) {
    const double shift = trials.Num(r, "sys_shift_mm"), smooth_share = trials.Num(r, "smooth_share_mm"),
                 locking = trials.Num(r, "locking_share_mm"), sigma = trials.Num(r, "radius_sigma_mm"),
                 noise = trials.Num(r, "noise_share_mm");  // NaN in a bench before the column
    if (!trials.Str(r, "reason").empty() || !std::isfinite(shift) || !(sigma > 0)) continue;
    const std::string realism = trials.Str(r, "realism");
    for (const double distance : {-1.0, trials.Num(r, "distance_mm")}) {
      Squares& q = effect[{realism, distance}];
      q.shift.push_back((shift / sigma) * (shift / sigma));
      q.smooth.push_back((smooth_share / sigma) * (smooth_share / sigma));
      q.locking.push_back((locking / sigma) * (locking / sigma));
      q.row2.push_back((smooth_share * smooth_share + locking * locking) / (sigma * sigma));
      if (std::isfinite(noise)) q.rows12.push_back(q.row2.back() + (noise / sigma) * (noise / sigma));
    }
    sys_smooth[realism].push_back(trials.Num(r, "sys_smooth_px"));
    sys_rms[realism].push_back(trials.Num(r, "sys_rms_px"));
    sys_rest[realism].push_back(trials.Num(r, "sys_signature_rest_px"));
    sys_cell_rest[realism].push_back(trials.Num(r, "sys_cell_signature_rest_px"));
  }
  for (const auto& [key, q] : effect) {
    const auto& [realism, distance] = key;
    const auto [e, se_e] = rms_of(q.shift);
    const auto [r2, se_r2] = rms_of(q.row2);
    const double ratio = e / r2, se_ratio = ratio * std::hypot(se_e / e, se_r2 / r2);
    std::string measured = fmt::format(
        "it moved the radius by {:.3f} +- {:.3f} sigma RMS over {} trials; the budget's row 2 is {:.3f} +- {:.3f} "
        "sigma RMS (smooth bias {:.3f}, pixel-locking correction {:.3f}): effect / row 2 = {:.2f} +- {:.2f}",
        e, se_e, q.shift.size(), r2, se_r2, rms_of(q.smooth).first, rms_of(q.locking).first, ratio, se_ratio);
    if (q.rows12.size() == q.shift.size()) {  // every trial has the noise row
      const auto [r12, se_r12] = rms_of(q.rows12);
      const double ratio12 = e / r12;
      measured += fmt::format("; effect / (noise row + row 2) = {:.2f} +- {:.2f} (rows 1 and 2 {:.3f} sigma RMS)",
                              ratio12, ratio12 * std::hypot(se_e / e, se_r12 / r12), r12);
    }
    if (distance < 0) {
      s += fmt::format(
          "the detector's systematic error (a noise-free photo's detections against the truth, medians: RMS {:.4f} "
          "px, smooth part {:.4f} px, left by the budget's signature model {:.4f} px, by a 2 x 2 cell's {:.4f} px), "
          "realism {}: {}\n",
          Median(sys_rms.at(realism)), Median(sys_smooth.at(realism)), Median(sys_rest.at(realism)),
          Median(sys_cell_rest.at(realism)), realism, measured);
    } else {
      s += fmt::format("  realism {} at {:g} mm: {}\n", realism, distance, measured);
    }
  }
  return s;
}

// Computes the cells from the trial rows and writes every output; returns whether every cell with trials
// meets the rule. `meta` is validity.json without the cells and the summary.
bool WriteOutputs(const fs::path& out, SweepTable& trials, json meta, const std::string& head,
                  std::ostream& log) {
  const Grid grid = Grid::FromJson(meta.at("grid"));
  const ValidityRule rule;
  std::map<int, std::vector<size_t>> by_cell;
  for (size_t r = 0; r < trials.rows.size(); ++r) by_cell[std::stoi(trials.Str(r, "cell"))].push_back(r);
  std::vector<CellStats> cells;
  SweepTable table;
  table.header = CellColumns();
  json cells_json = json::array();
  int camera_pass = 0, with_trials = 0, no_radius = 0;
  RuleCount radius_count, camera_count[2][3];
  for (int c = 0; c < grid.Cells(); ++c) {
    const auto it = by_cell.find(c);
    if (it == by_cell.end()) continue;  // not in this shard
    CellStats s = CellOf(trials, it->second, grid.CellAt(c), rule);
    ++with_trials;
    radius_count.Add(rule, s.radius);
    for (int f = 0; f < 2; ++f) {
      for (int a = 0; a < 3; ++a) camera_count[f][a].Add(rule, s.camera[f][a]);
    }
    camera_pass += s.camera_pass ? 1 : 0;
    no_radius += s.radius.n == 0 ? 1 : 0;
    table.rows.push_back(CellRow(s));
    cells_json.push_back(CellJson(s));
    cells.push_back(std::move(s));
  }
  const int pass = radius_count.meets;  // a cell meets the rule exactly when CellStats::radius_pass
  const bool all = with_trials > 0 && pass == with_trials;
  const RuleReference radius_ref = radius_count.Reference(rule);
  std::string summary = TableText(cells, rule);
  summary += fmt::format(
      "\nradius, issue 16's rule (95% coverage in {:.0f}-{:.0f}% and |bias| < {:g} sigma in every cell): {} "
      "- {} of {} "
      "cells meet it{}; {} more are consistent with it within their Wilson interval, {} fail; {} trials per "
      "cell\n  {}\n",
      100 * rule.coverage95_lo, 100 * rule.coverage95_hi, rule.max_bias_sigma, all ? "PASS" : "FAIL", pass,
      with_trials, no_radius > 0 ? fmt::format(" ({} without any radius)", no_radius) : std::string(),
      radius_count.consistent, radius_count.fails, grid.trials,
      ReferenceText(radius_count, radius_ref, true));
  summary += fmt::format(
      "camera position (centre and axis frames, every coordinate, the same rule): {} of {} cells; per "
      "coordinate, meet / consistent / fail:\n",
      camera_pass, with_trials);
  json camera_json;
  for (int f = 0; f < 2; ++f) {
    for (int a = 0; a < 3; ++a) {
      const RuleCount& c = camera_count[f][a];
      const RuleReference ref = c.Reference(rule);
      summary += fmt::format("  {} {}: {}\n", kFrames[f], kAxes[a], ReferenceText(c, ref, false));
      camera_json[kFrames[f]][kAxes[a]] = c.Json(ref);
    }
  }
  summary += DetectionErrorLines(trials);
  summary += NoiseIndependenceLines(trials);
  log << "\n" << summary;
  meta["rule"] = {{"coverage95", {rule.coverage95_lo, rule.coverage95_hi}},
                  {"max_abs_bias_sigma", rule.max_bias_sigma},
                  {"binomial_interval", "Wilson score, 95%"}};
  meta["summary"] = {{"cells", with_trials},
                     {"radius_pass", pass},
                     {"radius_consistent", radius_count.consistent + pass},
                     {"radius_rule", radius_count.Json(radius_ref)},
                     {"camera_pass", camera_pass},
                     {"camera_rule", camera_json},
                     {"all_pass", all},
                     {"trials", trials.rows.size()}};
  meta["cells"] = cells_json;
  WriteFileAtomic(out / "validity_trials.csv", trials.ToCsv());
  WriteFileAtomic(out / "validity.csv", table.ToCsv());
  WriteFileAtomic(out / "validity.json", meta.dump(1) + "\n");
  WriteFileAtomic(out / "validity.txt", head + "\n" + summary);
  WriteChart(cells, rule, out);
  log << fmt::format("wrote {}, validity.csv, validity.json, validity.txt, validity.png\n",
                     (out / "validity_trials.csv").string());
  return all;
}

}  // namespace

std::vector<std::string> RealismOverrides(const std::string& level) {
  // The synthetic camera's imaging chain (synth/imaging.h): "off" is the clean monochrome chain, "on" the
  // realistic 24 MP interchangeable-lens camera (Bayer, demosaic, JPEG, defocus, panel fall-off, glare).
  // A level may carry scene overrides after '+' (an ablation: "on+imaging.glare=0+imaging.f_number=0").
  const std::vector<std::string> parts = SplitList(level, '+');
  std::vector<std::string> set;
  if (!parts.empty() && parts[0] == "off") set.push_back("imaging.preset=clean");
  if (!parts.empty() && parts[0] == "on") set.push_back("imaging.preset=ilc24");
  if (set.empty()) {
    throw Error("--realism", fmt::format("'{}' is not a level", level),
                "give on, off or on,off, each optionally followed by +dotted.key=value scene overrides");
  }
  for (size_t i = 1; i < parts.size(); ++i) {
    if (parts[i].find('=') == std::string::npos || parts[i].front() == '=') {
      throw Error("--realism", fmt::format("'{}' in '{}' is not a dotted.key=value override", parts[i], level),
                  "give e.g. on+imaging.glare=0");
    }
    set.push_back(parts[i]);
  }
  return set;
}

const ShardFiles& ValidityShardFiles() {
  static const ShardFiles files{"validity.json",
                                "validity_trials.csv",
                                kFormat,
                                "curvecheck bench validity",
                                "validity bench",
                                "same grid, trials, seed, scene, jitter, board",
                                {"cell", "reason", "trial_ms"},
                                "/summary/trials"};
  return files;
}

void BenchValidityOptions::Check() const {
  const auto list = [](const std::vector<double>& v, const char* option, double lo, double hi, bool open_lo,
                       const char* example) {
    if (v.empty()) throw Error(option, "is empty", fmt::format("give e.g. {}", example));
    for (double x : v) {
      if (!(open_lo ? x > lo : x >= lo) || !(x <= hi)) {
        throw Error(option, fmt::format("{:g} is outside {}{:g}, {:g}]", x, open_lo ? "(" : "[", lo, hi),
                    fmt::format("give e.g. {}", example));
      }
    }
  };
  list(scales, "--scales", 0, 1, true, "0.25,0.5,1");
  list(distances_mm, "--distances-mm", 300, 20000, false, "1000,2000,3000");
  list(yaws_deg, "--yaws-deg", -80, 80, false, "0,20,40");
  list(radius_factors, "--radius-factors", 0.5, 2, false, "0.92,1,1.08");
  if (realism.empty()) throw Error("--realism", "is empty", "give on, off or on,off");
  for (const std::string& r : realism) RealismOverrides(r);
  CheckCount(trials, 1, 10000, "--trials");
  if (seed < 0) throw Error("--seed", "must be 0 or more", "");
  if (!(jitter_mm >= 0 && jitter_mm <= 100) || !(jitter_deg >= 0 && jitter_deg <= 5)) {
    throw Error("bench validity", "the jitter must be 0..100 mm and 0..5 deg", "");
  }
  if (!(pitch_tolerance_percent >= 0 && pitch_tolerance_percent <= 5)) {
    throw Error("--pitch-tolerance", fmt::format("{:g} % is not in [0, 5]", pitch_tolerance_percent),
                "give e.g. 0.1 (the analysis's default, percent) or 0 for the datasheet's pitch exactly");
  }
  if (!(lens_misfit_stated >= 0 && lens_misfit_stated <= 10)) {
    throw Error("--lens-misfit-stated", fmt::format("{:g} is not in [0, 10]", lens_misfit_stated),
                "give 1 (the true lens's misfit, as a calibration that measured it exactly), 0 (none stated) or "
                "a factor such as 0.5 or 2");
  }
  if (!(pixel_locking_prior_px >= 0)) {
    throw Error("--pixel-locking-prior", fmt::format("{:g} px is negative", pixel_locking_prior_px),
                "give e.g. 0.1 (the analysis's default) or 0 (no prior)");
  }
  if (ParsePatternKind(pattern, "--pattern") == PatternKind::kBoth) {
    throw Error("--pattern", "'both' is not a pattern of this bench", "give checkerboard or apriltag");
  }
  CheckCount(tag_cols, 1, 64, "--tags");
  CheckCount(tag_rows, 1, 64, "--tags");
  shard.Check();
}

bool RunBenchValidity(const BenchValidityOptions& o, const fs::path& out, std::ostream& log) {
  o.Check();
  Bench b;
  b.options = o;
  b.grid = GridOf(o);
  for (const std::string& level : o.realism)
    b.scenes[level] = LoadSceneWithOverrides(o.scene, RealismOverrides(level));
  const SyntheticScene& first = b.scenes.begin()->second;
  if (first.monitor.curvature_per_mm == 0) {
    throw Error("--scene", fmt::format("'{}' has a flat monitor", o.scene),
                "bench validity measures the radius: give the scene of a curved monitor");
  }
  b.spec.kind = ParsePatternKind(o.pattern, "--pattern");
  b.spec.cols = o.cols;
  b.spec.rows = o.rows;
  b.spec.tag_cols = o.tag_cols;
  b.spec.tag_rows = o.tag_rows;
  b.scratch = out / fmt::format(".validity-scratch-{}", o.shard.index);
  fs::create_directories(b.scratch);
  if (o.keep_results) {
    b.results = out / "results";
    fs::create_directories(b.results);
  }
  const int total = b.grid.Cells() * o.trials;
  std::vector<int> mine;
  for (int k = 0; k < total; ++k) {
    if (o.shard.Has(k)) mine.push_back(k);
  }
  std::string levels;
  for (const std::string& level : o.realism) {
    const std::vector<std::string> set = RealismOverrides(level);
    levels +=
        fmt::format("{}{} = {}", levels.empty() ? "" : "; ", level,
                    set.empty() ? std::string("the scene's own") : fmt::format("{}", fmt::join(set, " ")));
  }
  const std::string machine = DescribeMachine();
  const std::string head = fmt::format(
      "{}\n{}\nbench validity: scene {} ({}, nominal R {:.0f} mm), camera {} {}x{} scaled by {}; distances "
      "{} mm; "
      "yaws {} deg around the screen centre; realism {}; true radius x {}; {}, exact rendering for "
      "the "
      "camera's position; camera jitter {:g} mm and {:g} deg per axis (1 sigma); true pixel pitch the "
      "datasheet's x (1 + d), d uniform in +-{:g}%; the default analysis (the chosen model's numbers) with "
      "that pitch tolerance and told the true lens's misfit x {:g} as its calibration's (0: none); {} cells x {} trials = {} trials, shard {}/{} runs {}; seed {} (trial k: seed + "
      "k)\n",
      o.command_line, machine, o.scene, first.monitor.name, 1 / first.monitor.curvature_per_mm,
      first.camera.lensmodel, first.camera.width, first.camera.height, fmt::join(o.scales, ","),
      fmt::join(o.distances_mm, ","), fmt::join(o.yaws_deg, ","), levels, fmt::join(o.radius_factors, ","),
      b.spec.kind == PatternKind::kAprilTag ? fmt::format("{}x{} tag36h11 tags", o.tag_cols, o.tag_rows)
                                            : fmt::format("{}x{} board", o.cols, o.rows),
      o.jitter_mm, o.jitter_deg, o.pitch_tolerance_percent, o.lens_misfit_stated, b.grid.Cells(), o.trials, total, o.shard.index,
      o.shard.count, mine.size(), o.seed);
  log << head << std::flush;

  SweepTable trials;
  trials.header = TrialColumns();
  const Stopwatch wall;
  for (size_t i = 0; i < mine.size(); ++i) {
    std::string line;
    trials.rows.push_back(RunTrial(b, mine[i], &line));
    log << fmt::format("[{}/{}] #{} {}\n", i + 1, mine.size(), mine[i], line) << std::flush;
  }
  const double wall_s = wall.Seconds();
  std::error_code ec;
  fs::remove_all(b.scratch, ec);
  b.renderer.reset();

  json grid = b.grid.ToJson();
  grid["scene"] = o.scene;
  grid["seed"] = o.seed;
  grid["jitter"] = {{"position_mm", o.jitter_mm}, {"aim_deg", o.jitter_deg}};
  grid["pitch_tolerance_percent"] = o.pitch_tolerance_percent;
  grid["lens_misfit_stated"] = o.lens_misfit_stated;
  grid["correct_pixel_locking"] = o.correct_pixel_locking;
  grid["pixel_locking_prior_px"] = o.pixel_locking_prior_px;
  grid["detector_effect"] = o.detector_effect;
  grid["board"] = {o.cols, o.rows};
  grid["pattern"] = o.pattern;
  grid["tags"] = {o.tag_cols, o.tag_rows};
  json overrides = json::object();
  for (const std::string& level : o.realism) overrides[level] = RealismOverrides(level);
  grid["realism_overrides"] = overrides;
  grid["trials"] = total;
  const std::string timing = fmt::format("{} trials in {:.1f} s wall: {:.2f} s per trial\n", mine.size(),
                                         wall_s, mine.empty() ? 0.0 : wall_s / mine.size());
  log << timing;
  const json meta = {{"format", kFormat},
                     {"command", o.command_line},
                     {"machine", machine},
                     {"grid", grid},
                     {"shard", {{"index", o.shard.index}, {"count", o.shard.count}, {"trials", mine.size()}}},
                     {"wall_s", wall_s}};
  return WriteOutputs(out, trials, meta, head + timing, log);
}

bool MergeBenchValidity(const std::vector<fs::path>& dirs, const fs::path& out,
                        const std::string& command_line, std::ostream& log) {
  MergedShards merged = ReadShards(dirs, ValidityShardFiles());
  const int total = merged.grid.at("trials").get<int>();
  const int missing = total - static_cast<int>(merged.table.rows.size());
  const std::string head = fmt::format(
      "{}\nmerged {} folders: {} of {} trials{}\n", command_line, dirs.size(), merged.table.rows.size(),
      total,
      missing > 0 ? fmt::format(" ({} missing: merge the remaining shards for the full grid)", missing)
                  : std::string());
  log << head;
  const json meta = {{"format", kFormat},
                     {"command", command_line},
                     {"grid", merged.grid},
                     {"merged_from", merged.merged_from},
                     {"missing_trials", missing}};
  return WriteOutputs(out, merged.table, meta, head, log);
}

}  // namespace curvecheck::experiments
