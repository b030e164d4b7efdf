#include "analysis/screenshot_check.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "pattern/feature_id.h"

namespace curvecheck {
namespace {

// Edge samples of one line: position along the sampling axis t (column x or row y, relative to the corner) and the
// edge's coordinate across it (y or x, absolute).
struct EdgeSamples {
  std::vector<double> t, across;
};

// Samples the line across = centre_across + slope * t on both arms. `transposed`: the image is indexed (x, y) as
// (row, col) swapped, i.e. the line is sampled per row and `across` is x. Returns false when an arm has fewer than
// 4 usable samples.
bool SampleLine(const cv::Mat& lin, bool transposed, double c_along, double c_across, double slope, int inner,
                int arm, double half, int only_side, EdgeSamples* out) {
  const int n_along = transposed ? lin.rows : lin.cols, n_across = transposed ? lin.cols : lin.rows;
  auto at = [&](int along, int across) {
    return transposed ? lin.at<double>(along, across) : lin.at<double>(across, along);
  };
  out->t.clear(), out->across.clear();
  const int c = static_cast<int>(std::lround(c_along));
  for (int side : {-1, 1}) {
    if (only_side != 0 && side != only_side) continue;
    int used = 0;
    for (int k = inner; k <= arm; ++k) {
      const int along = c + side * k;
      if (along < 0 || along >= n_along) break;
      const double predicted = c_across + slope * (along - c_along);
      const int j0 = static_cast<int>(std::floor(predicted - half)), j1 = static_cast<int>(std::ceil(predicted + half));
      if (j0 < 0 || j1 >= n_across) break;
      const double top = at(along, j0), bottom = at(along, j1);
      // The segment must reach into both regions: its two end pixels pure and different.
      if (std::abs(top - bottom) < 0.25) continue;
      if (std::abs(at(along, j0 + 1) - top) > 0.02 * std::abs(top - bottom) ||
          std::abs(at(along, j1 - 1) - bottom) > 0.02 * std::abs(top - bottom)) {
        continue;
      }
      double sum = 0;
      for (int j = j0; j <= j1; ++j) sum += (at(along, j) - bottom) / (top - bottom);
      out->t.push_back(along - c_along);
      out->across.push_back(j0 - 0.5 + sum);
      ++used;
    }
    if (used < 4) return false;
  }
  return true;
}

struct Quadratic {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  // across = p0 + p1 t + p2 t^2
  double sigma_p0 = 0;
  double Value(double t) const { return p(0) + t * (p(1) + t * p(2)); }
  double Slope(double t) const { return p(1) + 2 * p(2) * t; }
};

Quadratic FitQuadratic(const EdgeSamples& s) {
  const int n = static_cast<int>(s.t.size());
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    a.row(i) << 1, s.t[i], s.t[i] * s.t[i];
    b(i) = s.across[i];
  }
  Quadratic q;
  q.p = a.colPivHouseholderQr().solve(b);
  const double dof = std::max(1, n - 3);
  const double s2 = (a * q.p - b).squaredNorm() / dof;
  const Eigen::Matrix3d cov = (a.transpose() * a).inverse() * s2;
  q.sigma_p0 = std::sqrt(std::max(0.0, cov(0, 0)));
  return q;
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(pos));
  const double f = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

}  // namespace

namespace {

// Both corner kinds: `one_sided` samples each line only on the side its direction points to (an L-corner's edges).
std::optional<EdgeAreaCorner> RefineCornerByEdgeAreas(const cv::Mat& linear, const Eigen::Vector2d& guess,
                                                      const Eigen::Vector2d& line_a, const Eigen::Vector2d& line_b,
                                                      double max_arm_px, const EdgeAreaOptions& o, bool one_sided) {
  if (linear.type() != CV_64F || linear.channels() != 1) {
    throw Error("RefineXCornerByEdgeAreas", "the image must be CV_64F, one channel (linear light)");
  }
  if (line_a.norm() == 0 || line_b.norm() == 0) return std::nullopt;
  // The more horizontal line is sampled per column (y of x), the other per row (x of y).
  Eigen::Vector2d h = line_a, v = line_b;
  if (std::abs(h.x()) * std::abs(v.y()) < std::abs(h.y()) * std::abs(v.x())) std::swap(h, v);
  if (std::abs(h.x()) < 1e-9 || std::abs(v.y()) < 1e-9) return std::nullopt;
  const double cos_angle = std::abs(h.normalized().dot(v.normalized()));
  if (cos_angle > std::cos(30 * std::numbers::pi / 180)) return std::nullopt;
  double slope_h = h.y() / h.x(), slope_v = v.x() / v.y();  // dy/dx of the row line, dx/dy of the column line
  const int arm = std::min(o.arm_px, static_cast<int>(std::floor(max_arm_px)));
  // The other line must stay out of a segment: at `inner` px along one line, the segment's half-length times the
  // other line's slope plus a pixel for the box filter.
  const int inner = std::max(o.inner_px, static_cast<int>(std::ceil((o.half_segment_px + 1) *
                                                                      std::max(std::abs(slope_h), std::abs(slope_v)))) + 2);
  if (arm < inner + 3) return std::nullopt;
  Eigen::Vector2d c = guess;
  EdgeAreaCorner out;
  for (int round = 0; round < o.rounds; ++round) {
    EdgeSamples sh, sv;
    const int side_h = one_sided ? (h.x() > 0 ? 1 : -1) : 0, side_v = one_sided ? (v.y() > 0 ? 1 : -1) : 0;
    if (!SampleLine(linear, false, c.x(), c.y(), slope_h, inner, arm, o.half_segment_px, side_h, &sh)) {
      return std::nullopt;
    }
    if (!SampleLine(linear, true, c.y(), c.x(), slope_v, inner, arm, o.half_segment_px, side_v, &sv)) {
      return std::nullopt;
    }
    const Quadratic qh = FitQuadratic(sh), qv = FitQuadratic(sv);
    // Intersection: y = qh(x - cx), x = qv(y - cy); fixed point (|slope_h slope_v| < 1 for lines 30 deg apart).
    Eigen::Vector2d p = c;
    for (int i = 0; i < 50; ++i) {
      const double y = qh.Value(p.x() - c.x());
      const double x = qv.Value(y - c.y());
      const bool done = std::abs(x - p.x()) < 1e-12 && std::abs(y - p.y()) < 1e-12;
      p = {x, y};
      if (done) break;
    }
    if (!p.allFinite() || (p - guess).norm() > 3) return std::nullopt;
    slope_h = qh.Slope(p.x() - c.x()), slope_v = qv.Slope(p.y() - c.y());
    // Each curve's offset uncertainty moves the corner across that curve; for lines near 90 deg the two add.
    out.sigma_px = std::hypot(qh.sigma_p0, qv.sigma_p0) / std::sqrt(std::max(1e-6, 1 - cos_angle * cos_angle));
    out.samples = static_cast<int>(sh.t.size() + sv.t.size());
    c = p;
  }
  out.px = c;
  return out;
}

}  // namespace

std::optional<EdgeAreaCorner> RefineXCornerByEdgeAreas(const cv::Mat& linear, const Eigen::Vector2d& guess,
                                                       const Eigen::Vector2d& line_a, const Eigen::Vector2d& line_b,
                                                       double max_arm_px, const EdgeAreaOptions& o) {
  return RefineCornerByEdgeAreas(linear, guess, line_a, line_b, max_arm_px, o, false);
}

std::optional<EdgeAreaCorner> RefineLCornerByEdgeAreas(const cv::Mat& linear, const Eigen::Vector2d& guess,
                                                       const Eigen::Vector2d& toward_a, const Eigen::Vector2d& toward_b,
                                                       double max_arm_px, const EdgeAreaOptions& o) {
  return RefineCornerByEdgeAreas(linear, guess, toward_a, toward_b, max_arm_px, o, true);
}

void ScreenshotCheckOptions::Check(const std::string& where) const {
  RequireInRange(where, "tolerance_px", tolerance_px, 1e-6, 1e6, "give a positive tolerance in display px");
  RequireInRange(where, "max_scale_deviation", max_scale_deviation, 0, 1, "give a fraction such as 0.01");
  RequireInRange(where, "max_offset_px", max_offset_px, 0, 1e6, "give px");
  RequireInRange(where, "max_explained_fraction", max_explained_fraction, 0, 1, "give a fraction such as 0.2");
  if (gamma) RequireInRange(where, "gamma", *gamma, 0.1, 10, "give a display gamma such as 2.2");
  RequireInRange(where, "corner_floor_px", corner_floor_px, 0, 10, "give px");
  RequireInRange(where, "tag_corner_floor_px", tag_corner_floor_px, 0, 10, "give px");
  RequireInRange(where, "detector_floor_px", detector_floor_px, 0, 10, "give px");
  detect.Check(where);
}

const char* ScreenshotRefusalName(ScreenshotRefusal r) {
  switch (r) {
    case ScreenshotRefusal::kNone: return "";
    case ScreenshotRefusal::kWrongSize: return "wrong_size";
    case ScreenshotRefusal::kNotFound: return "pattern_not_found";
    case ScreenshotRefusal::kScaled: return "scaled";
    case ScreenshotRefusal::kShifted: return "shifted";
  }
  return "";
}

ScreenshotCheck CheckScreenshot(const cv::Mat& image, const PatternFile& pattern, const ScreenshotCheckOptions& o) {
  o.Check("check-screenshot options");
  if (image.type() != CV_8UC1) throw Error("screenshot", "the image must be 8-bit gray (ReadPhotoGray)");
  ScreenshotCheck out;
  out.tolerance_px = o.tolerance_px;
  const int nx = pattern.monitor.width_px, ny = pattern.monitor.height_px;
  for (const Feature& f : pattern.features) out.pattern_features += f.visible ? 1 : 0;
  if (image.cols != nx || image.rows != ny) {
    out.refusal = ScreenshotRefusal::kWrongSize;
    const double sx = static_cast<double>(image.cols) / nx, sy = static_cast<double>(image.rows) / ny;
    out.reason = fmt::format(
        "the capture is {} x {} px but the display of pattern.json ({}) is {} x {} px: {}", image.cols, image.rows,
        pattern.monitor.name, nx, ny,
        std::abs(sx - sy) < 0.01 * std::max(sx, sy)
            ? fmt::format("a capture scaled by {:.4g} (display scaling, a resized window or a downscaled screenshot)", sx)
            : std::string("a crop, a window's client area or another monitor's capture"));
    return out;
  }
  // Gamma for the edge areas: what the render encoded with, else the common display gamma.
  out.gamma = o.gamma.value_or(2.2);
  if (!o.gamma && pattern.raw.contains("render") && pattern.raw["render"].contains("display_gamma") &&
      pattern.raw["render"]["display_gamma"].is_number()) {
    out.gamma = pattern.raw["render"]["display_gamma"].get<double>();
  }

  const Detection det = DetectFeatures(image, pattern, o.detect);
  out.detector = det.detector;
  out.notes = det.notes;
  if (!det.failure.empty() || det.features.empty()) {
    out.refusal = ScreenshotRefusal::kNotFound;
    out.reason = det.failure.empty() ? "no feature of pattern.json found" : det.failure;
    return out;
  }
  std::map<std::string, const Feature*> by_id;
  for (const Feature& f : pattern.features) by_id[f.id] = &f;

  // Similarity detected <- exact on the detector's positions (Umeyama, with scale).
  std::vector<const DetectedFeature*> usable;
  for (const DetectedFeature& d : det.features) {
    const Feature* f = by_id.at(d.id);
    if (f->display_px) usable.push_back(&d);
  }
  if (usable.size() >= 3) {
    // Dynamic sizes: GCC 12 warns falsely (stringop-overread) inside umeyama on fixed 2-row matrices.
    Eigen::MatrixXd src(2, usable.size()), dst(2, usable.size());
    for (size_t i = 0; i < usable.size(); ++i) {
      src.col(static_cast<Eigen::Index>(i)) = *by_id.at(usable[i]->id)->display_px;
      dst.col(static_cast<Eigen::Index>(i)) = usable[i]->px;
    }
    const Eigen::MatrixXd t = Eigen::umeyama(src, dst, true);
    const Eigen::Matrix2d sr = t.topLeftCorner(2, 2);
    out.similarity.scale = std::sqrt(std::abs(sr.determinant()));
    out.similarity.rotation_deg = std::atan2(sr(1, 0), sr(0, 0)) * 180 / std::numbers::pi;
    const Eigen::Vector2d centre(0.5 * (nx - 1), 0.5 * (ny - 1));
    out.similarity.offset_at_centre_px = sr * centre + Eigen::Vector2d(t(0, 2), t(1, 2)) - centre;
    double raw2 = 0, resid2 = 0;
    for (Eigen::Index i = 0; i < src.cols(); ++i) {
      const Eigen::Vector2d e = dst.col(i) - src.col(i);
      const Eigen::Vector2d r = dst.col(i) - (sr * src.col(i) + Eigen::Vector2d(t(0, 2), t(1, 2)));
      raw2 += e.squaredNorm(), resid2 += r.squaredNorm();
    }
    out.similarity.raw_rms_px = std::sqrt(raw2 / static_cast<double>(src.cols()));
    out.similarity.residual_rms_px = std::sqrt(resid2 / static_cast<double>(src.cols()));
    const SimilarityFit& s = out.similarity;
    // Refused only when the similarity explains the errors: a letterbox or a crop moves every feature by one
    // scale and offset, a correction's error is not one (`none` on the 49" 1000R from 1.5 m: scale 1.020 but
    // residual 11.0 px of 25.3 px raw rms; a letterboxed exact render leaves ~0 px).
    const bool uniform = s.residual_rms_px < o.max_explained_fraction * s.raw_rms_px;
    if (uniform && std::abs(s.scale - 1) > o.max_scale_deviation) {
      out.refusal = ScreenshotRefusal::kScaled;
      out.reason = fmt::format(
          "the pattern appears scaled by {:.4f} as a whole (a similarity fitted to {} features leaves {:.2f} of {:.2f} "
          "px rms; at most a scale of {:g} allowed): a letterbox, a scaled window or display scaling, not a correction "
          "error",
          s.scale, usable.size(), s.residual_rms_px, s.raw_rms_px, 1 + o.max_scale_deviation);
      return out;
    }
    if (uniform && s.offset_at_centre_px.norm() > o.max_offset_px) {
      out.refusal = ScreenshotRefusal::kShifted;
      out.reason = fmt::format(
          "the pattern appears shifted by ({:.1f}, {:.1f}) px as a whole (a similarity fitted to {} features leaves "
          "{:.2f} of {:.2f} px rms; at most {:g} px allowed): a crop, a window's title bar or borders, or a letterbox, "
          "not a correction error",
          s.offset_at_centre_px.x(), s.offset_at_centre_px.y(), usable.size(), s.residual_rms_px, s.raw_rms_px,
          o.max_offset_px);
      return out;
    }
  }

  // Linear light for the edge areas.
  cv::Mat linear;
  image.convertTo(linear, CV_64F, 1.0 / 255);
  cv::pow(linear, out.gamma, linear);
  // Board geometry (checkerboard and both): inner corners per row.
  int per_row = 0;
  if (pattern.raw.contains("pattern") && pattern.raw["pattern"].contains("cols") &&
      pattern.raw["pattern"]["cols"].is_number_integer()) {
    per_row = pattern.raw["pattern"]["cols"].get<int>() - 1;
  }
  std::map<std::string, Eigen::Vector2d> detected_at;
  for (const DetectedFeature& d : det.features) detected_at[d.id] = d.px;
  int refined = 0, kept = 0;
  for (const DetectedFeature* d : usable) {
    const Feature& f = *by_id.at(d->id);
    ScreenshotFeature sf;
    sf.id = d->id;
    sf.exact_px = *f.display_px;
    sf.detected_px = d->px;
    sf.refinement = det.detector;
    sf.sigma_px = o.detector_floor_px;
    const int k = static_cast<int>(CornerIndexOfId(d->id).value_or(-1));
    const size_t dot = d->id.rfind('.');
    if (d->id[0] == 't' && dot != std::string::npos) {
      // Tag corner t<id>.<j>: the black border's two sides run toward corners j + 1 and j + 3 (mod 4).
      const int j = d->id[dot + 1] - '0';
      const std::string tag = d->id.substr(0, dot + 1);
      const auto a = by_id.find(tag + std::to_string((j + 1) % 4)), b = by_id.find(tag + std::to_string((j + 3) % 4));
      if (a != by_id.end() && b != by_id.end() && a->second->display_px && b->second->display_px) {
        const Eigen::Vector2d ta = *a->second->display_px - sf.exact_px, tb = *b->second->display_px - sf.exact_px;
        if (const auto c = RefineLCornerByEdgeAreas(linear, d->px, ta, tb, 0.8 * std::min(ta.norm(), tb.norm()),
                                                    o.edges)) {
          sf.detected_px = c->px;
          sf.sigma_px = std::hypot(c->sigma_px, o.tag_corner_floor_px);
          sf.refinement = "edge-areas";
          ++refined;
        } else {
          ++kept;
        }
      }
    } else if (k >= 0 && per_row > 0) {
      // The two lines' directions and the arm limit from the neighbours' exact positions (directions only: the
      // measurement never uses the exact position itself).
      auto exact_of = [&](int kk) -> std::optional<Eigen::Vector2d> {
        const auto it = by_id.find(fmt::format("c{}", kk));
        if (it == by_id.end() || !it->second->display_px) return std::nullopt;
        return *it->second->display_px;
      };
      const int col = k % per_row;
      Eigen::Vector2d row_dir = Eigen::Vector2d::Zero(), col_dir = Eigen::Vector2d::Zero();
      double nearest = 1e300;
      for (int s : {-1, 1}) {
        if (col + s >= 0 && col + s < per_row) {
          if (auto e = exact_of(k + s)) row_dir += s * (*e - sf.exact_px), nearest = std::min(nearest, (*e - sf.exact_px).norm());
        }
        if (auto e = exact_of(k + s * per_row)) {
          col_dir += s * (*e - sf.exact_px), nearest = std::min(nearest, (*e - sf.exact_px).norm());
        }
      }
      if (const auto c = RefineXCornerByEdgeAreas(linear, d->px, row_dir, col_dir, 0.45 * nearest, o.edges)) {
        sf.detected_px = c->px;
        sf.sigma_px = std::hypot(c->sigma_px, o.corner_floor_px);
        sf.refinement = "edge-areas";
        ++refined;
      } else {
        ++kept;
      }
    }
    out.features.push_back(sf);
  }
  if (kept > 0) {
    out.notes.push_back(fmt::format("{} corners kept the detector's position (edge areas could not be sampled)", kept));
  }
  if (refined > 0) out.notes.push_back(fmt::format("{} corners measured by edge areas", refined));

  std::vector<double> e;
  double sum2 = 0;
  size_t worst = 0;
  for (size_t i = 0; i < out.features.size(); ++i) {
    const double n = out.features[i].Error().norm();
    e.push_back(n);
    sum2 += n * n;
    if (n > e[worst]) worst = i;
  }
  out.rms_px = e.empty() ? 0 : std::sqrt(sum2 / static_cast<double>(e.size()));
  out.p95_px = Percentile(e, 0.95);
  out.max_px = e.empty() ? 0 : e[worst];
  // U (k = 2) of the figure the tolerance applies to: the worst feature's |error|, whose standard uncertainty is
  // its per-axis sigma (the norm of a 2D error with per-axis sigma s has a standard uncertainty of about s).
  out.expanded_uncertainty_px = e.empty() ? 0 : 2 * out.features[worst].sigma_px;
  const double t = o.tolerance_px, u = out.expanded_uncertainty_px;
  out.verdict = out.max_px + u <= t ? "pass" : out.max_px - u > t ? "fail" : "inconclusive";
  return out;
}

nlohmann::json ScreenshotCheckToJson(const ScreenshotCheck& c, const PatternFile& pattern) {
  nlohmann::json j;
  j["format"] = "curvecheck.screenshot/1";
  j["display_px"] = {pattern.monitor.width_px, pattern.monitor.height_px};
  j["pattern_method"] = pattern.method;
  j["detector"] = c.detector;
  j["gamma"] = c.gamma;
  j["features_detected"] = c.features.size();
  j["features_visible_in_pattern"] = c.pattern_features;
  j["rms_px"] = c.rms_px;
  j["p95_px"] = c.p95_px;
  j["max_px"] = c.max_px;
  j["tolerance_px"] = c.tolerance_px;
  j["expanded_uncertainty_px"] = c.expanded_uncertainty_px;
  j["test_uncertainty_ratio"] = c.expanded_uncertainty_px > 0 ? nlohmann::json(c.tolerance_px / c.expanded_uncertainty_px)
                                                              : nlohmann::json(nullptr);
  j["verdict"] = c.verdict;
  j["decision_rule"] =
      "e = max_px, U = expanded uncertainty (k = 2) of the worst feature's position; pass if e + U <= tolerance, fail "
      "if e - U > tolerance, else inconclusive (ISO 14253-1 guard band; shared/design/metrology.md section 2)";
  j["similarity"] = {{"scale", c.similarity.scale},
                     {"rotation_deg", c.similarity.rotation_deg},
                     {"offset_at_centre_px", {c.similarity.offset_at_centre_px.x(), c.similarity.offset_at_centre_px.y()}},
                     {"raw_rms_px", c.similarity.raw_rms_px},
                     {"residual_rms_px", c.similarity.residual_rms_px}};
  j["notes"] = c.notes;
  nlohmann::json features = nlohmann::json::array();
  for (const ScreenshotFeature& f : c.features) {
    const Eigen::Vector2d e = f.Error();
    features.push_back({{"id", f.id},
                        {"detected_px", {f.detected_px.x(), f.detected_px.y()}},
                        {"exact_px", {f.exact_px.x(), f.exact_px.y()}},
                        {"error_px", {e.x(), e.y()}},
                        {"sigma_px", f.sigma_px},
                        {"refinement", f.refinement}});
  }
  j["features"] = features;
  return j;
}

GnuplotChart ScreenshotErrorMap(const ScreenshotCheck& c, const PatternFile& pattern, double magnify) {
  GnuplotChart chart;
  chart.data_name = "errors.dat";
  std::ostringstream data;
  data << "# exact_x exact_y dx dy |error| (display px)\n";
  for (const ScreenshotFeature& f : c.features) {
    const Eigen::Vector2d e = f.Error();
    data << fmt::format("{:.4f} {:.4f} {:.6f} {:.6f} {:.6f}\n", f.exact_px.x(), f.exact_px.y(), e.x(), e.y(), e.norm());
  }
  chart.data = data.str();
  const int nx = pattern.monitor.width_px, ny = pattern.monitor.height_px;
  chart.script = fmt::format(
      "set title \"check-screenshot: error per feature over the display ({} x {} px); max {:.4f} px, rms {:.4f} px; "
      "vectors x {:g}\"\n"
      "set xrange [-0.5:{}]\nset yrange [{}:-0.5]\nset size ratio -1\nset xlabel \"display x (px)\"\n"
      "set ylabel \"display y (px)\"\nset cblabel \"|error| (display px)\"\nset palette defined (0 '#440154', 0.5 '#21918c', 1 '#fde725')\n"
      "set object 1 rectangle from -0.5,-0.5 to {},{} fillstyle empty border lc rgb \"#808080\"\n"
      "plot \"{}\" using 1:2:($3*{:g}):($4*{:g}) with vectors lc rgb \"#d62728\" notitle, \\\n"
      "     \"{}\" using 1:2:5 with points pt 7 ps 1.5 lc palette notitle\n",
      nx, ny, c.max_px, c.rms_px, magnify, nx - 0.5, ny - 0.5, nx - 0.5, ny - 0.5, chart.data_name, magnify, magnify,
      chart.data_name);
  return chart;
}

}  // namespace curvecheck
