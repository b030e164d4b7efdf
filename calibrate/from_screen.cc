#include "calibrate/from_screen.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "analysis/screen_model.h"
#include "calibrate/projection_compare.h"
#include "core/screen_geometry.h"
#include "core/error.h"
#include "core/math_util.h"
#include "core/monitor_json.h"
#include "core/stats.h"

namespace curvecheck {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// mrcal's names of the intrinsics of the OPENCV models (core, then distortions); "p<i>" beyond.
std::vector<std::string> IntrinsicNames(int n) {
  static const std::vector<std::string> kNames = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2",
                                                  "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4"};
  std::vector<std::string> out;
  for (int i = 0; i < n; ++i) {
    out.push_back(i < static_cast<int>(kNames.size()) ? kNames[static_cast<size_t>(i)] : fmt::format("p{}", i));
  }
  return out;
}

CameraModel SeedCamera(const std::string& lensmodel, int width, int height, double focal_px) {
  CameraModel c;
  c.lensmodel = lensmodel;
  c.width = width;
  c.height = height;
  c.intrinsics.assign(static_cast<size_t>(LensModelParameterCount(lensmodel)), 0.0);
  c.intrinsics[0] = c.intrinsics[1] = focal_px;
  c.intrinsics[2] = 0.5 * (width - 1);
  c.intrinsics[3] = 0.5 * (height - 1);
  c.Check("the seeded camera model");
  return c;
}

std::string PhotoList(const std::vector<PhotoObservations>& photos) {
  std::string s;
  for (size_t i = 0; i < photos.size() && i < 3; ++i) s += (i ? ", " : "") + photos[i].photo;
  if (photos.size() > 3) s += fmt::format(" and {} more", photos.size() - 3);
  return s.empty() ? "the photos" : s;
}

// Largest angle between two cameras' directions from the screen centre (centre frame), and the distance range.
void ViewGeometry(const ModelFit& fit, FromScreenObservability* o) {
  o->view_spread_deg = 0;
  o->distance_min_mm = kInf;
  o->distance_max_mm = 0;
  for (size_t a = 0; a < fit.cameras.size(); ++a) {
    const Eigen::Vector3d ca = fit.cameras[a].centre_from_cam.translation;
    o->distance_min_mm = std::min(o->distance_min_mm, ca.norm());
    o->distance_max_mm = std::max(o->distance_max_mm, ca.norm());
    for (size_t b = a + 1; b < fit.cameras.size(); ++b) {
      const Eigen::Vector3d cb = fit.cameras[b].centre_from_cam.translation;
      const double cosang = std::clamp(ca.normalized().dot(cb.normalized()), -1.0, 1.0);
      o->view_spread_deg = std::max(o->view_spread_deg, std::acos(cosang) * kDegPerRad);
    }
  }
}

void Observability(const LensCandidateFit& cand, double corr_limit, FromScreenObservability* o) {
  const ModelFit& m = cand.fit.Chosen();
  ViewGeometry(m, o);
  const int n = static_cast<int>(m.intrinsics.size());
  o->names = IntrinsicNames(n);
  o->sigma.assign(static_cast<size_t>(n), kNaN);
  if (m.intrinsics_covariance.rows() == n && n > 0) {
    const Eigen::VectorXd sd = m.intrinsics_covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    for (int i = 0; i < n; ++i) o->sigma[static_cast<size_t>(i)] = sd[i];
    const Eigen::VectorXd inv = sd.unaryExpr([](double v) { return v > 0 ? 1 / v : 0.0; });
    o->correlation = inv.asDiagonal() * m.intrinsics_covariance * inv.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(o->correlation);
    const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
    o->correlation_condition = lo > 0 ? hi / lo : kInf;
    const double sk = m.curvature_noise_sigma_per_mm;
    if (m.intrinsics_curvature_cov.size() == n && sk > 0 && sd[0] > 0) {
      o->curvature_focal_correlation = m.intrinsics_curvature_cov[0] / (sk * sd[0]);
    }
  }
  o->focal_distance_correlation = m.focal_distance_correlation;
  o->max_abs_focal_distance_correlation = 0;
  double min_abs = kInf;
  for (double c : o->focal_distance_correlation) {
    if (!std::isfinite(c)) continue;
    o->max_abs_focal_distance_correlation = std::max(o->max_abs_focal_distance_correlation, std::abs(c));
    min_abs = std::min(min_abs, std::abs(c));
  }
  const double fx = m.intrinsics.empty() ? kNaN : m.intrinsics[0];
  std::string constrained, loose;
  for (int i = 0; i < n; ++i) {
    const std::string item = fmt::format("{} {:.4g} +- {:.2g}", o->names[static_cast<size_t>(i)],
                                         m.intrinsics[static_cast<size_t>(i)], o->sigma[static_cast<size_t>(i)]);
    // Constrained: its sigma moves a point at the imager's half-diagonal by less than 0.1 px (a focal length or a
    // principal point: sigma itself in px; a distortion: sigma times its term's size there, at most 1).
    const double half_diag = 0.5 * std::hypot(m.intrinsics.size() > 2 ? 2 * m.intrinsics[2] : 0,
                                              m.intrinsics.size() > 3 ? 2 * m.intrinsics[3] : 0);
    const double effect = i < 4 ? o->sigma[static_cast<size_t>(i)] * (i < 2 ? half_diag / fx : 1)
                                : o->sigma[static_cast<size_t>(i)] * fx;
    std::string& list = effect < 0.1 ? constrained : loose;
    list += (list.empty() ? "" : ", ") + item;
  }
  o->statement = fmt::format(
      "Scale is fixed by the monitor's pixel pitch (its physical size): the photos alone cannot tell a larger, "
      "farther screen from a smaller, nearer one. Focal length and distance are coupled (a screen seen square-on "
      "measures f/d); the screen's depth and the spread of viewing directions ({:.1f} deg between the farthest "
      "views, distances {:.0f}-{:.0f} mm) break the coupling: corr(fx, camera distance) is {:.3f} to {:.3f} over "
      "the photos (refused above {:.3f}); corr(fx, curvature) is {:.3f}. Condition number of the intrinsics' "
      "correlation matrix: {:.3g}. Constrained (sigma below 0.1 px at the half-diagonal): {}. Weakly constrained: "
      "{}. The principal point trades with the cameras' rotation, and the distortion is known only where the "
      "screen was seen (extrapolated beyond).",
      o->view_spread_deg, o->distance_min_mm, o->distance_max_mm, std::isfinite(min_abs) ? min_abs : kNaN,
      o->max_abs_focal_distance_correlation, corr_limit, o->curvature_focal_correlation, o->correlation_condition,
      constrained.empty() ? "none" : constrained, loose.empty() ? "none" : loose);
}

// The projection uncertainty map of the chosen lens (FromScreenProjection).
void ProjectionMap(const std::vector<PhotoObservations>& photos, const Eigen::MatrixXd& covariance, double limit_px,
                   FromScreenResult* r) {
  FromScreenProjection& p = r->projection;
  p.limit_px = limit_px;
  p.pixel_px = ImagerGrid(r->width, r->height, p.grid_x, p.grid_y);
  std::vector<Eigen::Vector2d> observed;
  for (const PhotoObservations& o : photos) observed.insert(observed.end(), o.detected_px.begin(), o.detected_px.end());
  p.covered = CoveredCells(observed, r->width, r->height, p.grid_x, p.grid_y);
  p.covered_cells = static_cast<int>(std::count(p.covered.begin(), p.covered.end(), true));
  p.sigma_px.assign(p.pixel_px.size(), kNaN);
  p.valid.assign(p.pixel_px.size(), false);
  p.covered_median_sigma_px = p.covered_max_sigma_px = kNaN;
  if (p.covered_cells < 3 || covariance.rows() != static_cast<long>(r->model.intrinsics.size())) return;
  const ProjectionComparison c = CompareProjections({r->model, covariance}, {r->model, {}}, p.pixel_px, p.covered);
  p.sigma_px = c.sigma_px;
  p.covered_median_sigma_px = c.median_sigma_px;
  p.covered_max_sigma_px = c.max_sigma_px;
  for (size_t i = 0; i < p.valid.size(); ++i) {
    p.valid[i] = p.covered[i] && (!(limit_px > 0) || p.sigma_px[i] <= limit_px);
    p.valid_cells += p.valid[i] ? 1 : 0;
  }
}

nlohmann::json MatrixJson(const Eigen::MatrixXd& m) {
  nlohmann::json out = nlohmann::json::array();
  for (long r = 0; r < m.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (long c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    out.push_back(row);
  }
  return out;
}

nlohmann::json Num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

void FromScreenOptions::Check() const {
  for (const std::string& m : lensmodels) {
    if (!IsMrcalLensModel(m) || m.rfind("LENSMODEL_OPENCV", 0) != 0) {
      throw Error("--lensmodel", fmt::format("'{}' is not an OPENCV lens model of mrcal", m),
                  "give LENSMODEL_OPENCV4, LENSMODEL_OPENCV5 or LENSMODEL_OPENCV8 (or auto)");
    }
  }
  if (!(focal_px >= 0) || !std::isfinite(focal_px)) {
    throw Error("--focal-px", fmt::format("the focal length seed is {} px", focal_px),
                "give the focal length in px (--focal-px), or photos whose EXIF has the 35 mm equivalent focal length");
  }
  RequireInRange("--from-screen", "bic_margin", bic_margin, 0, 1e6, "give e.g. 10");
  if (min_photos < 3) throw Error("--from-screen", "min_photos below 3", "give 6 or more");
  RequireInRange("--from-screen", "min_view_spread_deg", min_view_spread_deg, 0, 180, "give e.g. 10");
  RequireInRange("--from-screen", "max_focal_distance_correlation", max_focal_distance_correlation, 0, 1, "");
  RequireInRange("--from-screen", "max_relative_focal_sigma", max_relative_focal_sigma, 0, 1, "");
  RequireInRange("--max-projection-sigma", "max_projection_sigma_px", max_projection_sigma_px, 0, 100,
                 "give the largest acceptable median projection sigma in px, e.g. 0.12 (0 = no limit)");
  fit.Check("--from-screen fit options");
}

PhotoObservations ObserveScreenImage(const cv::Mat& gray, const std::string& name, const PatternFile& pattern,
                                     const DetectOptions& options) {
  std::map<std::string, Eigen::Vector2d> display;
  for (const Feature& f : pattern.features) {
    if (f.display_px) display[f.id] = *f.display_px;
  }
  const Detection d = DetectFeatures(gray, pattern, options);
  if (d.failure_kind != DetectionFailure::kNone) {
    throw Error(name, fmt::format("the pattern was not detected: {}", d.failure),
                "leave the photo out, or retake it with the whole screen in view and in focus");
  }
  PhotoObservations o;
  o.photo = name;
  for (const DetectedFeature& f : d.features) {
    const auto it = display.find(f.id);
    if (!f.flag.empty() || it == display.end()) continue;
    o.ids.push_back(f.id);
    o.display_px.push_back(it->second);
    o.detected_px.push_back(f.px);
  }
  return o;
}

std::vector<PhotoObservations> ObserveScreenPhotos(const std::vector<std::filesystem::path>& photos,
                                                   const PatternFile& pattern, const DetectOptions& options,
                                                   int* width, int* height) {
  std::vector<PhotoObservations> out;
  *width = *height = 0;
  for (const std::filesystem::path& path : photos) {
    const cv::Mat gray = ReadPhotoGray(path);
    if (out.empty()) {
      *width = gray.cols, *height = gray.rows;
    } else if (gray.cols != *width || gray.rows != *height) {
      throw Error(path.string(),
                  fmt::format("is {} x {} px, but {} is {} x {} px", gray.cols, gray.rows, photos.front().string(),
                              *width, *height),
                  "give photos of one camera at one resolution");
    }
    PhotoObservations o = ObserveScreenImage(gray, path.string(), pattern, options);
    o.photo = path.filename().string();
    out.push_back(std::move(o));
  }
  return out;
}

std::optional<double> FocalSeedFromExif(const nlohmann::json& exif, int width, int height) {
  if (!exif.is_object() || !exif.contains("focal_length_35mm") || !exif["focal_length_35mm"].is_number()) {
    return std::nullopt;
  }
  const double f35 = exif["focal_length_35mm"].get<double>();
  if (!(f35 > 0)) return std::nullopt;
  return f35 * std::hypot(width, height) / std::hypot(36.0, 24.0);
}

FromScreenResult CalibrateFromScreen(const std::vector<PhotoObservations>& photos, const Monitor& monitor, int width,
                                     int height, const FromScreenOptions& options) {
  options.Check();
  monitor.Check("monitor");
  const std::string where = PhotoList(photos);
  if (static_cast<int>(photos.size()) < options.min_photos) {
    throw Error(where,
                fmt::format("{} photo(s) of the screen; the lens, every camera pose and the curvature need at least {}",
                            photos.size(), options.min_photos),
                fmt::format("add {} or more photos from other positions: to the left and right (yaw 10-20 deg from "
                            "the screen's normal), above and below, and at two distances",
                            options.min_photos - static_cast<int>(photos.size())));
  }
  FromScreenResult r;
  FitOptions fo = options.fit;
  fo.fit_intrinsics = true;
  fo.models = {monitor.is_flat() ? ScreenModelKind::kFlat : ScreenModelKind::kCylinder};
  fo.heldout_folds = 0;
  double focal_seed = options.focal_px;
  if (!(focal_seed > 0)) {
    // No seed given: OPENCV4 fits from trial seeds spanning normal lenses (0.6-1.7 times the image diagonal, 26 to
    // 73 mm in 35 mm terms); the fitted focal length of the lowest residual is the seed.
    double best_rms = kInf;
    std::string tried;
    for (double factor : {0.6, 0.85, 1.2, 1.7}) {
      const double f = factor * std::hypot(width, height);
      try {
        const ScreenFitResult fit = FitScreen(monitor, SeedCamera("LENSMODEL_OPENCV4", width, height, f), photos, fo);
        const ModelFit& m = fit.Chosen();
        tried += fmt::format("{}{:.0f} px -> {:.3f} px RMS", tried.empty() ? "" : ", ", f, m.rms_px);
        if (m.converged && m.rms_px < best_rms && !m.intrinsics.empty()) {
          best_rms = m.rms_px;
          focal_seed = m.intrinsics[0];
        }
      } catch (const Error& e) {
        tried += fmt::format("{}{:.0f} px failed", tried.empty() ? "" : ", ", f);
      }
    }
    if (!(focal_seed > 0)) {
      throw Error(where, "no focal length seed was given and none of the trial seeds converged (" + tried + ")",
                  "give --focal-px (the focal length in px, within 20%)");
    }
    r.focal_seed_source =
        fmt::format("none given: the OPENCV4 fit of the lowest residual from trial seeds ({})", tried);
  }
  r.monitor = monitor;
  r.width = width;
  r.height = height;
  r.focal_seed_px = focal_seed;
  for (const PhotoObservations& p : photos) r.photos.push_back(p.photo);
  const std::vector<std::string> models =
      options.lensmodels.empty()
          ? std::vector<std::string>{"LENSMODEL_OPENCV4", "LENSMODEL_OPENCV5", "LENSMODEL_OPENCV8"}
          : options.lensmodels;
  for (const std::string& lensmodel : models) {
    LensCandidateFit c;
    c.lensmodel = lensmodel;
    const CameraModel seed = SeedCamera(lensmodel, width, height, focal_seed);
    c.intrinsics = static_cast<int>(seed.intrinsics.size());
    try {
      c.fit = FitScreen(monitor, seed, photos, fo);
      const ModelFit& m = c.fit.Chosen();
      c.bic = m.bic;
      c.rms_px = m.rms_px;
      c.noise_px = m.noise_px;
      if (!m.converged) c.error = "did not converge: " + m.condition_note;
      if (m.intrinsics.size() != seed.intrinsics.size()) c.error = "no intrinsics from the fit";
    } catch (const Error& e) {
      c.error = e.what();
    }
    // The spread of the views, from the first fit that gave poses: too similar photos are refused before the
    // richer lens models are tried.
    if (r.candidates.empty() && c.error.empty()) {
      FromScreenObservability o;
      ViewGeometry(c.fit.Chosen(), &o);
      if (o.view_spread_deg < options.min_view_spread_deg) {
        throw Error(where,
                    fmt::format("the photos are too similar: their viewing directions span {:.1f} deg (distances "
                                "{:.0f}-{:.0f} mm from the screen centre), below {:.0f} deg, so the focal length "
                                "cannot be told from the distance",
                                o.view_spread_deg, o.distance_min_mm, o.distance_max_mm, options.min_view_spread_deg),
                    "add photos from the sides (about 15 deg left and right of the screen's normal, e.g. 0.4 m "
                    "sideways at 1.5 m), from above and below, and from a second distance");
      }
    }
    r.candidates.push_back(std::move(c));
  }
  // The simplest candidate within bic_margin of the lowest BIC among those that fitted.
  double best = kInf;
  for (const LensCandidateFit& c : r.candidates) {
    if (c.error.empty()) best = std::min(best, c.bic);
  }
  if (!std::isfinite(best)) {
    throw Error(where, "no lens model could be fitted: " + r.candidates.front().error,
                "check --focal-px (the seed) and that the photos show the pattern of --pattern");
  }
  for (size_t i = 0; i < r.candidates.size(); ++i) {
    if (r.candidates[i].error.empty() && r.candidates[i].bic <= best + options.bic_margin) {
      r.chosen = static_cast<int>(i);
      break;
    }
  }
  const LensCandidateFit& ch = r.Chosen();
  r.choice = fmt::format("{}: the simplest lens model within {:g} of the lowest BIC", ch.lensmodel, options.bic_margin);
  const ModelFit& m = ch.fit.Chosen();
  r.model = SeedCamera(ch.lensmodel, width, height, focal_seed);
  r.model.intrinsics = m.intrinsics;
  r.model.Check("the calibrated camera model");
  Observability(ch, options.max_focal_distance_correlation, &r.observability);
  const FromScreenObservability& o = r.observability;
  // Refusals after the fit: the coupling not broken.
  const double rel_focal = o.sigma.empty() ? kNaN : o.sigma[0] / m.intrinsics[0];
  double min_abs_corr = kInf;
  for (double c : o.focal_distance_correlation) {
    if (std::isfinite(c)) min_abs_corr = std::min(min_abs_corr, std::abs(c));
  }
  if (!(rel_focal <= options.max_relative_focal_sigma) || min_abs_corr > options.max_focal_distance_correlation) {
    throw Error(where,
                fmt::format("the photos do not separate the focal length from the distance: fx = {:.1f} +- {:.2g} px "
                            "({:.2g}% of it, limit {:.2g}%), corr(fx, distance) at least {:.4f} (limit {:.4f})",
                            m.intrinsics[0], o.sigma.empty() ? kNaN : o.sigma[0], 100 * rel_focal,
                            100 * options.max_relative_focal_sigma, min_abs_corr,
                            options.max_focal_distance_correlation),
                "add photos from the sides (yaw 15-20 deg), from above and below, and from a second distance");
  }
  r.radius_mm = m.radius_mm;
  r.radius_sigma_mm = m.radius_sigma_mm;
  r.radius_ci95_mm = m.radius_ci95_mm;
  // The stated covariance: every row of the intrinsics budget (the noise row alone if it could not be computed,
  // and the note says so).
  r.intrinsics_budget = IntrinsicsBudgetFromScreen(photos, monitor, r.model, m, fo);
  r.intrinsics_covariance = r.intrinsics_budget.computed ? r.intrinsics_budget.combined : m.intrinsics_covariance;
  ProjectionMap(photos, r.intrinsics_covariance, options.max_projection_sigma_px, &r);
  r.precise = !(options.max_projection_sigma_px > 0) ||
              r.projection.covered_median_sigma_px <= options.max_projection_sigma_px;
  if (!r.precise) {
    r.suggested = SuggestPositions(r);
    if (options.refuse_imprecise) {
      std::string add;
      for (const SuggestedPosition& p : r.suggested) {
        add += fmt::format("{}({:.0f}, {:.0f}, {:.0f}) mm aimed at ({:.0f}, {:.0f}, {:.0f}) mm [{}]", add.empty() ? "" : "; ",
                           p.position_mm.x(), p.position_mm.y(), p.position_mm.z(), p.look_at_mm.x(),
                           p.look_at_mm.y(), p.look_at_mm.z(), p.why);
      }
      throw Error(where,
                  fmt::format("the photos do not pin the lens down where they put the screen: the projection sigma "
                              "over the {} covered cells (of {} x {}) is {:.3f} px (median; max {:.3f} px), above "
                              "{:.3f} px (0.3 px at 95%)",
                              r.projection.covered_cells, r.projection.grid_x, r.projection.grid_y,
                              r.projection.covered_median_sigma_px, r.projection.covered_max_sigma_px,
                              options.max_projection_sigma_px),
                  "add photos from these camera positions (screen frame: x right, y up, z toward the viewer; the "
                  "whole screen in view): " + add + "; or accept a looser lens with --max-projection-sigma");
    }
  }
  return r;
}

std::vector<SuggestedPosition> SuggestPositions(const FromScreenResult& r) {
  const ModelFit& m = r.Chosen().fit.Chosen();
  std::vector<double> distance;
  double widest_yaw = 0;
  for (const CameraEstimate& c : m.cameras) {
    const Eigen::Vector3d t = c.centre_from_cam.translation;
    distance.push_back(t.norm());
    widest_yaw = std::max(widest_yaw, std::abs(std::atan2(t.x(), t.z())) * kDegPerRad);
  }
  const double d = distance.empty() ? 1000 : Median(distance);
  const double yaw = std::max(35.0, widest_yaw + 10) / kDegPerRad, tilt = 15 / kDegPerRad;
  const Eigen::Vector3d centre = ScreenCentreInScreen(r.monitor);
  std::vector<SuggestedPosition> out;
  for (double side : {-1.0, 1.0}) {
    out.push_back({centre + d * Eigen::Vector3d(side * std::sin(yaw), 0, std::cos(yaw)), centre,
                   fmt::format("yaw {:+.0f} deg", side * yaw * kDegPerRad)});
  }
  for (double side : {1.0, -1.0}) {
    out.push_back({centre + d * Eigen::Vector3d(0, side * std::sin(tilt), std::cos(tilt)), centre,
                   fmt::format("{} 15 deg", side > 0 ? "above," : "below,")});
  }
  return out;
}

std::string FromScreenSummary(const FromScreenResult& r) {
  std::string s = fmt::format("focal seed {:.1f} px ({}); {} photos, {} x {} px\n", r.focal_seed_px,
                              r.focal_seed_source.empty() ? "given" : r.focal_seed_source, r.photos.size(), r.width,
                              r.height);
  s += fmt::format("{:<20} {:>6} {:>10} {:>9} {:>9} {:>12}\n", "lens model", "params", "BIC", "RMS px", "noise px",
                   "fx px");
  for (size_t i = 0; i < r.candidates.size(); ++i) {
    const LensCandidateFit& c = r.candidates[i];
    if (!c.error.empty()) {
      s += fmt::format("{:<20} {:>6} failed: {}\n", c.lensmodel, c.intrinsics, c.error);
      continue;
    }
    const ModelFit& m = c.fit.Chosen();
    s += fmt::format("{:<20} {:>6} {:>10.1f} {:>9.3f} {:>9.3f} {:>12.2f}{}\n", c.lensmodel, c.intrinsics, c.bic,
                     c.rms_px, c.noise_px, m.intrinsics.empty() ? kNaN : m.intrinsics[0],
                     static_cast<int>(i) == r.chosen ? "  <- chosen" : "");
  }
  s += "choice: " + r.choice + "\n";
  s += "observability: " + r.observability.statement + "\n";
  const ModelFit& m = r.Chosen().fit.Chosen();
  if (r.radius_mm) {
    s += fmt::format("screen ({}): R = {:.1f} +- {:.1f} mm (95% interval {:.1f} to {:.1f} mm; sigma from the joint "
                     "covariance, lens included)\n",
                     m.model, *r.radius_mm, r.radius_sigma_mm.value_or(kNaN), r.radius_ci95_mm[0], r.radius_ci95_mm[1]);
  } else {
    s += fmt::format("screen ({}): no radius (flat, or R beyond {:.0f} mm at 95%)\n", m.model,
                     m.radius_lower_bound_mm);
  }
  const FromScreenProjection& p = r.projection;
  s += fmt::format("projection sigma (the lens's stated uncertainty) over the {} cells of {} x {} that hold detections: "
                   "median {:.3f} px, max {:.3f} px; valid (sigma <= {:.3f} px) on {} cells{}\n",
                   p.covered_cells, p.grid_x, p.grid_y, p.covered_median_sigma_px, p.covered_max_sigma_px, p.limit_px,
                   p.valid_cells, r.precise ? "" : " (NOT precise enough: add the suggested positions)");
  const FromScreenIntrinsicsBudget& ib = r.intrinsics_budget;
  if (ib.computed) {
    s += "intrinsics uncertainty by source (sigma of fx; the stated covariance is the sum of the rows):";
    for (const FromScreenIntrinsicsBudget::Row& row : ib.rows) {
      s += fmt::format(" {} fx {:.3g} px;", row.name, std::sqrt(std::max(0.0, row.covariance(0, 0))));
    }
    s += fmt::format(" combined fx {:.3g} px; the lens's departure from any {} (not followed by the intrinsics) "
                     "{:.4f} px RMS\n",
                     std::sqrt(std::max(0.0, r.intrinsics_covariance(0, 0))), r.model.lensmodel,
                     std::sqrt(ib.unmodelled_variance_px2));
  } else {
    s += "warning: the intrinsics covariance holds the detection noise only: " + ib.note + "\n";
  }
  for (const std::string& w : r.Chosen().fit.warnings) s += "warning: " + w + "\n";
  return s;
}

nlohmann::json FromScreenJson(const FromScreenResult& r) {
  nlohmann::json j;
  j["format"] = "curvecheck.calibration_from_screen/1";
  j["method"] =
      "lens intrinsics, camera poses and the screen's curvature estimated jointly (Ceres, the mrcal lens model "
      "through libmrcal with dq/dintrinsics) from photos of the monitor; scale from the monitor's pixel pitch";
  j["monitor"] = MonitorToJson(r.monitor);
  j["imagersize"] = {r.width, r.height};
  j["focal_seed_px"] = r.focal_seed_px;
  j["focal_seed_source"] = r.focal_seed_source;
  j["photos"] = r.photos;
  nlohmann::json cands = nlohmann::json::array();
  for (const LensCandidateFit& c : r.candidates) {
    nlohmann::json e = {{"lensmodel", c.lensmodel}, {"intrinsics_count", c.intrinsics}};
    if (!c.error.empty()) {
      e["error"] = c.error;
    } else {
      const ModelFit& m = c.fit.Chosen();
      e["bic"] = c.bic;
      e["rms_px"] = c.rms_px;
      e["noise_px"] = c.noise_px;
      e["intrinsics"] = m.intrinsics;
      e["radius_mm"] = m.radius_mm ? nlohmann::json(*m.radius_mm) : nlohmann::json(nullptr);
      e["radius_sigma_mm"] = m.radius_sigma_mm ? nlohmann::json(*m.radius_sigma_mm) : nlohmann::json(nullptr);
    }
    cands.push_back(e);
  }
  j["candidates"] = cands;
  j["choice"] = r.choice;
  const ModelFit& m = r.Chosen().fit.Chosen();
  j["lensmodel"] = r.model.lensmodel;
  j["intrinsics"] = r.model.intrinsics;
  j["intrinsics_names"] = r.observability.names;
  j["intrinsics_covariance"] = MatrixJson(r.intrinsics_covariance);
  const FromScreenIntrinsicsBudget& ib = r.intrinsics_budget;
  nlohmann::json rows = nlohmann::json::array();
  for (const FromScreenIntrinsicsBudget::Row& row : ib.rows) {
    nlohmann::json sd = nlohmann::json::array();
    for (long i = 0; i < row.covariance.rows(); ++i) sd.push_back(Num(std::sqrt(std::max(0.0, row.covariance(i, i)))));
    rows.push_back({{"name", row.name},
                    {"type", row.type},
                    {"source", row.source},
                    {"dof", Num(row.dof)},
                    {"sigma", sd},
                    {"covariance", MatrixJson(row.covariance)}});
  }
  j["intrinsics_budget"] = {
      {"computed", ib.computed},
      {"note", ib.note},
      {"rows", rows},
      {"dof", Num(ib.dof)},
      {"observations", ib.observations},
      {"residual_check_px", Num(ib.residual_check_px)},
      {"noise_check_relative", Num(ib.noise_check)},
      {"unmodelled_rms_px", Num(std::sqrt(ib.unmodelled_variance_px2))},
      {"unmodelled_components", [&] {
         nlohmann::json a = nlohmann::json::array();
         for (const UncertaintyBudget::FieldComponent& c : ib.unmodelled) {
           const bool ring = c.family == UncertaintyBudget::FieldFamily::kRing;
           a.push_back({{"family", ring ? "ring" : "gaussian"},
                        {ring ? "period_px" : "length_px", Num(c.length_px)},
                        {"rms_px", Num(std::sqrt(c.variance_px2))}});
         }
         return a;
       }()},
      {"stated", ib.computed ? "intrinsics_covariance is the sum of the rows (independent sources)"
                             : "intrinsics_covariance is the detection noise row alone (see note)"},
      {"unmodelled_meaning",
       "the lens's departure from its model that no intrinsics of this lens model follow (the misfit fields' "
       "combined RMS per coordinate; its components: Gaussian fields by correlation length, ring fields by period): "
       "a comparison with the true lens, not with another calibration of it, adds it per point"}};
  const FromScreenObservability& o = r.observability;
  nlohmann::json sig = nlohmann::json::array();
  for (double v : o.sigma) sig.push_back(Num(v));
  nlohmann::json fdc = nlohmann::json::array();
  for (double v : o.focal_distance_correlation) fdc.push_back(Num(v));
  j["observability"] = {{"intrinsics_sigma", sig},
                        {"intrinsics_correlation", MatrixJson(o.correlation)},
                        {"correlation_condition_number", Num(o.correlation_condition)},
                        {"focal_distance_correlation", fdc},
                        {"max_abs_focal_distance_correlation", o.max_abs_focal_distance_correlation},
                        {"curvature_focal_correlation", Num(o.curvature_focal_correlation)},
                        {"view_spread_deg", o.view_spread_deg},
                        {"distance_range_mm", {o.distance_min_mm, o.distance_max_mm}},
                        {"statement", o.statement}};
  nlohmann::json budget = nlohmann::json::array();
  for (const BudgetComponent& c : m.budget.components) {
    budget.push_back({{"name", c.name}, {"radius_mm", Num(c.radius_mm)}, {"source", c.source}});
  }
  j["screen"] = {{"model", m.model},
                 {"radius_mm", r.radius_mm ? nlohmann::json(*r.radius_mm) : nlohmann::json(nullptr)},
                 {"radius_sigma_mm", r.radius_sigma_mm ? nlohmann::json(*r.radius_sigma_mm) : nlohmann::json(nullptr)},
                 {"radius_ci95_mm", {Num(r.radius_ci95_mm[0]), Num(r.radius_ci95_mm[1])}},
                 {"radius_lower_bound_mm", Num(m.radius_lower_bound_mm)},
                 {"sigma_includes", "the lens (joint covariance, marginalised over the intrinsics and the poses), "
                                    "detector systematic, lens model misfit and pixel pitch (the screen fit's budget)"},
                 {"budget", budget},
                 {"noise_px", m.noise_px},
                 {"status", r.Chosen().fit.status},
                 {"warnings", r.Chosen().fit.warnings},
                 {"assumptions", r.Chosen().fit.assumptions}};
  nlohmann::json per = nlohmann::json::array();
  for (size_t p = 0; p < m.cameras.size(); ++p) {
    double sum = 0;
    int count = 0;
    for (size_t i = 0; i < m.residual_px[p].size(); ++i) {
      if (m.outlier[p][i] || !m.residual_px[p][i].allFinite()) continue;
      sum += m.residual_px[p][i].squaredNorm();
      ++count;
    }
    const Eigen::Vector3d c = m.cameras[p].position_in_screen_mm;
    per.push_back({{"photo", r.photos[p]},
                   {"features", m.residual_px[p].size()},
                   {"rms_px", count > 0 ? std::sqrt(sum / count) : kNaN},
                   {"camera_position_in_screen_mm", {c.x(), c.y(), c.z()}}});
  }
  j["per_photo"] = per;
  const FromScreenProjection& p = r.projection;
  nlohmann::json sigma = nlohmann::json::array(), covered = nlohmann::json::array(), valid = nlohmann::json::array();
  for (size_t i = 0; i < p.sigma_px.size(); ++i) {
    sigma.push_back(Num(p.sigma_px[i]));
    covered.push_back(p.covered[i] ? 1 : 0);
    valid.push_back(p.valid[i] ? 1 : 0);
  }
  j["projection_uncertainty"] = {
      {"grid", {p.grid_x, p.grid_y}},
      {"cells", "cell centres (i + 0.5) W / grid_x - 0.5, (j + 0.5) H / grid_y - 0.5, row-major"},
      {"sigma_px", sigma},
      {"covered", covered},
      {"valid", valid},
      {"covered_cells", p.covered_cells},
      {"valid_cells", p.valid_cells},
      {"covered_median_sigma_px", Num(p.covered_median_sigma_px)},
      {"covered_max_sigma_px", Num(p.covered_max_sigma_px)},
      {"limit_px", p.limit_px},
      {"precise", r.precise},
      {"method", "worst-direction sigma of the projection of rays at infinity: the intrinsics covariance "
                 "propagated through mrcal's projection difference, the rotation fitted over the covered cells; "
                 "covered = the cell holds detections; valid = covered and sigma <= limit_px (outside, the lens is "
                 "extrapolated or not known to the limit)"}};
  nlohmann::json sugg = nlohmann::json::array();
  for (const SuggestedPosition& s : r.suggested) {
    sugg.push_back({{"position_mm", {s.position_mm.x(), s.position_mm.y(), s.position_mm.z()}},
                    {"look_at_mm", {s.look_at_mm.x(), s.look_at_mm.y(), s.look_at_mm.z()}},
                    {"why", s.why}});
  }
  j["suggested_positions"] = sugg;
  return j;
}

nlohmann::json FromScreenCovarianceJson(const FromScreenResult& r, const std::string& model_file) {
  const ModelFit& m = r.Chosen().fit.Chosen();
  const FromScreenIntrinsicsBudget& ib = r.intrinsics_budget;
  if (r.intrinsics_covariance.size() == 0 || !r.intrinsics_covariance.allFinite()) {
    throw Error(model_file, "the calibration from the screen has no intrinsics covariance",
                "add photos from more positions");
  }
  return {{"format", "curvecheck.intrinsics_covariance/1"},
          {"model", model_file},
          {"lensmodel", r.model.lensmodel},
          {"intrinsics", r.model.intrinsics},
          {"covariance", MatrixJson(r.intrinsics_covariance)},
          {"dof", ib.computed ? ib.dof : static_cast<double>(m.dof)},
          {"observed_pixel_uncertainty_px", m.noise_px},
          {"method", ib.computed
                         ? "calibrate --from-screen: the sum of the intrinsics budget's rows (calibration.json "
                           "intrinsics_budget): detection noise (noise_px^2 times the intrinsics block of the joint "
                           "(J^T J)^-1 of the screen fit with free intrinsics, marginal over the poses and the "
                           "curvature), detector systematic and lens model misfit (the screen fit's rows propagated "
                           "to the intrinsics through its linearized refit); dof by Welch-Satterthwaite"
                         : "calibrate --from-screen: noise_px^2 times the intrinsics block of the joint (J^T J)^-1 "
                           "of the screen fit with free intrinsics (marginal over the poses and the curvature); the "
                           "systematic rows could not be propagated: " + ib.note}};
}

std::vector<double> LensDifferencePx(const CameraModel& truth, const CameraModel& estimate, int gridn_width,
                                     int gridn_height, double distance_mm) {
  std::vector<Eigen::Vector2d> q;
  for (int j = 0; j < gridn_height; ++j) {
    for (int i = 0; i < gridn_width; ++i) {
      q.emplace_back((truth.width - 1) * i / std::max(1.0, gridn_width - 1.0),
                     (truth.height - 1) * j / std::max(1.0, gridn_height - 1.0));
    }
  }
  const std::vector<Eigen::Vector3d> vt = UnprojectPixels(truth, q), ve = UnprojectPixels(estimate, q);
  const Eigen::Vector2d centre(0.5 * (truth.width - 1), 0.5 * (truth.height - 1));
  const double radius = std::min(truth.width, truth.height) / 6.0;
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < q.size(); ++k) {
    if ((q[k] - centre).norm() <= radius) h += ve[k] * vt[k].transpose();
  }
  // Kabsch: the rotation R maximising sum ve . R vt.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d rot = svd.matrixU() * d * svd.matrixV().transpose();
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& v : vt) points.push_back(rot * (distance_mm * v));
  const std::vector<Eigen::Vector2d> qe = ProjectPoints(estimate, points);
  std::vector<double> out;
  for (size_t k = 0; k < q.size(); ++k) out.push_back((qe[k] - q[k]).norm());
  return out;
}

}  // namespace curvecheck
