#include "analysis/plan.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <sstream>

#include "analysis/verify.h"
#include "core/error.h"
#include "core/gnuplot.h"
#include "core/look_at.h"
#include "core/math_util.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

// The features the plan observes: those of the pattern with a display position.
struct PlanFeatures {
  std::vector<std::string> ids;
  std::vector<Eigen::Vector2d> display_px;
};

PlanFeatures FeaturesOf(const PatternFile& pattern) {
  PlanFeatures f;
  for (const Feature& feature : pattern.features) {
    if (!feature.display_px) continue;
    f.ids.push_back(feature.id);
    f.display_px.push_back(*feature.display_px);
  }
  return f;
}

Pose CentreFromCam(const Monitor& m, const Pose& screen_from_cam) {
  return Pose(screen_from_cam.rotation, screen_from_cam.translation - ScreenCentreInScreen(m));
}

// The camera's projections of the features on the nominal screen (NaN behind the camera).
std::vector<Eigen::Vector2d> ProjectFeatures(const Monitor& m, const CameraModel& camera,
                                             const Pose& screen_from_cam,
                                             const std::vector<Eigen::Vector2d>& display_px,
                                             Eigen::VectorXd* depth) {
  const Pose cam_from_screen = screen_from_cam.Inverse();
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector2d& px : display_px) {
    points.push_back(cam_from_screen * SurfacePointFromUv(m, UvFromDisplayPx(m, px)));
  }
  std::vector<Eigen::Vector2d> q = ProjectPoints(camera, points);
  if (depth) depth->resize(static_cast<long>(points.size()));
  for (size_t i = 0; i < points.size(); ++i) {
    if (depth) (*depth)[static_cast<long>(i)] = points[i].z();
    if (!(points[i].z() > 0)) q[i].setConstant(kNaN);
  }
  return q;
}

double Median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// A smooth field over the image common to every photo (the lens model misfit the plan assumes): Legendre
// polynomials of total degree <= `degree` with seeded N(0, 1) coefficients per coordinate, scaled so that its
// RMS over a 32 x 32 grid of the imager is rms_px per coordinate (the budget's own misfit family,
// FitOptions::misfit_field_degree).
struct SmoothField {
  Eigen::VectorXd ax, ay;
  int width = 0, height = 0, degree = 0;
  double scale = 0;

  SmoothField(const CameraModel& camera, int degree_, double rms_px, std::mt19937_64& rng)
      : width(camera.width), height(camera.height), degree(degree_) {
    std::vector<Eigen::Vector2d> grid;
    for (int j = 0; j < 32; ++j) {
      for (int i = 0; i < 32; ++i) grid.emplace_back((i + 0.5) * width / 32.0, (j + 0.5) * height / 32.0);
    }
    const Eigen::MatrixXd b = LegendreFieldBasis(grid, width, height, degree);
    std::normal_distribution<double> unit(0, 1);
    ax.resize(b.cols());
    ay.resize(b.cols());
    for (long i = 0; i < b.cols(); ++i) ax[i] = unit(rng), ay[i] = unit(rng);
    const double ms =
        ((b * ax).squaredNorm() + (b * ay).squaredNorm()) / (2.0 * static_cast<double>(grid.size()));
    scale = ms > 0 ? rms_px / std::sqrt(ms) : 0;
  }
  Eigen::Vector2d At(const Eigen::Vector2d& q) const {
    if (scale == 0) return Eigen::Vector2d::Zero();
    const Eigen::MatrixXd b = LegendreFieldBasis({q}, width, height, degree);
    return scale * Eigen::Vector2d(b.row(0).dot(ax), b.row(0).dot(ay));
  }
};

// The detector's pixel-locking (DetectionNoiseModel::pixel_locking_fraction): its phase offsets per
// coordinate, drawn once per simulated detector and common to its photos.
struct PixelLockingBias {
  double fraction = 0;
  Eigen::Vector2d phase = Eigen::Vector2d::Zero();
  PixelLockingBias(double fraction_, std::mt19937_64& rng) : fraction(fraction_) {
    std::uniform_real_distribution<double> uniform(0, 2 * kPi);
    phase = Eigen::Vector2d(uniform(rng), uniform(rng));
  }
  Eigen::Vector2d At(const Eigen::Vector2d& q, double noise_px) const {
    Eigen::Vector2d b;
    for (int c = 0; c < 2; ++c)
      b[c] = fraction * noise_px * std::sin(2 * kPi * (q[c] - std::floor(q[c])) + phase[c]);
    return b;
  }
  // The independent Gaussian part's sigma: the total RMS per coordinate stays noise_px.
  double GaussianSigma(double noise_px) const {
    return noise_px * std::sqrt(std::max(0.0, 1 - 0.5 * fraction * fraction));
  }
};

// The detections of one placement: the true projections, plus the lens field, plus the detector's
// pixel-locking and independent Gaussian noise (together of the placement's expected level per coordinate).
// Only features inside the imager are kept.
PhotoObservations Simulate(const Monitor& m, const CameraModel& camera, const PlanFeatures& f,
                           const PlanPlacement& place, const SmoothField& lens,
                           const PixelLockingBias& locking, std::mt19937_64& rng, const std::string& name) {
  std::normal_distribution<double> noise(0, locking.GaussianSigma(place.noise_px));
  const std::vector<Eigen::Vector2d> q =
      ProjectFeatures(m, camera, place.screen_from_cam, f.display_px, nullptr);
  PhotoObservations obs;
  obs.photo = name;
  for (size_t i = 0; i < q.size(); ++i) {
    const double nx = noise(rng), ny = noise(rng);
    if (!q[i].allFinite() || q[i].x() < 0 || q[i].y() < 0 || q[i].x() > camera.width - 1 ||
        q[i].y() > camera.height - 1) {
      continue;
    }
    obs.ids.push_back(f.ids[i]);
    obs.display_px.push_back(f.display_px[i]);
    const Eigen::Vector2d image = q[i] + lens.At(q[i]);
    obs.detected_px.push_back(image + locking.At(image, place.noise_px) + Eigen::Vector2d(nx, ny));
  }
  return obs;
}

FitOptions PlannerFitOptions(const PlanOptions& o, double noise_px) {
  FitOptions fit = o.fit;
  fit.models = {ScreenModelKind::kCylinder};
  fit.heldout_folds = 0;
  fit.detection_noise_px = noise_px;
  return fit;
}

std::string Fixed(double v, int digits) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, digits) : "-"; }

}  // namespace

DetectionNoiseModel DefaultDetectionNoiseModel() {
  // fit.noise_px of `analyze` on single realistic synthetic photos (datasets/scenes/default.yaml: 24 MP
  // OPENCV8 lens, imaging preset ilc24, the 16 x 5 checkerboard rendered for the eye 1.5 m in front of the
  // centre of the 49" 1000R monitor), by camera px per display px m (f pitch / distance): quarter resolution
  // (f = 1250 px) at 1000-3000 mm and yaw 0/25/40 deg, half resolution (f = 2500 px) at 1500, 2200 (yaw 25)
  // and 3000 mm; the median per m where several yaws were measured. 16 photos, 0.013-0.037 px, median 0.030:
  // no trend with m over 0.1-0.4 (the scatter between yaws at one distance is larger than any trend); the
  // ends are held constant beyond.
  DetectionNoiseModel m;
  m.camera_px_per_display_px_to_noise_px = {{0.097, 0.036},  {0.133, 0.031}, {0.167, 0.030}, {0.195, 0.030},
                                            {0.234, 0.0325}, {0.266, 0.029}, {0.292, 0.031}, {0.390, 0.031}};
  // The pixel-locking amplitude (the mean of x and y of fit.uncertainty_budget.detector_systematic.
  // pixel_locking_amplitude_px) over fit.noise_px on the same 16 photos: median 0.84 (0.39-1.13).
  m.pixel_locking_fraction = 0.84;
  m.source =
      "fit.noise_px of analyze on 16 realistic synthetic photos (ilc24 chain, quarter and half resolution, "
      "0.1-0.4 camera px per display px, yaw 0-40 deg): median 0.030 px, range 0.013-0.037 px; docs/bench/"
      "plan_bench.txt; pixel-locking amplitude 0.84 of it (median)";
  return m;
}

double DetectionNoiseModel::NoisePx(double m) const {
  const auto& t = camera_px_per_display_px_to_noise_px;
  if (t.empty()) throw Error("detection noise model", "has no rows", "");
  if (!(m > 0) || m <= t.front().first) return t.front().second;
  if (m >= t.back().first) return t.back().second;
  for (size_t i = 1; i < t.size(); ++i) {
    if (m <= t[i].first) {
      const double a = std::log(t[i - 1].first), b = std::log(t[i].first), x = std::log(m);
      return t[i - 1].second + (t[i].second - t[i - 1].second) * (x - a) / (b - a);
    }
  }
  return t.back().second;
}

void DetectionNoiseModel::Check(const std::string& where) const {
  const auto& t = camera_px_per_display_px_to_noise_px;
  if (t.empty())
    throw Error(where, "the detection noise model has no rows", "give at least one (m, noise_px) row");
  if (!(pixel_locking_fraction >= 0 && pixel_locking_fraction <= std::sqrt(2.0))) {
    throw Error(where, fmt::format("pixel-locking fraction {}", pixel_locking_fraction),
                "give 0 to sqrt(2) (the sinusoid's RMS is at most the noise)");
  }
  for (size_t i = 0; i < t.size(); ++i) {
    if (!(t[i].first > 0) || !(t[i].second > 0) || !std::isfinite(t[i].first) ||
        !std::isfinite(t[i].second)) {
      throw Error(
          where,
          fmt::format("noise model row {} ({}, {}) is not positive and finite", i, t[i].first, t[i].second),
          "");
    }
    if (i > 0 && !(t[i].first > t[i - 1].first)) {
      throw Error(where, "the noise model's rows are not in ascending order of camera px per display px", "");
    }
  }
}

void PlanOptions::Check(const std::string& where) const {
  const auto positive_list = [&](const std::vector<double>& v, const std::string& what, bool allow_zero) {
    if (v.empty()) throw Error(where, what + " is empty", "give at least one value");
    for (double x : v) {
      if (!std::isfinite(x) || (allow_zero ? x < 0 : x <= 0)) {
        throw Error(where, fmt::format("{} holds {}", what, x),
                    allow_zero ? "give values >= 0" : "give values > 0");
      }
    }
  };
  positive_list(distances_mm, "the distances", false);
  positive_list(yaws_deg, "the yaws", true);
  for (double y : yaws_deg) {
    if (y >= 89) throw Error(where, fmt::format("yaw {} deg", y), "give yaws below 89 deg");
  }
  if (heights_mm.empty()) throw Error(where, "the heights are empty", "give at least one value (0)");
  if (!(target_radius_sigma_mm >= 0) || !std::isfinite(target_radius_sigma_mm)) {
    throw Error(where, fmt::format("target radius sigma {} mm", target_radius_sigma_mm),
                "give a value > 0 (mm)");
  }
  if (!(tolerance_display_px > 0) || !std::isfinite(tolerance_display_px)) {
    throw Error(where, fmt::format("tolerance {} display px", tolerance_display_px), "give a value > 0");
  }
  if (photos < 0 || max_photos < 1 || photos > 64 || max_photos > 64) {
    throw Error(where, fmt::format("photos {} / max_photos {}", photos, max_photos), "give 1 to 64 photos");
  }
  if (!(imager_margin >= 0 && imager_margin < 0.4)) throw Error(where, "imager margin outside [0, 0.4)", "");
  if (!(min_feature_spacing_camera_px > 0)) throw Error(where, "minimum feature spacing must be > 0 px", "");
  if (!(max_obliquity_deg > 0 && max_obliquity_deg < 90))
    throw Error(where, "maximum obliquity outside (0, 90) deg", "");
  if (!(lens_misfit_relative >= 0 && lens_misfit_relative < 0.01)) {
    throw Error(where, fmt::format("lens misfit {} of the width", lens_misfit_relative), "give 0 to 0.01");
  }
  if (seeds < 1 || seeds > 100) throw Error(where, fmt::format("{} seeds", seeds), "give 1 to 100");
  noise.Check(where);
  fit.Check(where);
}

PlanPlacement EvaluatePlacement(const Monitor& monitor, const CameraModel& camera, const PatternFile& pattern,
                                double distance_mm, double yaw_deg, double height_mm,
                                const PlanOptions& options) {
  if (!(distance_mm > 0))
    throw Error("capture plan", fmt::format("distance {} mm", distance_mm), "give a distance > 0");
  PlanPlacement p;
  p.distance_mm = distance_mm;
  p.yaw_deg = yaw_deg;
  p.height_mm = height_mm;
  const double yaw = yaw_deg / kDegPerRad;
  const Eigen::Vector3d centre = ScreenCentreInScreen(monitor);
  p.look_at_in_screen_mm = centre;
  p.position_in_screen_mm =
      centre + Eigen::Vector3d(distance_mm * std::sin(yaw), height_mm, distance_mm * std::cos(yaw));
  p.screen_from_cam = ScreenFromCamLookAt(p.position_in_screen_mm, centre, Eigen::Vector3d::UnitY());
  if (FrontClearanceMm(monitor, p.position_in_screen_mm) <= 0) {
    p.why_not = "part of the screen faces away from the camera";
    return p;
  }
  const PlanFeatures f = FeaturesOf(pattern);
  if (f.ids.empty())
    throw Error("capture plan", "the pattern has no feature on the display", "render another pattern");
  const std::vector<Eigen::Vector2d> q =
      ProjectFeatures(monitor, camera, p.screen_from_cam, f.display_px, nullptr);
  // The camera's resolving power: the image displacement of one display px along x and y, per feature.
  std::vector<Eigen::Vector2d> qx = f.display_px, qy = f.display_px;
  for (size_t i = 0; i < qx.size(); ++i) qx[i].x() += 1, qy[i].y() += 1;
  const std::vector<Eigen::Vector2d> q1 = ProjectFeatures(monitor, camera, p.screen_from_cam, qx, nullptr);
  const std::vector<Eigen::Vector2d> q2 = ProjectFeatures(monitor, camera, p.screen_from_cam, qy, nullptr);
  const double mx = options.imager_margin * camera.width, my = options.imager_margin * camera.height;
  std::vector<double> scale;
  int outside = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    const bool in = q[i].allFinite() && q[i].x() >= mx && q[i].y() >= my &&
                    q[i].x() <= camera.width - 1 - mx && q[i].y() <= camera.height - 1 - my;
    outside += !in;
    if (!in) continue;
    ++p.features;
    scale.push_back(0.5 * ((q1[i] - q[i]).norm() + (q2[i] - q[i]).norm()));
    const Eigen::Vector2d uv = UvFromDisplayPx(monitor, f.display_px[i]);
    const Eigen::Vector3d point = SurfacePointFromUv(monitor, uv);
    const double c = SurfaceNormalFromUv(monitor, uv).dot((p.position_in_screen_mm - point).normalized());
    p.max_obliquity_deg = std::max(p.max_obliquity_deg, std::acos(std::clamp(c, -1.0, 1.0)) * kDegPerRad);
  }
  double spacing = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < q.size(); ++i) {
    for (size_t j = i + 1; j < q.size(); ++j) {
      if (q[i].allFinite() && q[j].allFinite()) spacing = std::min(spacing, (q[i] - q[j]).norm());
    }
  }
  p.feature_spacing_camera_px = std::isfinite(spacing) ? spacing : 0;
  p.camera_px_per_display_px = Median(scale);
  p.noise_px = options.noise.NoisePx(p.camera_px_per_display_px);
  if (outside > 0) {
    p.why_not = fmt::format("{} of {} features outside the imager (margin {:.0f}%)", outside, q.size(),
                            100 * options.imager_margin);
  } else if (p.feature_spacing_camera_px < options.min_feature_spacing_camera_px) {
    p.why_not = fmt::format("features {:.1f} px apart in the image (at least {:.0f} px needed)",
                            p.feature_spacing_camera_px, options.min_feature_spacing_camera_px);
  } else if (p.max_obliquity_deg > options.max_obliquity_deg) {
    p.why_not = fmt::format("features seen {:.0f} deg off their normal (at most {:.0f})", p.max_obliquity_deg,
                            options.max_obliquity_deg);
  } else {
    p.usable = true;
  }
  if (p.usable) {
    try {
      p.radius_crb_mm = RadiusCramerRaoBoundMm(monitor, camera, {CentreFromCam(monitor, p.screen_from_cam)},
                                               {f.display_px}, p.noise_px);
    } catch (const Error& e) {
      p.usable = false;
      p.why_not = "the radius is not observable from here alone";
    }
  }
  return p;
}

std::pair<double, std::vector<PlanBudgetRow>> PredictRadiusSigma(const Monitor& monitor,
                                                                 const CameraModel& camera,
                                                                 const PatternFile& pattern,
                                                                 const std::vector<PlanPlacement>& placements,
                                                                 const PlanOptions& options) {
  if (placements.empty()) throw Error("capture plan", "no placement to predict", "");
  const PlanFeatures f = FeaturesOf(pattern);
  double noise_ms = 0;
  for (const PlanPlacement& p : placements) noise_ms += p.noise_px * p.noise_px;
  const double noise_px = std::sqrt(noise_ms / static_cast<double>(placements.size()));
  const FitOptions fit_options = PlannerFitOptions(options, noise_px);
  double sum2 = 0;
  std::map<std::string, double> rows2;
  std::vector<std::string> order;
  for (int s = 0; s < options.seeds; ++s) {
    std::mt19937_64 rng(options.seed + 7919u * static_cast<unsigned>(s));
    const SmoothField lens(camera, options.fit.misfit_field_degree,
                           options.lens_misfit_relative * camera.width, rng);
    const PixelLockingBias locking(options.noise.pixel_locking_fraction, rng);
    std::vector<PhotoObservations> photos;
    for (size_t i = 0; i < placements.size(); ++i) {
      photos.push_back(
          Simulate(monitor, camera, f, placements[i], lens, locking, rng, fmt::format("planned-{}", i + 1)));
    }
    const ScreenFitResult r = FitScreen(monitor, camera, photos, fit_options);
    const ModelFit& c = r.Chosen();
    if (!c.radius_sigma_mm) {
      throw Error("capture plan",
                  fmt::format("the simulated fit gives no radius from these {} placement(s): {}",
                              placements.size(), c.condition_note.empty() ? r.status : c.condition_note),
                  "allow closer or more oblique placements (--distances-mm, --yaws-deg)");
    }
    sum2 += *c.radius_sigma_mm * *c.radius_sigma_mm;
    for (const BudgetComponent& row : c.budget.components) {
      if (!rows2.count(row.name)) order.push_back(row.name);
      const double v = std::isfinite(row.radius_mm) ? row.radius_mm : 0;
      rows2[row.name] += v * v;
    }
  }
  std::vector<PlanBudgetRow> rows;
  for (const std::string& name : order) rows.push_back({name, std::sqrt(rows2[name] / options.seeds)});
  return {std::sqrt(sum2 / options.seeds), rows};
}

CapturePlan PlanCapture(const Monitor& monitor, const CameraModel& camera, const PatternFile& pattern,
                        const PlanOptions& options) {
  options.Check("capture plan options");
  monitor.Check("monitor");
  camera.Check("camera model");
  if (monitor.is_flat()) {
    throw Error("capture plan",
                fmt::format("monitor {} is flat: there is no radius to measure", monitor.name),
                "plan for a curved monitor");
  }
  CapturePlan plan;
  // The grid, each yaw also mirrored (a positive yaw puts the camera to the right).
  std::vector<double> yaws;
  for (double y : options.yaws_deg) {
    yaws.push_back(y);
    if (y > 0) yaws.push_back(-y);
  }
  for (double h : options.heights_mm) {
    for (double y : yaws) {
      for (double d : options.distances_mm) {
        plan.grid.push_back(EvaluatePlacement(monitor, camera, pattern, d, y, h, options));
      }
    }
  }
  std::vector<const PlanPlacement*> usable;
  std::map<std::string, int> reasons;
  for (const PlanPlacement& p : plan.grid) {
    if (p.usable) {
      usable.push_back(&p);
    } else {
      reasons[p.why_not.substr(0, p.why_not.find_first_of("0123456789"))]++;
    }
  }
  if (usable.empty()) {
    std::string why;
    for (const auto& [reason, n] : reasons)
      why += fmt::format("{}{} x '{}...'", why.empty() ? "" : ", ", n, reason);
    throw Error("capture plan",
                fmt::format("no placement of the {} searched is usable ({})", plan.grid.size(), why),
                "give other distances (--distances-mm), a wider lens or a smaller pattern");
  }
  // Best single photos first (the radius's Cramer-Rao bound at the expected noise). The curvature is the only
  // parameter the photos share, so each photo adds its own information about it (its Schur complement after
  // its pose): the best set of n distinct placements is, to first order, the n best single ones.
  std::stable_sort(usable.begin(), usable.end(), [](const PlanPlacement* a, const PlanPlacement* b) {
    return a->radius_crb_mm < b->radius_crb_mm;
  });
  const double target = options.target_radius_sigma_mm;
  const int fixed = options.photos > 0 ? options.photos : (target > 0 ? 0 : 4);
  const int most = static_cast<int>(
      std::min<size_t>(usable.size(), static_cast<size_t>(fixed > 0 ? fixed : options.max_photos)));
  std::vector<PlanPlacement> set;
  std::pair<double, std::vector<PlanBudgetRow>> pred;
  for (int n = 1; n <= most; ++n) {
    set.push_back(*usable[static_cast<size_t>(n - 1)]);
    // With a fixed count only that count is predicted; otherwise every count until the target is met.
    if (fixed > 0 && n < most) continue;
    try {
      pred = PredictRadiusSigma(monitor, camera, pattern, set, options);
    } catch (const Error&) {
      // Too few photos for a radius (ill-conditioned): more may give one; the last count must.
      if (n == most) throw;
      plan.sigma_by_photos_mm.emplace_back(n, kNaN);
      continue;
    }
    plan.sigma_by_photos_mm.emplace_back(n, pred.first);
    if (fixed == 0 && pred.first <= target) break;
  }
  plan.positions = set;
  plan.predicted_radius_sigma_mm = pred.first;
  plan.budget = pred.second;
  double floor2 = 0;
  for (const PlanBudgetRow& row : plan.budget) {
    if (row.name == "pixel pitch" || row.name == "lens calibration") floor2 += row.radius_mm * row.radius_mm;
  }
  plan.radius_sigma_floor_mm = std::sqrt(floor2);
  plan.target_reached = target > 0 && plan.predicted_radius_sigma_mm <= target;
  std::string dominant;
  double largest = -1;
  for (const PlanBudgetRow& row : plan.budget) {
    if (row.radius_mm > largest) largest = row.radius_mm, dominant = row.name;
  }
  if (target <= 0) {
    plan.target_note = fmt::format("no target given: {} photos planned", set.size());
  } else if (plan.target_reached) {
    plan.target_note = fmt::format("{} photo(s) reach the target {:.3g} mm (predicted {:.3g} mm)", set.size(),
                                   target, plan.predicted_radius_sigma_mm);
  } else if (target <= plan.radius_sigma_floor_mm) {
    plan.target_note = fmt::format(
        "the target {:.3g} mm cannot be reached: the rows that no number of photos removes (pixel pitch, "
        "lens "
        "calibration) are already {:.3g} mm; a tighter pitch tolerance or lens calibration is needed",
        target, plan.radius_sigma_floor_mm);
  } else {
    plan.target_note = fmt::format(
        "the target {:.3g} mm is not reached with {} photo(s) ({} usable placements searched): predicted "
        "{:.3g} mm, "
        "dominated by {} ({:.3g} mm); photograph from closer, with a longer lens or at a higher resolution",
        target, set.size(), usable.size(), plan.predicted_radius_sigma_mm, dominant, largest);
  }

  // The verification from the eye point the pattern was rendered for, looking at the screen centre.
  const Eigen::Vector3d eye = pattern.viewpoint_in_screen, centre = ScreenCentreInScreen(monitor);
  const Eigen::Vector3d from_centre = eye - centre;
  const double d = from_centre.norm();
  const double yaw = std::atan2(from_centre.x(), from_centre.z()) * kDegPerRad;
  const double horizontal = std::hypot(from_centre.x(), from_centre.z());
  PlanOptions vo = options;
  PlanPlacement v = EvaluatePlacement(monitor, camera, pattern, horizontal, yaw, from_centre.y(), vo);
  (void)d;
  plan.verification_placement = v;
  if (!v.usable) {
    plan.verification_note =
        fmt::format("from the eye point the camera cannot verify the pattern: {}", v.why_not);
  } else {
    const PlanFeatures f = FeaturesOf(pattern);
    std::mt19937_64 rng(options.seed);
    const SmoothField lens(camera, options.fit.misfit_field_degree,
                           options.lens_misfit_relative * camera.width, rng);
    const PixelLockingBias locking(options.noise.pixel_locking_fraction, rng);
    const PhotoObservations obs = Simulate(monitor, camera, f, v, lens, locking, rng, "eye");
    VerifyOptions verify;
    verify.tolerance_display_px = options.tolerance_display_px;
    const Verification r = VerifyCorrection(pattern, camera, obs.ids, obs.detected_px, verify);
    if (!r.failure.empty()) {
      plan.verification_note = "the simulated verification gives no verdict: " + r.failure;
    } else {
      plan.verification_predicted = true;
      plan.predicted_verification_u_display_px = r.expanded_uncertainty_display_px;
      plan.predicted_verification_e_display_px = r.error_p95_display_px;
      plan.verification_tolerance_ratio = r.tolerance_ratio;
      plan.verification_conclusive = r.verdict == Verdict::kPass;
      plan.verification_note = fmt::format(
          "a correct rendering photographed from the eye point: e = {:.3f}, U = {:.3f} display px (k = 2), "
          "T/U = "
          "{:.2f}: {} for T = {:.3g} display px{}",
          r.error_p95_display_px, r.expanded_uncertainty_display_px, r.tolerance_ratio,
          plan.verification_conclusive ? "conclusive (pass)" : "inconclusive", options.tolerance_display_px,
          r.tolerance_ratio < 2
              ? "; T/U below 2: the set-up is not fit for this tolerance (move closer, use a "
                "longer focal length or a higher resolution)"
              : "");
    }
  }

  plan.assumptions = {
      "the monitor is the nominal one (ideal cylinder of the stated radius and pitch); the photos show the "
      "pattern "
      "of the given pattern.json",
      fmt::format(
          "detection noise per coordinate from the realistic chain's measurements, as a function of the "
          "camera px per display px ({})",
          options.noise.source),
      fmt::format(
          "lens model misfit of {:.3g} px RMS per coordinate ({:.2g} of the imager width), smooth and common "
          "to every photo",
          options.lens_misfit_relative * camera.width, options.lens_misfit_relative),
      options.fit.intrinsics_covariance.size() > 0
          ? "lens calibration uncertainty from the camera model's intrinsics covariance"
          : "lens calibration taken as exact (no intrinsics covariance beside the camera model)",
      fmt::format(
          "the analysis fits the cylinder (the model a nominal curved screen selects); prediction = RMS over "
          "{} simulated detection draws of the fit's combined radius sigma (its whole budget)",
          options.seeds),
      fmt::format(
          "placements: camera looking at the screen centre, level; distance from the centre {} mm; yaw +-{} "
          "deg; height {} mm; usable when every feature is inside the imager with a {:.0f}% margin, features "
          ">= {:.0f} px apart and <= {:.0f} deg off their normal",
          fmt::join(options.distances_mm, ","), fmt::join(options.yaws_deg, ","),
          fmt::join(options.heights_mm, ","), 100 * options.imager_margin,
          options.min_feature_spacing_camera_px, options.max_obliquity_deg),
  };
  const auto& rows = options.noise.camera_px_per_display_px_to_noise_px;
  for (const PlanPlacement& p : plan.positions) {
    if (p.camera_px_per_display_px < 0.9 * rows.front().first ||
        p.camera_px_per_display_px > 1.1 * rows.back().first) {
      plan.assumptions.push_back(
          fmt::format("the detection noise is extrapolated: the planned positions see {:.3g} camera px per "
                      "display px, the noise "
                      "was measured over {:.3g}-{:.3g} (held constant beyond)",
                      p.camera_px_per_display_px, rows.front().first, rows.back().first));
      break;
    }
  }
  return plan;
}

nlohmann::json PlanJson(const CapturePlan& plan, const Monitor& monitor, const CameraModel& camera,
                        const PlanOptions& options, const std::string& command_line) {
  const auto vec = [](const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
  const auto placement = [&](const PlanPlacement& p) {
    return nlohmann::json{{"position_mm", vec(p.position_in_screen_mm)},
                          {"look_at_mm", vec(p.look_at_in_screen_mm)},
                          {"up", nlohmann::json::array({0, 1, 0})},
                          {"distance_mm", p.distance_mm},
                          {"yaw_deg", p.yaw_deg},
                          {"height_mm", p.height_mm},
                          {"features", p.features},
                          {"feature_spacing_camera_px", p.feature_spacing_camera_px},
                          {"camera_px_per_display_px", p.camera_px_per_display_px},
                          {"max_obliquity_deg", p.max_obliquity_deg},
                          {"expected_noise_px", p.noise_px},
                          {"single_photo_radius_crb_mm", p.radius_crb_mm}};
  };
  nlohmann::json j;
  j["format"] = "curvecheck.plan/1";
  j["command"] = command_line;
  j["frame"] = "screen frame: origin on the cylinder axis, x right, y up, +z toward the viewer; mm";
  j["monitor"] = {{"name", monitor.name},
                  {"resolution", {monitor.width_px, monitor.height_px}},
                  {"width_mm", monitor.width_mm},
                  {"height_mm", monitor.height_mm},
                  {"radius_mm", monitor.radius_mm()}};
  j["camera"] = {{"lensmodel", camera.lensmodel},
                 {"width", camera.width},
                 {"height", camera.height},
                 {"focal_px", camera.intrinsics.empty() ? kNaN : camera.intrinsics[0]}};
  j["positions"] = nlohmann::json::array();
  for (const PlanPlacement& p : plan.positions) j["positions"].push_back(placement(p));
  j["predicted_radius_sigma_mm"] = plan.predicted_radius_sigma_mm;
  j["predicted_radius_budget"] = nlohmann::json::array();
  for (const PlanBudgetRow& row : plan.budget)
    j["predicted_radius_budget"].push_back({{"name", row.name}, {"radius_mm", row.radius_mm}});
  j["radius_sigma_floor_mm"] = plan.radius_sigma_floor_mm;
  j["sigma_by_photos_mm"] = nlohmann::json::array();
  for (const auto& [n, sigma] : plan.sigma_by_photos_mm) {
    j["sigma_by_photos_mm"].push_back(
        {{"photos", n},
         {"radius_sigma_mm", std::isfinite(sigma) ? nlohmann::json(sigma) : nlohmann::json(nullptr)}});
  }
  j["target_radius_sigma_mm"] = options.target_radius_sigma_mm > 0
                                    ? nlohmann::json(options.target_radius_sigma_mm)
                                    : nlohmann::json(nullptr);
  j["target_reached"] = plan.target_reached;
  j["target_note"] = plan.target_note;
  j["tolerance_display_px"] = options.tolerance_display_px;
  if (plan.verification_predicted) {
    j["predicted_verification_u_display_px"] = plan.predicted_verification_u_display_px;
  } else {
    j["predicted_verification_u_display_px"] = nullptr;
  }
  j["verification"] = {{"position_mm", vec(plan.verification_placement.position_in_screen_mm)},
                       {"look_at_mm", vec(plan.verification_placement.look_at_in_screen_mm)},
                       {"predicted", plan.verification_predicted},
                       {"expanded_uncertainty_display_px", plan.predicted_verification_u_display_px},
                       {"error_p95_display_px", plan.predicted_verification_e_display_px},
                       {"tolerance_ratio", plan.verification_tolerance_ratio},
                       {"conclusive", plan.verification_conclusive},
                       {"note", plan.verification_note}};
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& [m, s] : options.noise.camera_px_per_display_px_to_noise_px) rows.push_back({m, s});
  j["noise_model"] = {{"camera_px_per_display_px_to_noise_px", rows}, {"source", options.noise.source}};
  j["assumptions"] = plan.assumptions;
  return j;
}

std::string PlanText(const CapturePlan& plan, const PlanOptions& options) {
  std::ostringstream out;
  size_t usable = 0;
  for (const PlanPlacement& p : plan.grid) usable += p.usable;
  out << fmt::format("capture plan: {} placements searched, {} usable; {} recommended\n\n", plan.grid.size(),
                     usable, plan.positions.size());
  out << fmt::format("{:>3} {:>8} {:>7} {:>7}   {:>24} {:>9} {:>9} {:>8} {:>9} {:>10}\n", "#", "dist mm",
                     "yaw deg", "h mm", "position_mm (screen)", "spacing", "cam/disp", "obliq", "noise px",
                     "1-photo mm");
  for (size_t i = 0; i < plan.positions.size(); ++i) {
    const PlanPlacement& p = plan.positions[i];
    out << fmt::format(
        "{:>3} {:>8.0f} {:>7.0f} {:>7.0f}   {:>24} {:>9.1f} {:>9.3f} {:>8.1f} {:>9.3f} {:>10.2f}\n", i + 1,
        p.distance_mm, p.yaw_deg, p.height_mm,
        fmt::format("[{:.0f}, {:.0f}, {:.0f}]", p.position_in_screen_mm.x(), p.position_in_screen_mm.y(),
                    p.position_in_screen_mm.z()),
        p.feature_spacing_camera_px, p.camera_px_per_display_px, p.max_obliquity_deg, p.noise_px,
        p.radius_crb_mm);
  }
  out << fmt::format("\npredicted radius sigma: {:.3f} mm from {} photo(s)", plan.predicted_radius_sigma_mm,
                     plan.positions.size());
  if (options.target_radius_sigma_mm > 0) {
    out << fmt::format(" (target {:.3g} mm: {})", options.target_radius_sigma_mm,
                       plan.target_reached ? "reached" : "NOT reached");
  }
  out << "\n  " << plan.target_note << "\n  budget (u(R), mm):";
  for (const PlanBudgetRow& row : plan.budget)
    out << fmt::format("  {} {}", row.name, Fixed(row.radius_mm, 3));
  out << fmt::format("\n  floor that more photos do not remove: {:.3f} mm\n", plan.radius_sigma_floor_mm);
  if (plan.sigma_by_photos_mm.size() > 1) {
    out << "  sigma by number of photos (mm):";
    for (const auto& [n, sigma] : plan.sigma_by_photos_mm) out << fmt::format(" {}:{}", n, Fixed(sigma, 2));
    out << "\n";
  }
  out << fmt::format("\nverification (tolerance T = {:.3g} display px): {}\n", options.tolerance_display_px,
                     plan.verification_note);
  out << "\nassumptions:\n";
  for (const std::string& a : plan.assumptions) out << "  - " << a << "\n";
  return out.str();
}

std::string PlanChartData(const CapturePlan& plan) {
  // Height 0 only, one block per yaw (ascending), distances ascending; unusable placements as NaN (gaps).
  std::map<double, std::map<double, double>> by_yaw;
  for (const PlanPlacement& p : plan.grid) {
    if (p.height_mm != 0) continue;
    by_yaw[p.yaw_deg][p.distance_mm] = p.usable ? p.radius_crb_mm : kNaN;
  }
  std::ostringstream out;
  out << "# distance_mm yaw_deg single_photo_radius_crb_mm (NaN: placement not usable)\n";
  for (const auto& [yaw, row] : by_yaw) {
    if (yaw < 0) continue;  // mirrored yaws give the same figures
    for (const auto& [d, s] : row)
      out << fmt::format("{} {} {}\n", d, yaw, std::isfinite(s) ? fmt::format("{:.6g}", s) : "NaN");
    out << "\n\n";
  }
  return out.str();
}

std::string PlanChartScript(const CapturePlan& plan, const std::string& data_file) {
  std::vector<double> yaws;
  for (const PlanPlacement& p : plan.grid) {
    if (p.height_mm == 0 && p.yaw_deg >= 0 && std::find(yaws.begin(), yaws.end(), p.yaw_deg) == yaws.end()) {
      yaws.push_back(p.yaw_deg);
    }
  }
  std::sort(yaws.begin(), yaws.end());
  const std::string file = GnuplotString(data_file);
  std::string by_distance;
  for (size_t i = 0; i < yaws.size(); ++i) {
    by_distance += fmt::format("{}{} index {} using 1:3 with linespoints title \"yaw {:g} deg\"",
                               i ? ", " : "", file, i, yaws[i]);
  }
  return fmt::format(
      "set multiplot layout 1,2 title \"single-photo radius sigma at the expected detection noise "
      "(Cramer-Rao, "
      "height 0; gaps: placement not usable)\"\n"
      "set logscale y\nset grid\nset key top left\nset ylabel \"radius sigma (mm)\"\n"
      "set xlabel \"distance from the screen centre (mm)\"\n"
      "plot {}\n"
      "set xlabel \"yaw about the screen centre (deg)\"\n"
      "set cblabel \"distance (mm)\"\n"
      "plot {} using 2:3:1 with points pointtype 7 palette notitle\n"
      "unset multiplot\n",
      by_distance, file);
}

}  // namespace curvecheck
