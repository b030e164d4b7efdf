#include "experiments/bench_flat_vs_board.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>

#include "calibrate/calibrate.h"
#include "calibrate/from_screen.h"
#include "core/correction.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "core/stopwatch.h"
#include "datasets/monitor_presets.h"
#include "experiments/scene_lookup.h"
#include "experiments/verdict_tally.h"
#include "pattern/pattern.h"
#include "pattern/pattern_json.h"
#include "render/renderer.h"
#include "synth/lens_misfit.h"
#include "synth/synthetic_board.h"
#include "synth/synthetic_camera.h"
#include "synth/true_monitor.h"

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


// The observations of one seed (cache file, format curvecheck.flat_vs_board_cache/1).
struct ObservationCache {
  std::vector<PhotoObservations> screen;
  BoardSpec board;
  std::vector<ChessboardDetection> detections;
  std::vector<std::vector<Eigen::Vector2d>> board_true_px;  // per view, the corners' true image positions
};

nlohmann::json Points(const std::vector<Eigen::Vector2d>& v) {
  nlohmann::json out = nlohmann::json::array();
  for (const Eigen::Vector2d& q : v) out.push_back({q.x(), q.y()});
  return out;
}

std::vector<Eigen::Vector2d> PointsFrom(const nlohmann::json& j) {
  std::vector<Eigen::Vector2d> out;
  for (const nlohmann::json& q : j) out.emplace_back(q[0].get<double>(), q[1].get<double>());
  return out;
}

void WriteCache(const std::filesystem::path& path, const ObservationCache& c) {
  nlohmann::json j;
  j["format"] = "curvecheck.flat_vs_board_cache/1";
  nlohmann::json screen = nlohmann::json::array();
  for (const PhotoObservations& p : c.screen) {
    screen.push_back({{"photo", p.photo}, {"ids", p.ids}, {"display_px", Points(p.display_px)},
                      {"detected_px", Points(p.detected_px)}});
  }
  j["screen"] = screen;
  j["board"] = {{"corners_x", c.board.corners_x}, {"corners_y", c.board.corners_y},
                {"square_mm", c.board.square_mm}, {"source", c.board.source}};
  nlohmann::json views = nlohmann::json::array();
  for (size_t v = 0; v < c.detections.size(); ++v) {
    const ChessboardDetection& d = c.detections[v];
    views.push_back({{"photo", d.photo.string()}, {"width", d.width}, {"height", d.height}, {"found", d.found},
                     {"detector", d.detector}, {"problem", d.problem}, {"corners_px", Points(d.corners_px)},
                     {"true_px", Points(c.board_true_px[v])}});
  }
  j["views"] = views;
  std::filesystem::create_directories(path.parent_path());
  WriteFileAtomic(path, j.dump());
}

ObservationCache ReadCache(const std::filesystem::path& path) {
  const nlohmann::json j = nlohmann::json::parse(ReadFileToString(path));
  if (j.value("format", "") != "curvecheck.flat_vs_board_cache/1") {
    throw Error(path.string(), "not a flat-vs-board observation cache", "delete it");
  }
  ObservationCache c;
  for (const nlohmann::json& p : j["screen"]) {
    PhotoObservations o;
    o.photo = p["photo"].get<std::string>();
    o.ids = p["ids"].get<std::vector<std::string>>();
    o.display_px = PointsFrom(p["display_px"]);
    o.detected_px = PointsFrom(p["detected_px"]);
    c.screen.push_back(std::move(o));
  }
  c.board.corners_x = j["board"]["corners_x"].get<int>();
  c.board.corners_y = j["board"]["corners_y"].get<int>();
  c.board.square_mm = j["board"]["square_mm"].get<double>();
  c.board.source = j["board"]["source"].get<std::string>();
  for (const nlohmann::json& v : j["views"]) {
    ChessboardDetection d;
    d.photo = v["photo"].get<std::string>();
    d.width = v["width"].get<int>();
    d.height = v["height"].get<int>();
    d.found = v["found"].get<bool>();
    d.detector = v["detector"].get<std::string>();
    d.problem = v["problem"].get<std::string>();
    d.corners_px = PointsFrom(v["corners_px"]);
    c.detections.push_back(std::move(d));
    c.board_true_px.push_back(PointsFrom(v["true_px"]));
  }
  return c;
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

FlatVsBoardTrial RunFlatVsBoardTrial(const BenchFlatVsBoardOptions& o, uint64_t seed,
                                     const std::filesystem::path& cache_dir) {
  o.Check();
  const Stopwatch watch;
  FlatVsBoardTrial t;
  SyntheticScene scene = FindScene(o.scene, "--scene");
  scene.camera = ScaledCamera(scene.camera, o.scale);
  scene.imaging.lens_seed = seed;
  scene.monitor = LoadMonitor(o.monitor);
  if (!scene.monitor.is_flat()) throw Error("--monitor", o.monitor + " is not flat", "give a flat monitor preset");
  scene.truth = TrueMonitor{};
  // The true image of every detected feature: the true surface point through the model and its misfit field,
  // at each photo's pose.
  const TrueImages true_images(scene);
  const LensMisfit& misfit = true_images.misfit();
  t.true_misfit_px = misfit.rms_px();
  const Eigen::Vector3d centre = ScreenCentreInScreen(scene.monitor);
  const std::filesystem::path cache_file =
      cache_dir.empty() ? std::filesystem::path() : cache_dir / fmt::format("seed-{}.json", seed);
  std::optional<ObservationCache> cache;
  if (!cache_file.empty() && std::filesystem::exists(cache_file)) cache = ReadCache(cache_file);
  t.from_cache = cache.has_value();
  std::optional<Renderer> renderer;
  std::optional<PatternFile> pattern;
  Image8 display_image;
  if (!cache) {
    // The default pattern rendered for a viewpoint on the screen's normal (experiments/trial.h RenderTrialDisplay's
    // steps, here without the analysis it links: on a flat monitor the drawing does not depend on the viewpoint).
    renderer.emplace();
    const Eigen::Vector3d viewpoint = centre + Eigen::Vector3d(0, 0, 0.5 * (o.z_min_mm + o.z_max_mm));
    const RenderOptions render;
    const Pattern drawn = BuildPattern(PatternSpec{}, scene.monitor, viewpoint, TangentPlaneAtCentre(scene.monitor));
    GrayImage gray = renderer->Render(scene.monitor, viewpoint, drawn, render);
    display_image = Image8{gray.width, gray.height, 1, std::move(gray.pixels)};
    pattern = ParsePatternJson(PatternToJson(drawn, scene.monitor, viewpoint, render.method.ToJson()).dump(),
                               "the bench's pattern.json");
  }
  std::mt19937_64 rng(seed * 7919 + 17);
  std::uniform_int_distribution<int> count(o.min_photos, o.max_photos);
  std::uniform_real_distribution<double> ur(-1, 1);
  std::normal_distribution<double> unit(0, 1), aim(0, M_PI / 180);
  const double w_mm = scene.monitor.width_mm, h_mm = scene.monitor.height_mm;
  std::vector<PhotoObservations> obs;
  std::vector<Eigen::Vector2d> screen_px, board_px, screen_err, board_err, board_err_at;
  std::vector<int> screen_photo, board_photo;
  ObservationCache fresh;
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
                     AngleAxisFromVector(a).toRotationMatrix(),
                 position);
        if (ScreenInside(scene, 0.02)) break;
      }
      PhotoObservations p;
      if (cache) {
        if (static_cast<size_t>(i) >= cache->screen.size()) throw Error(cache_file.string(), "too few photos", "delete it");
        p = cache->screen[static_cast<size_t>(i)];
      } else {
        scene.sensor.seed = seed * 1000 + static_cast<uint64_t>(i);
        const SyntheticPhoto photo = RenderSyntheticPhoto(scene, display_image);
        p = ObserveScreenImage(PhotoToMat(photo), fmt::format("flat{}", i), *pattern, DetectOptions{});
        fresh.screen.push_back(p);
      }
      for (size_t k = 0; k < p.detected_px.size(); ++k) {
        screen_err.push_back(p.detected_px[k] -
                             true_images.ImageOf(true_images.CameraPoint(p.display_px[k])));
        screen_photo.push_back(i);
      }
      screen_px.insert(screen_px.end(), p.detected_px.begin(), p.detected_px.end());
      obs.push_back(std::move(p));
    }
    FromScreenOptions fso;
    fso.focal_px = scene.camera.intrinsics[0] * (1 + 0.1 * unit(rng));
    const FromScreenResult fs = CalibrateFromScreen(obs, scene.monitor, scene.camera.width, scene.camera.height, fso);
    t.screen_lensmodel = fs.model.lensmodel;
    const Eigen::MatrixXd& screen_cov = fs.intrinsics_covariance;
    const Eigen::MatrixXd& screen_noise = fs.Chosen().fit.Chosen().intrinsics_covariance;
    t.screen_budget_note = fs.intrinsics_budget.computed ? "" : fs.intrinsics_budget.note;
    t.screen_unmodelled_px = std::sqrt(fs.intrinsics_budget.unmodelled_variance_px2);

    BoardSpec board;
    std::vector<ChessboardDetection> detections;
    if (cache) {
      board = cache->board;
      detections = cache->detections;
      for (size_t v = 0; v < detections.size(); ++v) {
        if (!detections[v].found) continue;
        for (size_t k = 0; k < detections[v].corners_px.size(); ++k) {
          board_err.push_back(detections[v].corners_px[k] - cache->board_true_px[v][k]);
          board_err_at.push_back(detections[v].corners_px[k]);
          board_photo.push_back(static_cast<int>(v));
        }
      }
    } else {
      SyntheticBoardOptions bo;
      bo.camera = scene.camera;
      bo.views = o.board_views;
      bo.imaging = scene.imaging;
      bo.seed = seed;
      // Squares of 48 display px at 0.5 mm (24 mm): the board (11 x 8 squares, 264 x 192 mm) fills 0.4-0.85 of the
      // image at 0.26-0.55 m for the default camera.
      bo.pixel_pitch_mm = 0.5;
      const SyntheticBoardSet set = MakeSyntheticBoardSet(bo);
      board = set.board;
      for (const SyntheticBoardView& v : set.views) {
        detections.push_back(DetectChessboard(v.photo, set.board, ChessboardOptions()));
        fresh.board_true_px.push_back(v.corners_px);
        if (!detections.back().found) continue;
        for (size_t k = 0; k < v.corners_px.size(); ++k) {
          board_err.push_back(detections.back().corners_px[k] - v.corners_px[k]);
          board_err_at.push_back(detections.back().corners_px[k]);
          board_photo.push_back(static_cast<int>(detections.size()) - 1);
        }
      }
      fresh.board = board;
      fresh.detections = detections;
      if (!cache_file.empty()) WriteCache(cache_file, fresh);
    }
    for (const ChessboardDetection& d : detections) {
      if (d.found) board_px.insert(board_px.end(), d.corners_px.begin(), d.corners_px.end());
    }
    t.screen_detection = DetectionErrorsOf(screen_px, screen_err, screen_photo, scene.camera.width, scene.camera.height);
    t.board_detection = DetectionErrorsOf(board_err_at, board_err, board_photo, scene.camera.width, scene.camera.height);
    CalibrateOptions co;
    co.lensmodels = {"LENSMODEL_OPENCV5"};
    co.cross_validate = false;
    co.seed = seed;
    const CalibrationResult b = Calibrate(detections, board, co);
    const CandidateResult& bc = b.Chosen();
    if (!bc.error.empty()) throw Error("board calibration", bc.error, "");
    t.board_lensmodel = b.model.lensmodel;

    const std::vector<Eigen::Vector2d> grid = ImagerGrid(scene.camera.width, scene.camera.height, kGridX, kGridY);
    const std::vector<bool> region =
        And(CoveredCells(screen_px, scene.camera.width, scene.camera.height, kGridX, kGridY),
            CoveredCells(board_px, scene.camera.width, scene.camera.height, kGridX, kGridY));
    t.cells = static_cast<int>(std::count(region.begin(), region.end(), true));
    LensWithCovariance s(fs.model, screen_cov);
    s.unmodelled = fs.intrinsics_budget.unmodelled;
    const LensWithCovariance s_noise(fs.model, screen_noise), bl_noise(b.model, bc.intrinsics_covariance);
    // The board's stated covariance: mrcal's (noise) plus its measured misfit's share (mrcal_solve.py misfit_field).
    LensWithCovariance bl(b.model, bc.intrinsics_covariance);
    if (bc.intrinsics_covariance_misfit.rows() == bc.intrinsics_covariance.rows()) {
      bl.covariance += bc.intrinsics_covariance_misfit;
      UncertaintyBudget::FieldComponent field;  // mrcal_solve.py misfit_field: one Gaussian field
      field.length_px = bc.misfit_length_px;
      field.variance_px2 = bc.misfit_variance_px2;
      bl.unmodelled = {field};
    }
    t.board_misfit_px = std::sqrt(std::max(0.0, bc.misfit_variance_px2));
    t.screen_summary = FromScreenSummary(fs);
    std::string board_rows = "board (mrcal, " + b.model.lensmodel + "): sigma of the intrinsics, noise:";
    for (long k = 0; k < bc.intrinsics_covariance.rows(); ++k) {
      board_rows += fmt::format(" {:.3g}", std::sqrt(std::max(0.0, bc.intrinsics_covariance(k, k))));
    }
    board_rows += "; misfit share:";
    for (long k = 0; k < bc.intrinsics_covariance_misfit.rows(); ++k) {
      board_rows += fmt::format(" {:.3g}", std::sqrt(std::max(0.0, bc.intrinsics_covariance_misfit(k, k))));
    }
    t.screen_summary += board_rows + fmt::format("; misfit RMS {:.4f} px at {:.0f} px{}\n", t.board_misfit_px,
                                                 bc.misfit_length_px,
                                                 bc.misfit_note.empty() ? "" : " (" + bc.misfit_note + ")");
    LensWithCovariance truth(scene.camera);
    truth.true_image_of = [&misfit](const Eigen::Vector2d& q) { return misfit.TrueImageOf(q); };
    truth.model_pixel_of = [&misfit](const Eigen::Vector2d& q) { return misfit.ModelPixelOf(q); };
    t.screen_vs_board = CompareProjections(bl, s, grid, region);
    t.screen_vs_truth = CompareProjections(truth, s, grid, region);
    t.board_vs_truth = CompareProjections(truth, bl, grid, region);
    t.screen_vs_board_noise = CompareProjections(bl_noise, s_noise, grid, region);
    t.board_vs_truth_noise = CompareProjections(truth, bl_noise, grid, region);
    t.screen_vs_truth_noise = CompareProjections(truth, s_noise, grid, region);
    t.threshold_mahalanobis = AgreementBound(t.screen_vs_board);
    t.agree = Agree(t.screen_vs_board);
    t.threshold_noise = AgreementBound(t.screen_vs_board_noise);
    t.agree_noise = Agree(t.screen_vs_board_noise);
    t.fx_screen = fs.model.intrinsics[0];
    t.fx_screen_sigma = screen_cov.rows() ? std::sqrt(screen_cov(0, 0)) : kNaN;
    t.fx_screen_sigma_noise = screen_noise.rows() ? std::sqrt(screen_noise(0, 0)) : kNaN;
    t.fx_board = b.model.intrinsics[0];
    t.fx_board_sigma = bl.covariance.rows() ? std::sqrt(bl.covariance(0, 0)) : kNaN;
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
      "{:.0f}-{:.0f} mm; {} board views; scene {} at scale {}; observations cached in {}\n",
      o.trials, o.monitor, o.min_photos, o.max_photos, o.max_x_mm, o.max_y_mm, o.z_min_mm, o.z_max_mm, o.board_views,
      o.scene, o.scale, (dir / "cache").string());
  log << "m max: the largest per-cell Mahalanobis distance over the cells both saw (limit: the Bonferroni bound); "
         "stated = the from-screen calibration's stated covariance (its budget), noise = its detection-noise row "
         "alone; scr-tru, brd-tru: each against the true lens (model + misfit field); det: detection error RMS / "
         "its smooth part's RMS, px\n";
  log << fmt::format("{:>5} {:>6} {:>7} {:>5} {:>14} {:>14} {:>7} {:>7} {:>12} {:>12} {:>12} {:>12} {:>11} {:>11} "
                     "{:>5}\n",
                     "trial", "photos", "screen", "cells", "fx screen", "fx board", "|d| med", "sig med",
                     "m max/limit", "noise m/lim", "scr-tru m", "brd-tru m", "det scr", "det brd", "s")
      << std::flush;
  std::string csv =
      "trial,seed,photos,screen_lensmodel,board_lensmodel,cells,fx_screen,fx_screen_sigma,fx_screen_sigma_noise,"
      "fx_board,fx_board_sigma,diff_median_px,diff_max_px,sigma_median_px,sigma_max_px,mahalanobis_median,"
      "mahalanobis_max,rank,threshold_mahalanobis,agree,noise_sigma_median_px,noise_mahalanobis_max,noise_rank,"
      "noise_threshold,noise_agree,screen_truth_median_px,screen_truth_max_px,screen_truth_sigma_median_px,"
      "screen_truth_mahalanobis_max,screen_truth_rank,screen_truth_worst_x,screen_truth_worst_y,"
      "screen_truth_noise_mahalanobis_max,screen_truth_noise_rank,board_truth_median_px,board_truth_max_px,"
      "board_truth_sigma_median_px,board_truth_mahalanobis_max,board_truth_rank,board_truth_worst_x,"
      "board_truth_worst_y,board_truth_noise_mahalanobis_max,board_truth_noise_rank,screen_vs_board_worst_x,"
      "screen_vs_board_worst_y,true_misfit_px,screen_unmodelled_px,board_misfit_px,"
      "screen_det_rms_px,screen_det_mean_x,screen_det_mean_y,screen_det_smooth_px,screen_det_photo_smooth_px,"
      "board_det_rms_px,board_det_mean_x,board_det_mean_y,board_det_smooth_px,board_det_photo_smooth_px,from_cache,"
      "seconds,budget_note,error\n";
  int n = 0, agree = 0, agree_noise = 0, failed = 0, st_in = 0, stn_in = 0, bt_in = 0, btn_in = 0;
  std::vector<double> m_max;
  const auto worst = [](const ProjectionComparison& c) {
    double best = -1;
    Eigen::Vector2d at(kNaN, kNaN);
    for (size_t i = 0; i < c.mahalanobis.size(); ++i) {
      if (c.in_region[i] && std::isfinite(c.mahalanobis[i]) && c.mahalanobis[i] > best) {
        best = c.mahalanobis[i];
        at = c.pixel_px[i];
      }
    }
    return at;
  };
  for (int k = 0; k < o.trials; ++k) {
    const uint64_t seed = o.seed + static_cast<uint64_t>(k);
    const FlatVsBoardTrial t = RunFlatVsBoardTrial(o, seed, dir / "cache");
    const ProjectionComparison &c = t.screen_vs_board, &st = t.screen_vs_truth, &bt = t.board_vs_truth,
                               &cn = t.screen_vs_board_noise, &stn = t.screen_vs_truth_noise;
    const Eigen::Vector2d ws = worst(st), wb = worst(bt), wc = worst(c);
    const DetectionErrors &ds = t.screen_detection, &db = t.board_detection;
    csv += fmt::format(
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},"
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.1f},\"{}\",\"{}\"\n",
        k, seed, t.photos, t.screen_lensmodel, t.board_lensmodel, t.cells, t.fx_screen, t.fx_screen_sigma,
        t.fx_screen_sigma_noise, t.fx_board, t.fx_board_sigma, c.median_px, c.max_px, c.median_sigma_px,
        c.max_sigma_px, c.median_mahalanobis, c.max_mahalanobis, c.rank, t.threshold_mahalanobis, t.agree ? 1 : 0,
        cn.median_sigma_px, cn.max_mahalanobis, cn.rank, t.threshold_noise, t.agree_noise ? 1 : 0, st.median_px,
        st.max_px, st.median_sigma_px, st.max_mahalanobis, st.rank, ws.x(), ws.y(), stn.max_mahalanobis, stn.rank,
        bt.median_px, bt.max_px, bt.median_sigma_px, bt.max_mahalanobis, bt.rank, wb.x(), wb.y(),
        t.board_vs_truth_noise.max_mahalanobis, t.board_vs_truth_noise.rank, wc.x(), wc.y(), t.true_misfit_px,
        t.screen_unmodelled_px, t.board_misfit_px, ds.rms_px, ds.mean_px.x(), ds.mean_px.y(), ds.smooth_rms_px,
        ds.per_photo_smooth_rms_px, db.rms_px, db.mean_px.x(), db.mean_px.y(), db.smooth_rms_px,
        db.per_photo_smooth_rms_px, t.from_cache ? 1 : 0, t.seconds,
        t.screen_budget_note, t.error);
    WriteFileAtomic(dir / fmt::format("trial-{}.txt", k), t.screen_summary + t.error + "\n");
    if (!t.error.empty()) {
      ++failed;
      log << fmt::format("{:>5} {:>6} refused or failed: {}\n", k, t.photos, t.error) << std::flush;
      continue;
    }
    ++n;
    agree += t.agree ? 1 : 0;
    agree_noise += t.agree_noise ? 1 : 0;
    st_in += st.max_mahalanobis <= AgreementBound(st) ? 1 : 0;
    stn_in += stn.max_mahalanobis <= AgreementBound(stn) ? 1 : 0;
    bt_in += bt.max_mahalanobis <= AgreementBound(bt) ? 1 : 0;
    btn_in += t.board_vs_truth_noise.max_mahalanobis <= AgreementBound(t.board_vs_truth_noise) ? 1 : 0;
    m_max.push_back(c.max_mahalanobis);
    log << fmt::format(
               "{:>5} {:>6} {:>7} {:>5} {:>8.2f}+-{:<5.2f} {:>8.2f}+-{:<5.2f} {:>7.3f} {:>7.3f} {:>5.2f}/{:<4.2f}{:>2} "
               "{:>5.2f}/{:<4.2f}{:>2} {:>5.2f}/{:<5.2f} {:>5.2f}/{:<5.2f} {:>5.3f}/{:<5.3f} {:>5.3f}/{:<5.3f} "
               "{:>5.0f}{}\n",
               k, t.photos, t.screen_lensmodel.substr(10), t.cells, t.fx_screen, t.fx_screen_sigma, t.fx_board,
               t.fx_board_sigma, c.median_px, c.median_sigma_px, c.max_mahalanobis, t.threshold_mahalanobis,
               t.agree ? "" : " X", cn.max_mahalanobis, t.threshold_noise, t.agree_noise ? "" : " X",
               st.max_mahalanobis, AgreementBound(st), bt.max_mahalanobis, AgreementBound(bt), ds.rms_px,
               ds.smooth_rms_px, db.rms_px, db.smooth_rms_px, t.seconds,
               t.screen_budget_note.empty() ? "" : " (budget: " + t.screen_budget_note + ")")
        << std::flush;
  }
  WriteFileAtomic(dir / "flat_vs_board_trials.csv", csv);
  const BinomialInterval w = WilsonInterval(agree, n), wn = WilsonInterval(agree_noise, n);
  const BinomialInterval ws = WilsonInterval(st_in, n), wsn = WilsonInterval(stn_in, n), wb = WilsonInterval(bt_in, n),
                         wbn = WilsonInterval(btn_in, n);
  log << fmt::format(
      "summary: {} trials ({} refused or failed); the flat-monitor and board calibrations agreed (largest per-cell "
      "Mahalanobis distance within the Bonferroni bound over the combined covariance's rank, 95% family-wise) in {} "
      "of {} = {:.1f}% (Wilson 95% interval {:.1f}-{:.1f}%; honest uncertainties give >= 95%) with the from-screen "
      "calibration's and the board's stated covariances, {} of {} (Wilson {:.1f}-{:.1f}%) with both detection-noise "
      "covariances alone (as before the budgets); median "
      "of the largest Mahalanobis distance {:.2f}\n",
      o.trials, failed, agree, n, n ? 100.0 * agree / n : kNaN, 100 * w.lo, 100 * w.hi, agree_noise, n,
      100 * wn.lo, 100 * wn.hi, m_max.empty() ? kNaN : Median(m_max));
  log << fmt::format(
      "against the true lens (model + misfit field), by the same rule: the from-screen calibration within its stated "
      "uncertainty in {} of {} (Wilson {:.1f}-{:.1f}%), within its noise row alone in {} of {} (Wilson "
      "{:.1f}-{:.1f}%); the board calibration within its stated uncertainty (mrcal's plus its measured misfit) in "
      "{} of {} (Wilson {:.1f}-{:.1f}%), within mrcal's alone in {} of {} (Wilson {:.1f}-{:.1f}%)\n",
      st_in, n, 100 * ws.lo, 100 * ws.hi, stn_in, n, 100 * wsn.lo, 100 * wsn.hi, bt_in, n, 100 * wb.lo,
      100 * wb.hi, btn_in, n, 100 * wbn.lo, 100 * wbn.hi);
  log << fmt::format("wrote {}\n", (dir / "flat_vs_board_trials.csv").string());
}

}  // namespace curvecheck::experiments
