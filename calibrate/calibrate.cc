#include "calibrate/calibrate.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>

#include "calibrate/mrcal_solve_script.h"
#include "core/camera_model.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/stats.h"
#include "core/stopwatch.h"
#include "core/subprocess.h"

namespace curvecheck {
namespace {
namespace fs = std::filesystem;

double Num(const nlohmann::json& j) {
  return j.is_number() ? j.get<double>() : std::numeric_limits<double>::quiet_NaN();
}

// The median of the finite values (core/stats.h); NaN when there is none (no uncertainty to report).
double FiniteMedian(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  return v.empty() ? std::numeric_limits<double>::quiet_NaN() : Median(std::move(v));
}

// Focal length seed (px) from OpenCV: the closed-form estimate from the boards' homographies.
double FocalSeedPx(const std::vector<const ChessboardDetection*>& used, const BoardSpec& board, int width, int height) {
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
  std::vector<cv::Point3f> corners;
  for (const Eigen::Vector3d& p : board.CornersInBoard()) corners.emplace_back(float(p.x()), float(p.y()), 0.f);
  for (const ChessboardDetection* d : used) {
    object.push_back(corners);
    std::vector<cv::Point2f> q;
    for (const Eigen::Vector2d& c : d->corners_px) q.emplace_back(float(c.x()), float(c.y()));
    image.push_back(std::move(q));
  }
  const cv::Mat k = cv::initCameraMatrix2D(object, image, cv::Size(width, height), 1.0);
  const double f = k.at<double>(0, 0);
  // The estimate assumes no distortion; guard against nonsense with a 60 deg horizontal field of view.
  return (std::isfinite(f) && f > 0.05 * width && f < 50.0 * width) ? f : 0.5 * width / std::tan(M_PI / 6);
}

CandidateResult ParseCandidate(const nlohmann::json& c) {
  CandidateResult r;
  r.lensmodel = c.at("lensmodel").get<std::string>();
  if (c.contains("error")) {
    r.error = c.at("error").get<std::string>();
    return r;
  }
  r.nparams = c.at("nparams").get<int>();
  r.rms_px = Num(c.at("rms_px"));
  r.worst_px = Num(c.at("worst_px"));
  r.ninliers = c.at("ninliers").get<int>();
  r.noutliers = c.at("noutliers").get<int>();
  r.solve_s = Num(c.at("solve_s"));
  const auto& s = c.at("structure");
  r.structure_z = Num(s.at("z"));
  r.structure_chi2_per_dof = Num(s.at("chi2_per_dof"));
  r.structure_cells = s.at("cells").get<int>();
  if (c.contains("crossval")) {
    const auto& v = c.at("crossval");
    r.crossval_done = true;
    r.crossval_rms_diff_px = Num(v.at("rms_diff_px"));
    r.crossval_rms_expected_px = Num(v.at("rms_expected_px"));
    r.crossval_ratio_median = Num(v.at("ratio_median"));
    r.crossval_ratio_p90 = Num(v.at("ratio_p90"));
    r.crossval_s = Num(v.at("solve_s"));
  }
  for (const auto& x : c.at("intrinsics")) r.intrinsics.push_back(Num(x));
  for (const auto& rt : c.at("cam_from_board_rt")) {
    Eigen::Matrix<double, 6, 1> v;
    for (int i = 0; i < 6; ++i) v(i) = Num(rt[static_cast<size_t>(i)]);
    r.cam_from_board_rt.push_back(v);
  }
  const auto& u = c.at("uncertainty");
  for (const auto& q : u.at("grid_px")) r.uncertainty.pixel_px.emplace_back(Num(q[0]), Num(q[1]));
  for (const auto& x : u.at("sigma_px")) r.uncertainty.sigma_px.push_back(Num(x));
  for (const auto& x : u.at("observed")) r.uncertainty.observed.push_back(x.get<bool>());
  for (const auto& x : c.at("per_photo_rms_px")) r.per_photo_rms_px.push_back(Num(x));
  for (const auto& photo : c.at("residuals_px")) {
    std::vector<Eigen::Vector2d> v;
    for (const auto& q : photo) v.emplace_back(Num(q[0]), Num(q[1]));
    r.residuals_px.push_back(std::move(v));
  }
  for (const auto& photo : c.at("inlier")) {
    std::vector<bool> v;
    for (const auto& x : photo) v.push_back(x.get<bool>());
    r.inlier.push_back(std::move(v));
  }
  r.model_text = ReadFileToString(c.at("model_path").get<std::string>());
  if (c.contains("intrinsics_covariance")) {
    const auto& ic = c.at("intrinsics_covariance");
    const auto& rows = ic.at("covariance");
    const long n = static_cast<long>(rows.size());
    r.intrinsics_covariance.resize(n, n);
    for (long i = 0; i < n; ++i) {
      for (long k = 0; k < n; ++k) r.intrinsics_covariance(i, k) = Num(rows[static_cast<size_t>(i)][static_cast<size_t>(k)]);
    }
    r.intrinsics_covariance_dof = Num(ic.at("dof"));
    r.observed_pixel_uncertainty_px = Num(ic.at("observed_pixel_uncertainty_px"));
  }
  if (c.contains("misfit")) {
    const auto& mf = c.at("misfit");
    if (mf.contains("error")) {
      r.misfit_note = mf.at("error").get<std::string>();
    } else {
      r.misfit_variance_px2 = Num(mf.at("variance_px2"));
      r.misfit_length_px = Num(mf.at("length_px"));
      const auto& rows = mf.at("covariance");
      const long n = static_cast<long>(rows.size());
      r.intrinsics_covariance_misfit.resize(n, n);
      for (long i = 0; i < n; ++i) {
        for (long k = 0; k < n; ++k) {
          r.intrinsics_covariance_misfit(i, k) = Num(rows[static_cast<size_t>(i)][static_cast<size_t>(k)]);
        }
      }
    }
  }
  return r;
}

}  // namespace

nlohmann::json IntrinsicsCovarianceJson(const CandidateResult& c, const std::string& model_file) {
  if (c.intrinsics_covariance.size() == 0 || !c.intrinsics_covariance.allFinite()) {
    throw Error(model_file, "the calibration has no intrinsics covariance (mrcal could not factor J^T J)",
                "recalibrate with more photos covering the imager");
  }
  nlohmann::json cov = nlohmann::json::array();
  for (long i = 0; i < c.intrinsics_covariance.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (long k = 0; k < c.intrinsics_covariance.cols(); ++k) row.push_back(c.intrinsics_covariance(i, k));
    cov.push_back(row);
  }
  nlohmann::json out = {{"format", "curvecheck.intrinsics_covariance/1"},
          {"model", model_file},
          {"lensmodel", c.lensmodel},
          {"intrinsics", c.intrinsics},
          {"covariance", cov},
          {"dof", c.intrinsics_covariance_dof},
          {"observed_pixel_uncertainty_px", c.observed_pixel_uncertainty_px},
          {"method", "mrcal: s^2 (J^T J)^-1 [J_obs^T J_obs] (J^T J)^-1 in the packed state, intrinsics block, "
                     "unpacked (D Var D), marginal over the board poses; s = std of the board residuals"}};
  // The lens model misfit the calibration measured: curvecheck analyze takes it for its lens-model-misfit row
  // unless the residuals show significantly more (FitOptions::stated_lens_misfit_px).
  if (c.misfit_note.empty() && c.misfit_length_px > 0 && std::isfinite(c.misfit_variance_px2)) {
    out["misfit"] = {{"rms_px", std::sqrt(std::max(0.0, c.misfit_variance_px2))},
                     {"length_px", c.misfit_length_px},
                     {"method", "a stationary Gaussian field common to every photo, from the residuals' correlation "
                                "between photos (mrcal_solve.py misfit_field)"}};
  }
  return out;
}

const std::string& MrcalSolveScript() {
  static const std::string kScript(kMrcalSolveScript);
  return kScript;
}

void CalibrateOptions::Check() const {
  // Checked with mrcal's own parser before any photo is read, not when the solver first meets the name.
  // "fov_x_deg=auto" is ours (the field of view from the stereographic seed): parsed with a number in its place.
  for (const std::string& m : lensmodels) {
    std::string parsable = m;
    if (const size_t at = parsable.rfind("fov_x_deg=auto"); at != std::string::npos && at + 14 == parsable.size()) {
      parsable.replace(at + 10, 4, "100");
    }
    if (!IsMrcalLensModel(parsable)) {
      throw Error("--lensmodel", fmt::format("'{}' is not a mrcal lens model name", m),
                  "use auto or e.g. LENSMODEL_OPENCV8 (the lens models are listed in mrcal's documentation, "
                  "'Lens models')");
    }
  }
  if (splined_nx < 4 || splined_nx > 60) {
    throw Error("--splined-nx", fmt::format("{} knots is outside 4..60", splined_nx), "use e.g. 16");
  }
  if (!(focal_px >= 0) || !std::isfinite(focal_px)) {
    throw Error("--focal-px", fmt::format("{} is not a focal length", focal_px), "give px, or 0 to estimate it");
  }
  if (min_photos_per_half < 3) throw Error("min_photos_per_half", "must be at least 3", "");
  if (!(structure_z_max > 0) || !(crossval_ratio_max > 0)) {
    throw Error("CalibrateOptions", "thresholds must be positive", "");
  }
  if (!(distance_mm >= 0) || !std::isfinite(distance_mm)) {
    throw Error("--distance-mm", fmt::format("{} is not a distance", distance_mm), "give mm, or 0 for infinity");
  }
  if (grid_x < 2 || grid_y < 2 || structure_x < 1 || structure_y < 1) {
    throw Error("CalibrateOptions", "evaluation grids need at least 2x2 cells", "");
  }
}

double CandidateResult::SigmaCentralMedian(int width, int height) const {
  std::vector<double> v;
  for (size_t i = 0; i < uncertainty.pixel_px.size(); ++i) {
    const Eigen::Vector2d& q = uncertainty.pixel_px[i];
    if (std::abs(q.x() - 0.5 * (width - 1)) <= 0.25 * width && std::abs(q.y() - 0.5 * (height - 1)) <= 0.25 * height) {
      v.push_back(uncertainty.sigma_px[i]);
    }
  }
  return FiniteMedian(v);
}

double CandidateResult::SigmaObservedMedian() const {
  std::vector<double> v;
  for (size_t i = 0; i < uncertainty.sigma_px.size(); ++i) {
    if (uncertainty.observed[i]) v.push_back(uncertainty.sigma_px[i]);
  }
  return FiniteMedian(v);
}

double CandidateResult::SigmaObservedMax() const {
  double m = 0;
  for (size_t i = 0; i < uncertainty.sigma_px.size(); ++i) {
    if (uncertainty.observed[i]) m = std::max(m, uncertainty.sigma_px[i]);
  }
  return m;
}

CalibrationResult Calibrate(const std::vector<ChessboardDetection>& detections, const BoardSpec& board,
                            const CalibrateOptions& options) {
  CalibrationPhotos photos;
  photos.detections = detections;
  return Calibrate(photos, board, options);
}

CalibrationResult Calibrate(const CalibrationPhotos& photos, const BoardSpec& board, const CalibrateOptions& options) {
  options.Check();
  board.Check(board.source);
  const std::vector<ChessboardDetection>& detections = photos.detections;
  const bool gathered = !photos.duplicate_of.empty();
  if (gathered && (photos.duplicate_of.size() != detections.size() || photos.content.size() != detections.size())) {
    throw Error("Calibrate", "CalibrationPhotos' vectors differ in length", "internal: use DetectCalibrationPhotos");
  }
  CalibrationResult r;
  r.board = board;
  r.detections = detections;
  r.content = photos.content;
  r.duplicate_of = photos.duplicate_of;
  r.notes = photos.DuplicateNotes();
  int duplicates = 0;
  std::vector<const ChessboardDetection*> used;
  for (size_t i = 0; i < detections.size(); ++i) {
    const ChessboardDetection& d = detections[i];
    if (gathered && photos.duplicate_of[i] >= 0) {  // its content is already counted (its first photo)
      ++duplicates;
      continue;
    }
    if (!d.found) continue;
    if (d.corners_px.size() != static_cast<size_t>(board.corner_count())) {
      throw Error(d.photo.string(), "detection does not match the board", "internal: detect with the same board");
    }
    if (used.empty()) {
      r.width = d.width;
      r.height = d.height;
    } else if (d.width != r.width || d.height != r.height) {
      throw Error(d.photo.string(), fmt::format("is {}x{} px but {} is {}x{}", d.width, d.height,
                                                used.front()->photo.string(), r.width, r.height),
                  "calibrate one camera at one resolution at a time");
    }
    used.push_back(&d);
    r.used.push_back(static_cast<int>(i));
  }
  if (used.size() < 3) {
    throw Error("photos", fmt::format("only {} of {} photos show the whole {}x{} board{}", used.size(),
                                      detections.size(), board.corners_x, board.corners_y,
                                      duplicates > 0 ? fmt::format(" ({} duplicate(s) counted once)", duplicates)
                                                     : std::string()),
                "take 20-40 photos with the whole board in view: close-ups that fill the corners, tilts up to 45 deg");
  }
  r.focal_seed_px = options.focal_px > 0 ? options.focal_px : FocalSeedPx(used, board, r.width, r.height);

  std::vector<std::string> models = options.lensmodels;
  if (models.empty()) {
    const int ny = std::max(4, static_cast<int>(std::lround(options.splined_nx * double(r.height) / r.width)));
    models = {"LENSMODEL_OPENCV4", "LENSMODEL_OPENCV8",
              fmt::format("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx={}_Ny={}_fov_x_deg=auto", options.splined_nx, ny)};
  }
  nlohmann::json in;
  in["imagersize"] = {r.width, r.height};
  in["board"] = {board.corners_x, board.corners_y};
  in["spacing_mm"] = board.square_mm;
  in["focal_px"] = r.focal_seed_px;
  in["lensmodels"] = models;
  in["grid"] = {options.grid_x, options.grid_y};
  in["structure_grid"] = {options.structure_x, options.structure_y};
  in["distance_mm"] = options.distance_mm > 0 ? nlohmann::json(options.distance_mm) : nlohmann::json(nullptr);
  in["seed"] = options.seed;
  nlohmann::json obs = nlohmann::json::array();
  for (const ChessboardDetection* d : used) {
    nlohmann::json photo = nlohmann::json::array();
    for (const Eigen::Vector2d& q : d->corners_px) photo.push_back({q.x(), q.y(), 1.0});
    obs.push_back(std::move(photo));
  }
  in["observations"] = std::move(obs);
  const int half = static_cast<int>(used.size()) / 2;
  if (options.cross_validate && half >= options.min_photos_per_half) {
    nlohmann::json a = nlohmann::json::array(), b = nlohmann::json::array();
    for (size_t i = 0; i < used.size(); ++i) (i % 2 == 0 ? a : b).push_back(i);
    in["halves"] = {a, b};
  } else {
    in["halves"] = nullptr;
  }

  const TempFolder tmp("curvecheck-calibrate", "the mrcal solver");
  in["out_dir"] = tmp.path().string();
  WriteFileAtomic(tmp.path() / "in.json", in.dump());
  WriteFileAtomic(tmp.path() / "mrcal_solve.py", MrcalSolveScript());
  const Stopwatch watch;
  const ProcessResult run = RunProcess({options.python, (tmp.path() / "mrcal_solve.py").string(),
                                        (tmp.path() / "in.json").string(), (tmp.path() / "out.json").string()});
  r.optimize_s = watch.Seconds();
  std::error_code ec;
  if (run.status != 0 || !fs::exists(tmp.path() / "out.json", ec)) {
    throw Error(options.python, fmt::format("the mrcal solver failed (exit status {}): {}", run.status,
                                            run.LastLine()),
                "install python3-mrcal (scripts/debian-packages.txt) and check that /usr/bin/python3 imports mrcal");
  }
  const nlohmann::json out = nlohmann::json::parse(ReadFileToString(tmp.path() / "out.json"));
  for (const auto& c : out.at("candidates")) {
    CandidateResult cr = ParseCandidate(c);
    cr.no_structure = cr.error.empty() && cr.structure_z <= options.structure_z_max;
    cr.crossval_pass = cr.crossval_done && cr.crossval_ratio_median <= options.crossval_ratio_max;
    r.candidates.push_back(std::move(cr));
  }
  // The simplest adequate candidate, in the given order (simplest first).
  for (size_t i = 0; i < r.candidates.size() && r.chosen < 0; ++i) {
    if (r.candidates[i].adequate()) {
      r.chosen = static_cast<int>(i);
      r.choice = r.candidates.size() == 1
                     ? "the only model tried; its residuals show no structure" +
                           std::string(r.candidates[i].crossval_done ? " and it cross-validates" : "")
                     : "the simplest model whose residuals show no structure" +
                           std::string(r.candidates[i].crossval_done ? " and whose cross-validation passes" : "");
    }
  }
  if (r.chosen < 0) {
    double best = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < r.candidates.size(); ++i) {
      const CandidateResult& c = r.candidates[i];
      if (!c.error.empty()) continue;
      const double score = c.crossval_done ? c.crossval_ratio_median : c.structure_z;
      if (r.chosen < 0 || score < best) {
        best = score;
        r.chosen = static_cast<int>(i);
      }
    }
    if (r.chosen < 0) {
      throw Error("calibrate", fmt::format("every lens model failed to solve; first: {}", r.candidates[0].error),
                  "check the photos (mrcal-show-residuals) and the board size");
    }
    r.choice = "NO candidate is adequate (structured residuals or failed cross-validation); chose the best "
               "cross-validation; take more photos covering the whole imager, or try another lens model";
  }
  r.model = ParseCameraModel(r.Chosen().model_text, "mrcal solver output");
  return r;
}

std::string CandidateTable(const CalibrationResult& r) {
  std::string s = fmt::format("{:<66} {:>6} {:>8} {:>9} {:>9} {:>10} {:>10} {:>11} {:>7}\n", "lens model", "params",
                              "rms px", "outliers", "struct z", "cv diff px", "cv expect", "cv ratio md", "verdict");
  for (size_t i = 0; i < r.candidates.size(); ++i) {
    const CandidateResult& c = r.candidates[i];
    if (!c.error.empty()) {
      s += fmt::format("{:<66} failed: {}\n", c.lensmodel, c.error);
      continue;
    }
    const std::string verdict = (static_cast<int>(i) == r.chosen ? "CHOSEN" : c.adequate() ? "ok" : "-");
    if (c.crossval_done) {
      s += fmt::format("{:<66} {:>6} {:>8.4f} {:>9} {:>9.2f} {:>10.4f} {:>10.4f} {:>11.2f} {:>7}\n", c.lensmodel,
                       c.nparams, c.rms_px, c.noutliers, c.structure_z, c.crossval_rms_diff_px,
                       c.crossval_rms_expected_px, c.crossval_ratio_median, verdict);
    } else {
      s += fmt::format("{:<66} {:>6} {:>8.4f} {:>9} {:>9.2f} {:>10} {:>10} {:>11} {:>7}\n", c.lensmodel, c.nparams,
                       c.rms_px, c.noutliers, c.structure_z, "-", "-", "-", verdict);
    }
  }
  s += fmt::format("chosen: {} ({})\n", r.Chosen().lensmodel, r.choice);
  return s;
}

nlohmann::json CalibrationJson(const CalibrationResult& r) {
  using nlohmann::json;
  auto finite = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };
  json j;
  j["format"] = "curvecheck.calibration/1";
  j["board"] = {{"corners", {r.board.corners_x, r.board.corners_y}}, {"square_mm", r.board.square_mm},
                {"source", r.board.source}};
  j["imager_px"] = {r.width, r.height};
  j["focal_seed_px"] = r.focal_seed_px;
  j["optimize_s"] = r.optimize_s;
  json photos = json::array();
  for (size_t i = 0; i < r.detections.size(); ++i) {
    const ChessboardDetection& d = r.detections[i];
    json p = {{"photo", d.photo.string()}, {"found", d.found}, {"detect_ms", d.ms}};
    if (d.found) p["detector"] = d.detector;
    if (!d.problem.empty()) p["problem"] = d.problem;
    if (i < r.content.size() && r.content[i]) {
      p["content"] = {{"hash", r.content[i]->Hex()}, {"width", r.content[i]->width},
                      {"height", r.content[i]->height}};
    }
    if (i < r.duplicate_of.size() && r.duplicate_of[i] >= 0) {
      p["duplicate_of"] = r.detections[static_cast<size_t>(r.duplicate_of[i])].photo.string();
    }
    p["used"] = std::find(r.used.begin(), r.used.end(), static_cast<int>(i)) != r.used.end();
    photos.push_back(std::move(p));
  }
  j["notes"] = r.notes;
  const CandidateResult& ch = r.Chosen();
  for (size_t k = 0; k < r.used.size(); ++k) {
    json& p = photos[static_cast<size_t>(r.used[k])];
    p["rms_px"] = finite(ch.per_photo_rms_px[k]);
    json corners = json::array();
    for (size_t i = 0; i < ch.residuals_px[k].size(); ++i) {
      const Eigen::Vector2d& q = r.detections[static_cast<size_t>(r.used[k])].corners_px[i];
      corners.push_back({{"corner", i}, {"detected_px", {q.x(), q.y()}},
                         {"residual_px", {finite(ch.residuals_px[k][i].x()), finite(ch.residuals_px[k][i].y())}},
                         {"outlier", !ch.inlier[k][i]}});
    }
    p["corners"] = std::move(corners);
  }
  j["photos"] = std::move(photos);
  json cands = json::array();
  for (size_t i = 0; i < r.candidates.size(); ++i) {
    const CandidateResult& c = r.candidates[i];
    json e = {{"lensmodel", c.lensmodel}, {"chosen", static_cast<int>(i) == r.chosen}};
    if (!c.error.empty()) {
      e["error"] = c.error;
    } else {
      e.update({{"nparams", c.nparams}, {"rms_px", finite(c.rms_px)}, {"worst_px", finite(c.worst_px)},
                {"inliers", c.ninliers}, {"outliers", c.noutliers}, {"solve_s", c.solve_s},
                {"structure", {{"z", finite(c.structure_z)}, {"chi2_per_dof", finite(c.structure_chi2_per_dof)},
                               {"cells", c.structure_cells}, {"pass", c.no_structure}}},
                {"intrinsics", c.intrinsics},
                {"sigma_central_median_px", finite(c.SigmaCentralMedian(r.width, r.height))},
                {"sigma_observed_median_px", finite(c.SigmaObservedMedian())},
                {"sigma_observed_max_px", finite(c.SigmaObservedMax())}, {"adequate", c.adequate()}});
      json misfit_sigma = json::array();
      for (long k = 0; k < c.intrinsics_covariance_misfit.rows(); ++k) {
        misfit_sigma.push_back(finite(std::sqrt(std::max(0.0, c.intrinsics_covariance_misfit(k, k)))));
      }
      e["misfit"] = {{"rms_px", finite(std::sqrt(std::max(0.0, c.misfit_variance_px2)))},
                     {"length_px", finite(c.misfit_length_px)},
                     {"intrinsics_sigma", misfit_sigma},
                     {"note", c.misfit_note},
                     {"what", "a smooth field common to every photo measured from the residuals' correlation between "
                              "photos (mrcal_solve.py misfit_field), and its share of the intrinsics' uncertainty; "
                              "not in the intrinsics covariance sidecar (mrcal's noise-only covariance)"}};
      if (c.crossval_done) {
        e["crossval"] = {{"rms_diff_px", finite(c.crossval_rms_diff_px)},
                         {"rms_expected_px", finite(c.crossval_rms_expected_px)},
                         {"ratio_median", finite(c.crossval_ratio_median)},
                         {"ratio_p90", finite(c.crossval_ratio_p90)}, {"pass", c.crossval_pass},
                         {"solve_s", c.crossval_s}};
      }
    }
    cands.push_back(std::move(e));
  }
  j["candidates"] = std::move(cands);
  j["chosen"] = {{"lensmodel", ch.lensmodel}, {"why", r.choice}};
  json grid = json::array();
  for (size_t i = 0; i < ch.uncertainty.pixel_px.size(); ++i) {
    grid.push_back({{"pixel_px", {ch.uncertainty.pixel_px[i].x(), ch.uncertainty.pixel_px[i].y()}},
                    {"sigma_px", finite(ch.uncertainty.sigma_px[i])}, {"observed", ch.uncertainty.observed[i]}});
  }
  j["uncertainty"] = {{"what", "worst-direction standard deviation of projection (mrcal), px"},
                      {"grid", std::move(grid)}};
  return j;
}

}  // namespace curvecheck
