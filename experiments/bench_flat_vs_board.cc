#include "experiments/bench_flat_vs_board.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "calibrate/calibrate.h"
#include "calibrate/from_screen.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "core/stopwatch.h"
#include "datasets/monitor_presets.h"
#include "experiments/scene_lookup.h"
#include "experiments/trial.h"
#include "experiments/verdict_tally.h"
#include "synth/synthetic_board.h"
#include "synth/synthetic_camera.h"

namespace curvecheck::experiments {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kGridX = 30, kGridY = 20;

// Whether the four corners of the screen project inside the image with a margin (fraction of its size).
bool ScreenInside(const SyntheticScene& scene, double margin) {
  const Pose cam_from_screen = scene.screen_from_cam.Inverse();
  for (const Eigen::Vector2d& uv : {Eigen::Vector2d(-1, -1), Eigen::Vector2d(1, -1), Eigen::Vector2d(-1, 1),
                                   Eigen::Vector2d(1, 1)}) {
    const Eigen::Vector3d p = cam_from_screen * SurfacePointFromUv(scene.monitor, uv);
    if (p.z() <= 0) return false;
    const Eigen::Vector2d q = ProjectPoint(scene.camera, p);
    if (!(q.x() > margin * scene.camera.width && q.x() < (1 - margin) * scene.camera.width &&
          q.y() > margin * scene.camera.height && q.y() < (1 - margin) * scene.camera.height)) {
      return false;
    }
  }
  return true;
}

std::vector<bool> And(const std::vector<bool>& a, const std::vector<bool>& b) {
  std::vector<bool> out(a.size());
  for (size_t i = 0; i < a.size(); ++i) out[i] = a[i] && b[i];
  return out;
}

}  // namespace

void BenchFlatVsBoardOptions::Check() const {
  RequireInRange("--trials", "trials", trials, 1, 1000, "give 1 to 1000");
  RequireInRange("--scale", "scale", scale, 0.05, 1, "give e.g. 0.25");
  if (min_photos < 3 || max_photos < min_photos || max_photos > 40) {
    throw Error("--photos", fmt::format("{} to {} photos", min_photos, max_photos), "give e.g. 8 to 12");
  }
  if (!(z_min_mm > 0 && z_max_mm >= z_min_mm && max_x_mm >= 0 && max_y_mm >= 0)) {
    throw Error("--flat-vs-board", "the camera position ranges are empty or behind the screen",
                "give z_min_mm > 0, z_max_mm >= z_min_mm");
  }
  RequireInRange("--board-views", "board_views", board_views, 6, 100, "give e.g. 24");
}

FlatVsBoardTrial RunFlatVsBoardTrial(const BenchFlatVsBoardOptions& o, uint64_t seed) {
  o.Check();
  const Stopwatch watch;
  FlatVsBoardTrial t;
  SyntheticScene scene = FindScene(o.scene, "--scene");
  scene.camera = ScaledCamera(scene.camera, o.scale);
  scene.imaging.lens_seed = seed;
  scene.monitor = LoadMonitor(o.monitor);
  if (!scene.monitor.is_flat()) throw Error("--monitor", o.monitor + " is not flat", "give a flat monitor preset");
  scene.truth = TrueMonitor{};
  Renderer renderer;
  const Eigen::Vector3d centre = ScreenCentreInScreen(scene.monitor);
  const TrialDisplay display =
      RenderTrialDisplay(renderer, scene.monitor, centre + Eigen::Vector3d(0, 0, 0.5 * (o.z_min_mm + o.z_max_mm)),
                         PatternSpec{});
  const PatternFile pattern = ParsePatternJson(display.PatternJson().dump(), "the bench's pattern.json");
  std::mt19937_64 rng(seed * 7919 + 17);
  std::uniform_int_distribution<int> count(o.min_photos, o.max_photos);
  std::uniform_real_distribution<double> ur(-1, 1);
  std::normal_distribution<double> unit(0, 1), aim(0, M_PI / 180);
  const double w_mm = scene.monitor.width_mm, h_mm = scene.monitor.height_mm;
  std::vector<PhotoObservations> obs;
  std::vector<Eigen::Vector2d> screen_px, board_px;
  try {
    t.photos = count(rng);
    for (int i = 0; i < t.photos; ++i) {
      for (int attempt = 0;; ++attempt) {
        if (attempt == 200) {
          throw Error("--flat-vs-board", "no camera position shows the whole screen",
                      "raise z_min_mm or lower max_x_mm, max_y_mm");
        }
        const Eigen::Vector3d position(o.max_x_mm * ur(rng), o.max_y_mm * ur(rng),
                                       o.z_min_mm + (o.z_max_mm - o.z_min_mm) * 0.5 * (1 + ur(rng)));
        const Eigen::Vector3d look = centre + Eigen::Vector3d(0.15 * w_mm * ur(rng), 0.15 * h_mm * ur(rng), 0);
        const Eigen::Vector3d a(aim(rng), aim(rng), aim(rng));
        scene.screen_from_cam =
            Pose(ScreenFromCamLookAt(position, look, Eigen::Vector3d::UnitY()).RotationMatrix() *
                     Eigen::AngleAxisd(a.norm(), a.norm() > 0 ? a.normalized() : Eigen::Vector3d::UnitZ())
                         .toRotationMatrix(),
                 position);
        if (ScreenInside(scene, 0.02)) break;
      }
      scene.sensor.seed = seed * 1000 + static_cast<uint64_t>(i);
      const SyntheticPhoto photo = RenderSyntheticPhoto(scene, display.image);
      PhotoObservations p = ObserveScreenImage(PhotoToMat(photo), fmt::format("flat{}", i), pattern, DetectOptions{});
      screen_px.insert(screen_px.end(), p.detected_px.begin(), p.detected_px.end());
      obs.push_back(std::move(p));
    }
    FromScreenOptions fso;
    fso.focal_px = scene.camera.intrinsics[0] * (1 + 0.1 * unit(rng));
    const FromScreenResult fs = CalibrateFromScreen(obs, scene.monitor, scene.camera.width, scene.camera.height, fso);
    t.screen_lensmodel = fs.model.lensmodel;
    const Eigen::MatrixXd& screen_cov = fs.Chosen().fit.Chosen().intrinsics_covariance;

    SyntheticBoardOptions bo;
    bo.camera = scene.camera;
    bo.views = o.board_views;
    bo.imaging = scene.imaging;
    bo.seed = seed;
    // Squares of 48 display px at 0.5 mm (24 mm): the board (11 x 8 squares, 264 x 192 mm) fills 0.4-0.85 of the
    // image at 0.26-0.55 m for the default camera.
    bo.pixel_pitch_mm = 0.5;
    const SyntheticBoardSet set = MakeSyntheticBoardSet(bo);
    std::vector<ChessboardDetection> detections;
    for (const SyntheticBoardView& v : set.views) {
      detections.push_back(DetectChessboard(v.photo, set.board, ChessboardOptions()));
      if (detections.back().found) {
        board_px.insert(board_px.end(), detections.back().corners_px.begin(), detections.back().corners_px.end());
      }
    }
    CalibrateOptions co;
    co.lensmodels = {"LENSMODEL_OPENCV5"};
    co.cross_validate = false;
    co.seed = seed;
    const CalibrationResult board = Calibrate(detections, set.board, co);
    const CandidateResult& bc = board.Chosen();
    if (!bc.error.empty()) throw Error("board calibration", bc.error, "");
    t.board_lensmodel = board.model.lensmodel;

    const std::vector<Eigen::Vector2d> grid = ImagerGrid(scene.camera.width, scene.camera.height, kGridX, kGridY);
    const std::vector<bool> region =
        And(CoveredCells(screen_px, scene.camera.width, scene.camera.height, kGridX, kGridY),
            CoveredCells(board_px, scene.camera.width, scene.camera.height, kGridX, kGridY));
    t.cells = static_cast<int>(std::count(region.begin(), region.end(), true));
    const LensWithCovariance s{fs.model, screen_cov}, b{board.model, bc.intrinsics_covariance}, truth{scene.camera, {}};
    t.screen_vs_board = CompareProjections(b, s, grid, region);
    t.screen_vs_truth = CompareProjections(truth, s, grid, region);
    t.board_vs_truth = CompareProjections(truth, b, grid, region);
    t.threshold_mahalanobis = AgreementBound(t.screen_vs_board);
    t.agree = Agree(t.screen_vs_board);
    t.fx_screen = fs.model.intrinsics[0];
    t.fx_screen_sigma = screen_cov.rows() ? std::sqrt(screen_cov(0, 0)) : kNaN;
    t.fx_board = board.model.intrinsics[0];
    t.fx_board_sigma = bc.intrinsics_covariance.rows() ? std::sqrt(bc.intrinsics_covariance(0, 0)) : kNaN;
  } catch (const Error& e) {
    t.error = e.what();
  }
  t.seconds = watch.Seconds();
  return t;
}

void RunBenchFlatVsBoard(const BenchFlatVsBoardOptions& o, const std::filesystem::path& dir, std::ostream& log) {
  o.Check();
  log << fmt::format(
      "bench calibrate --flat-vs-board: {} trials, {} flat monitor, {}-{} photos from x +-{:.0f}, y +-{:.0f}, z "
      "{:.0f}-{:.0f} mm; {} board views; scene {} at scale {}\n",
      o.trials, o.monitor, o.min_photos, o.max_photos, o.max_x_mm, o.max_y_mm, o.z_min_mm, o.z_max_mm, o.board_views,
      o.scene, o.scale);
  log << fmt::format("{:>5} {:>6} {:>8} {:>5} {:>14} {:>14} {:>8} {:>8} {:>7} {:>7} {:>5} {:>6} {:>8} {:>8} {:>6}\n",
                     "trial", "photos", "screen", "cells", "fx screen", "fx board", "|d| med", "|d| max", "sig med",
                     "m max", "limit", "agree", "scr-tru", "brd-tru", "s")
      << std::flush;
  std::string csv =
      "trial,seed,photos,screen_lensmodel,board_lensmodel,cells,fx_screen,fx_screen_sigma,fx_board,fx_board_sigma,"
      "diff_median_px,diff_max_px,sigma_median_px,sigma_max_px,mahalanobis_median,mahalanobis_max,rank,"
      "threshold_mahalanobis,agree,screen_truth_median_px,screen_truth_max_px,screen_truth_mahalanobis_max,"
      "board_truth_median_px,board_truth_max_px,board_truth_mahalanobis_max,seconds,error\n";
  int n = 0, agree = 0, failed = 0;
  std::vector<double> m_max;
  for (int k = 0; k < o.trials; ++k) {
    const uint64_t seed = o.seed + static_cast<uint64_t>(k);
    const FlatVsBoardTrial t = RunFlatVsBoardTrial(o, seed);
    const ProjectionComparison &c = t.screen_vs_board, &st = t.screen_vs_truth, &bt = t.board_vs_truth;
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.1f},\"{}\"\n", k,
                       seed, t.photos, t.screen_lensmodel, t.board_lensmodel, t.cells, t.fx_screen, t.fx_screen_sigma,
                       t.fx_board, t.fx_board_sigma, c.median_px, c.max_px, c.median_sigma_px, c.max_sigma_px,
                       c.median_mahalanobis, c.max_mahalanobis, c.rank, t.threshold_mahalanobis, t.agree ? 1 : 0,
                       st.median_px, st.max_px, st.max_mahalanobis, bt.median_px, bt.max_px, bt.max_mahalanobis,
                       t.seconds, t.error);
    if (!t.error.empty()) {
      ++failed;
      log << fmt::format("{:>5} {:>6} refused or failed: {}\n", k, t.photos, t.error) << std::flush;
      continue;
    }
    ++n;
    agree += t.agree ? 1 : 0;
    m_max.push_back(c.max_mahalanobis);
    log << fmt::format(
               "{:>5} {:>6} {:>8} {:>5} {:>8.2f}+-{:<5.2f} {:>8.2f}+-{:<5.2f} {:>8.3f} {:>8.3f} {:>7.3f} {:>7.2f} "
               "{:>5.2f} {:>6} {:>8.3f} {:>8.3f} {:>6.0f}\n",
               k, t.photos, t.screen_lensmodel.substr(10), t.cells, t.fx_screen, t.fx_screen_sigma, t.fx_board,
               t.fx_board_sigma, c.median_px, c.max_px, c.median_sigma_px, c.max_mahalanobis,
               t.threshold_mahalanobis, t.agree ? "yes" : "NO", st.median_px, bt.median_px, t.seconds)
        << std::flush;
  }
  WriteFileAtomic(dir / "flat_vs_board_trials.csv", csv);
  const BinomialInterval w = WilsonInterval(agree, n);
  log << fmt::format(
      "summary: {} trials ({} refused or failed); the flat-monitor and board calibrations agreed (largest per-cell "
      "Mahalanobis distance within the Bonferroni bound over the combined covariance's rank, 95% family-wise) in {} "
      "of {} = {:.1f}% (Wilson 95% interval {:.1f}-{:.1f}%; honest uncertainties give >= 95%); median of the largest "
      "Mahalanobis distance {:.2f}\n",
      o.trials, failed, agree, n, n ? 100.0 * agree / n : kNaN, 100 * w.lo, 100 * w.hi,
      m_max.empty() ? kNaN : Median(m_max));
  log << fmt::format("wrote {}\n", (dir / "flat_vs_board_trials.csv").string());
}

}  // namespace curvecheck::experiments
