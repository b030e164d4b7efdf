#include "experiments/bench_self_calibrate.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "core/error.h"
#include "core/file_io.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "core/stopwatch.h"
#include "calibrate/projection_compare.h"
#include "experiments/scene_lookup.h"
#include "experiments/verdict_tally.h"
#include "synth/synthetic_camera.h"

namespace curvecheck::experiments {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

void BenchSelfCalibrateOptions::Check() const {
  RequireInRange("--trials", "trials", trials, 1, 1000, "give 1 to 1000");
  RequireInRange("--scale", "scale", scale, 0.05, 1, "give e.g. 0.25");
  if (min_photos < 3 || max_photos < min_photos || max_photos > 40) {
    throw Error("--photos", fmt::format("{} to {} photos", min_photos, max_photos), "give e.g. 8 to 12");
  }
  RequireInRange("--radius-spread", "radius_spread", radius_spread, 0, 0.5, "give e.g. 0.05");
  RequireInRange("--focal-seed-error", "focal_seed_error", focal_seed_error, 0, 0.3, "give e.g. 0.1");
  RequireInRange("pitch_tolerance", "pitch_tolerance", pitch_tolerance, 0, 0.05, "give e.g. 0.001 (0.1%)");
}

SelfCalibrationTrial RunSelfCalibrationTrial(const SyntheticScene& base, const TrialDisplay& display,
                                             const PatternFile& pattern,
                                             const std::vector<Eigen::Vector3d>& positions_in_screen,
                                             double aim_jitter_deg, uint64_t seed, double focal_seed_px,
                                             const FromScreenOptions& given, bool follow_advice) {
  const Stopwatch watch;
  SelfCalibrationTrial t;
  t.true_radius_mm = base.truth.curvature_per_mm != 0 ? 1 / base.truth.curvature_per_mm : kNaN;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> aim(0, aim_jitter_deg * M_PI / 180);
  const Eigen::Vector3d centre = ScreenCentreInScreen(base.monitor);
  std::vector<PhotoObservations> obs;
  std::vector<Eigen::Vector2d> observed;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300), hi = Eigen::Vector2d::Constant(-1e300);
  const auto photograph = [&](const Eigen::Vector3d& position, const Eigen::Vector3d& look_at) {
    SyntheticScene scene = base;
    scene.sensor.seed = seed * 1000 + obs.size();
    const Eigen::Vector3d a(aim(rng), aim(rng), aim(rng));
    const Eigen::Matrix3d turn = AngleAxisFromVector(a).toRotationMatrix();
    scene.screen_from_cam =
        Pose(ScreenFromCamLookAt(position, look_at, Eigen::Vector3d::UnitY()).RotationMatrix() * turn, position);
    const SyntheticPhoto photo = RenderSyntheticPhoto(scene, display.image);
    PhotoObservations o =
        ObserveScreenImage(PhotoToMat(photo), fmt::format("photo{}", obs.size()), pattern, DetectOptions{});
    for (const Eigen::Vector2d& q : o.detected_px) lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
    observed.insert(observed.end(), o.detected_px.begin(), o.detected_px.end());
    obs.push_back(std::move(o));
  };
  // The lens against the truth over the cells that hold detections (the rotation fitted there).
  const int gw = 30, gh = 20;
  const std::vector<Eigen::Vector2d> grid = ImagerGrid(base.camera.width, base.camera.height, gw, gh);
  const auto compare = [&](const FromScreenResult& r) {
    return CompareProjections({base.camera, {}}, {r.model, r.intrinsics_covariance}, grid,
                              CoveredCells(observed, base.camera.width, base.camera.height, gw, gh));
  };
  try {
    for (const Eigen::Vector3d& p : positions_in_screen) photograph(p, centre);
    FromScreenOptions options = given;
    options.focal_px = focal_seed_px;
    options.refuse_imprecise = false;
    FromScreenResult r = CalibrateFromScreen(obs, base.monitor, base.camera.width, base.camera.height, options);
    t.first_precise = r.precise;
    t.first_cells_median_px = compare(r).median_px;
    t.first_sigma_px = r.projection.covered_median_sigma_px;
    if (!r.precise && follow_advice) {
      // The user follows the refusal's advice: the suggested photos are added and the calibration is run again.
      for (const SuggestedPosition& p : r.suggested) photograph(p.position_mm, p.look_at_mm);
      r = CalibrateFromScreen(obs, base.monitor, base.camera.width, base.camera.height, options);
    }
    t.photos = static_cast<int>(obs.size());
    t.precise = r.precise;
    t.lensmodel = r.model.lensmodel;
    const std::vector<double> diff = LensDifferencePx(base.camera, r.model, gw, gh, 1500);
    t.lens_median_px = Median(diff);
    std::vector<double> covered;
    for (int j = 0; j < gh; ++j) {
      for (int i = 0; i < gw; ++i) {
        const Eigen::Vector2d q((base.camera.width - 1) * i / (gw - 1.0), (base.camera.height - 1) * j / (gh - 1.0));
        if ((q.array() >= lo.array()).all() && (q.array() <= hi.array()).all()) {
          covered.push_back(diff[static_cast<size_t>(j * gw + i)]);
        }
      }
    }
    t.lens_covered_median_px = covered.empty() ? kNaN : Median(covered);
    t.lens_covered_max_px = covered.empty() ? kNaN : *std::max_element(covered.begin(), covered.end());
    const ProjectionComparison c = compare(r);
    t.cells_median_px = c.median_px;
    t.cells_max_px = c.max_px;
    t.cells_median_sigma_px = c.median_sigma_px;
    t.cells_max_mahalanobis = c.max_mahalanobis;
    if (r.radius_mm && r.radius_sigma_mm) {
      t.radius_mm = *r.radius_mm;
      t.radius_sigma_mm = *r.radius_sigma_mm;
      t.in_ci95 = r.radius_ci95_mm[0] <= t.true_radius_mm && t.true_radius_mm <= r.radius_ci95_mm[1];
      t.within_2sigma = std::abs(t.radius_mm - t.true_radius_mm) <= 2 * t.radius_sigma_mm;
    } else {
      t.error = "no radius";
    }
  } catch (const Error& e) {
    t.error = e.what();
  }
  t.seconds = watch.Seconds();
  return t;
}

void RunBenchSelfCalibrate(const BenchSelfCalibrateOptions& o, const std::filesystem::path& dir, std::ostream& log) {
  o.Check();
  const SyntheticScene scene0 = FindScene(o.scene, "--scene");
  Renderer renderer;
  const Eigen::Vector3d viewpoint = ScreenCentreInScreen(scene0.monitor) + Eigen::Vector3d(0, 0, 1500);
  const TrialDisplay display = RenderTrialDisplay(renderer, scene0.monitor, viewpoint, PatternSpec{});
  const PatternFile pattern = ParsePatternJson(display.PatternJson().dump(), "the bench's pattern.json");
  std::string csv = "trial,seed,photos,lensmodel,lens_median_px,lens_covered_median_px,lens_covered_max_px,"
                    "cells_median_px,cells_max_px,cells_median_sigma_px,cells_max_mahalanobis,first_precise,"
                    "first_cells_median_px,first_sigma_px,precise,true_radius_mm,radius_mm,radius_sigma_mm,in_ci95,within_2sigma,seconds,error\n";
  log << fmt::format("bench calibrate --from-screen: {} trials, {} to {} photos at scale {}, scene {}; true pixel "
                     "pitch the datasheet's x (1 + d), d uniform in +-{:g}%\n",
                     o.trials, o.min_photos, o.max_photos, o.scale, o.scene, 100 * o.pitch_tolerance);
  log << "columns: imager/covered/cov.max = the lens against the truth (px; mrcal projection_diff, rotation fitted "
         "at the centre) over the imager and the detections' bounding box; 1st: the first calibration's precision "
         "check (sigma = its median projection sigma over the cells holding detections, err = its error there, "
         "rotation fitted there), then the suggested photos added when it failed; cells/cells.max/sigma/m.max = the "
         "final calibration over those cells (m = Mahalanobis distance of the truth)\n";
  log << fmt::format(
      "{:>5} {:>6} {:>9} {:>7} {:>7} {:>8} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>5} {:>7} {:>7} {:>5} {:>4} {:>5}\n",
      "trial", "photos", "model", "1st sig", "1st err", "1st", "imager", "covered", "cov.max", "cells", "cel.max",
      "sigma", "m.max", "R true", "R", "sigma", "ci95", "s")
      << std::flush;
  std::vector<double> lens, lens_covered, cells, cells_max, precise_first, advised_before, advised_after;
  int n = 0, in95 = 0, in2s = 0, failed = 0;
  for (int k = 0; k < o.trials; ++k) {
    const uint64_t seed = o.seed + static_cast<uint64_t>(k);
    std::mt19937_64 rng(seed * 7919);
    std::uniform_int_distribution<int> count(o.min_photos, o.max_photos);
    std::uniform_real_distribution<double> ux(-450, 450), uy(-120, 120), uz(400, 650), ur(-1, 1);
    std::normal_distribution<double> unit(0, 1);
    SyntheticScene scene = scene0;
    scene.camera = ScaledCamera(scene0.camera, o.scale);
    scene.imaging.lens_seed = seed;
    scene.truth.curvature_per_mm = scene0.monitor.curvature_per_mm / (1 + o.radius_spread * ur(rng));
    std::vector<Eigen::Vector3d> positions;
    const int photos = count(rng);
    for (int i = 0; i < photos; ++i) positions.emplace_back(ux(rng), uy(rng), uz(rng));
    const double focal_seed = scene.camera.intrinsics[0] * (1 + o.focal_seed_error * unit(rng));
    // Drawn last, so that a seed's photos and focal seed stay those of the runs before the pitch was drawn.
    scene.truth.pitch_scale = 1 + o.pitch_tolerance * ur(rng);
    const SelfCalibrationTrial t =
        RunSelfCalibrationTrial(scene, display, pattern, positions, 1.0, seed, focal_seed, {}, o.follow_advice);
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.1f},\"{}\"\n", k, seed,
                       t.photos, t.lensmodel, t.lens_median_px, t.lens_covered_median_px, t.lens_covered_max_px,
                       t.cells_median_px, t.cells_max_px, t.cells_median_sigma_px, t.cells_max_mahalanobis,
                       t.first_precise ? 1 : 0, t.first_cells_median_px, t.first_sigma_px, t.precise ? 1 : 0,
                       t.true_radius_mm,
                       t.radius_mm, t.radius_sigma_mm, t.in_ci95 ? 1 : 0, t.within_2sigma ? 1 : 0, t.seconds, t.error);
    if (!t.error.empty()) {
      ++failed;
      log << fmt::format("{:>5} {:>6} failed: {}\n", k, t.photos, t.error) << std::flush;
      continue;
    }
    ++n;
    in95 += t.in_ci95 ? 1 : 0;
    in2s += t.within_2sigma ? 1 : 0;
    lens.push_back(t.lens_median_px);
    lens_covered.push_back(t.lens_covered_median_px);
    cells.push_back(t.cells_median_px);
    cells_max.push_back(t.cells_max_px);
    (t.first_precise ? precise_first : advised_after).push_back(t.cells_median_px);
    if (!t.first_precise) advised_before.push_back(t.first_cells_median_px);
    log << fmt::format(
               "{:>5} {:>6} {:>9} {:>7.3f} {:>7.3f} {:>8} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f} "
               "{:>5.1f} {:>7.1f} {:>7.1f} {:>5.1f} {:>4} {:>5.0f}\n",
               k, t.photos, t.lensmodel.substr(16), t.first_sigma_px, t.first_cells_median_px,
               t.first_precise ? "precise" : "advised", t.lens_median_px, t.lens_covered_median_px,
               t.lens_covered_max_px, t.cells_median_px, t.cells_max_px, t.cells_median_sigma_px,
               t.cells_max_mahalanobis, t.true_radius_mm, t.radius_mm, t.radius_sigma_mm, t.in_ci95 ? "yes" : "NO",
               t.seconds)
        << std::flush;
  }
  WriteFileAtomic(dir / "self_calibrate_trials.csv", csv);
  const BinomialInterval w95 = WilsonInterval(in95, n), w2s = WilsonInterval(in2s, n);
  int lens_ok = 0;
  for (double v : lens) lens_ok += v < 0.3 ? 1 : 0;
  log << fmt::format(
      "summary: {} trials ({} failed or refused); lens median difference over the imager: median {:.3f} px, max "
      "{:.3f} px, below 0.3 px in {} of {}; over the covered area: median {:.3f} px, max {:.3f} px\n",
      o.trials, failed, lens.empty() ? kNaN : Median(lens),
      lens.empty() ? kNaN : *std::max_element(lens.begin(), lens.end()),
      lens_ok, n, lens_covered.empty() ? kNaN : Median(lens_covered),
      lens_covered.empty() ? kNaN : *std::max_element(lens_covered.begin(), lens_covered.end()));
  const auto median = [](const std::vector<double>& v) { return v.empty() ? kNaN : Median(v); };
  const auto max_of = [](const std::vector<double>& v) {
    return v.empty() ? kNaN : *std::max_element(v.begin(), v.end());
  };
  int cells_ok = 0;
  for (double v : cells) cells_ok += v < 0.3 ? 1 : 0;
  const BinomialInterval wc = WilsonInterval(cells_ok, static_cast<int>(cells.size()));
  log << fmt::format(
      "over the cells holding detections (final calibration): median over trials {:.3f} px, worst trial {:.3f} px, "
      "below 0.3 px in {} of {} (Wilson 95% interval {:.1f}-{:.1f}%); largest cell error: median {:.3f} px, worst "
      "{:.3f} px\n",
      median(cells), max_of(cells), cells_ok, cells.size(), 100 * wc.lo, 100 * wc.hi, median(cells_max),
      max_of(cells_max));
  log << fmt::format(
      "precision check (median projection sigma <= {:.3f} px over those cells): passed at first in {} trials (their "
      "error median {:.3f} px, worst {:.3f} px); failed in {} (error before the suggested photos: median {:.3f} px, "
      "worst {:.3f} px; after{}: median {:.3f} px, worst {:.3f} px)\n",
      FromScreenOptions{}.max_projection_sigma_px, precise_first.size(), median(precise_first),
      max_of(precise_first), advised_before.size(), median(advised_before), max_of(advised_before),
      o.follow_advice ? "" : " (not followed: --ignore-advice)", median(advised_after), max_of(advised_after));
  log << fmt::format(
      "radius 95% interval coverage: {} of {} = {:.1f}% (Wilson 95% interval {:.1f}-{:.1f}%; accepted band 90-98%); "
      "within 2 sigma: {} of {} = {:.1f}% (Wilson {:.1f}-{:.1f}%)\n",
      in95, n, n ? 100.0 * in95 / n : kNaN, 100 * w95.lo, 100 * w95.hi, in2s, n, n ? 100.0 * in2s / n : kNaN,
      100 * w2s.lo, 100 * w2s.hi);
  log << fmt::format("wrote {}\n", (dir / "self_calibrate_trials.csv").string());
}

}  // namespace curvecheck::experiments
