#include "detect/detect_tags.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <thread>

namespace curvecheck::detect_internal {
namespace {

constexpr int kTagBorderCells = 8;      // tag36h11: outer edge of the black border, in cells
constexpr double kProfileStepPx = 0.5;  // sample spacing along an edge normal
constexpr double kMinEdgePx = 16;       // smaller tags have no clean border profile to fit
// RefineTagCorners: the smoothing's sigma is at most the cell's width over this.
constexpr double kCellPerSigma = 6;
// BorderShiftPx: the cell's width over the edges' 10-90% width below which the border's shift is not measured.
constexpr double kMinCellPerEdgeWidth = 2.5;

struct EdgeCurve {
  Eigen::Vector2d a, u, n;  // start corner, unit direction along the edge, unit outward normal
  double length = 1;
  Eigen::Vector3d coef = Eigen::Vector3d::Zero();  // t = c0 + c1 (s/L) + c2 (s/L)^2 (t along n, s along u)
  double rms = 0;
  int points = 0;

  // Signed offset of p from the curve along n, and its gradient.
  double F(const Eigen::Vector2d& p, Eigen::Vector2d* grad) const {
    const Eigen::Vector2d d = p - a;
    const double s = d.dot(u) / length;
    const double q = coef(0) + coef(1) * s + coef(2) * s * s;
    if (grad) *grad = n - (coef(1) + 2 * coef(2) * s) / length * u;
    return d.dot(n) - q;
  }
};

// Least squares quadratic t(s) through the points, then twice: drop points beyond 3 robust sigmas and refit.
bool FitEdge(const std::vector<Eigen::Vector2d>& st, EdgeCurve& e) {
  std::vector<bool> use(st.size(), true);
  for (int round = 0; round < 3; ++round) {
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d atb = Eigen::Vector3d::Zero();
    int n = 0;
    for (size_t i = 0; i < st.size(); ++i) {
      if (!use[i]) continue;
      const double s = st[i].x() / e.length;
      const Eigen::Vector3d row(1, s, s * s);
      ata += row * row.transpose();
      atb += row * st[i].y();
      ++n;
    }
    if (n < 8) return false;
    e.coef = ata.ldlt().solve(atb);
    std::vector<double> abs_r;
    double sum2 = 0;
    for (size_t i = 0; i < st.size(); ++i) {
      const double s = st[i].x() / e.length;
      const double r = std::abs(st[i].y() - (e.coef(0) + e.coef(1) * s + e.coef(2) * s * s));
      if (use[i]) {
        abs_r.push_back(r);
        sum2 += r * r;
      }
    }
    e.points = n;
    e.rms = std::sqrt(sum2 / n);
    if (round == 2) break;
    std::nth_element(abs_r.begin(), abs_r.begin() + abs_r.size() / 2, abs_r.end());
    const double limit = std::max(3 * 1.4826 * abs_r[abs_r.size() / 2], 0.05);
    for (size_t i = 0; i < st.size(); ++i) {
      const double s = st[i].x() / e.length;
      use[i] = std::abs(st[i].y() - (e.coef(0) + e.coef(1) * s + e.coef(2) * s * s)) <= limit;
    }
  }
  return true;
}

// Where a profile sampled at equal steps crosses `level` going up (rising) or down: the fractional sample index
// of the crossing nearest the profile's steepest step that way (linear between the samples); NaN if none.
double LevelCrossing(const std::vector<double>& v, double level, bool rising) {
  const auto step = [&](size_t j) { return rising ? v[j + 1] - v[j] : v[j] - v[j + 1]; };
  size_t steepest = 0;
  for (size_t j = 1; j + 1 < v.size(); ++j) {
    if (step(j) > step(steepest)) steepest = j;
  }
  const auto distance = [&](size_t j) { return j > steepest ? j - steepest : steepest - j; };
  long best = -1;
  for (size_t j = 0; j + 1 < v.size(); ++j) {
    const bool crosses = rising ? v[j] < level && v[j + 1] >= level : v[j] >= level && v[j + 1] < level;
    if (crosses && (best < 0 || distance(j) < distance(static_cast<size_t>(best)))) best = static_cast<long>(j);
  }
  if (best < 0) return std::nan("");
  const size_t b = static_cast<size_t>(best);
  return static_cast<double>(b) + (level - v[b]) / (v[b + 1] - v[b]);
}

// How far the outer edges' crossings sit inside the tag (px along the outward normals; NaN where it cannot be
// measured): per outer-edge profile beside a white data cell, the inner border edge's crossing on the same normal
// (the white cell inside, the black border outside) at the outer crossing's level, and (c - w) / 2, w the
// crossings' distance and c the cell's width there by the homography of the current corners (tag36h11: the border
// is one cell of eight); the median over the tag, from at least 8 pairs whose cells are 2.5 times the edges' 10-90%
// width or more (median). profile(i, ...) gives the outer profiles: edge index (4 = do not use, -1 =
// no more), s along the edge, t along the normal, its dark and bright levels.
template <typename ProfileAt>
double BorderShiftPx(const cv::Mat& image, const std::array<Eigen::Vector2d, 4>& px,
                     const std::array<EdgeCurve, 4>& edges, ProfileAt profile) {
  constexpr double n = kTagBorderCells;
  const std::array<cv::Point2f, 4> frame{cv::Point2f(0, 0), cv::Point2f(n, 0), cv::Point2f(n, n), cv::Point2f(0, n)};
  std::array<cv::Point2f, 4> img;
  for (int k = 0; k < 4; ++k) img[k] = cv::Point2f(static_cast<float>(px[k].x()), static_cast<float>(px[k].y()));
  const cv::Mat h = cv::getPerspectiveTransform(frame.data(), img.data());
  const auto map = [&](Eigen::Vector2d q) {
    const double x = h.at<double>(0, 0) * q.x() + h.at<double>(0, 1) * q.y() + h.at<double>(0, 2);
    const double y = h.at<double>(1, 0) * q.x() + h.at<double>(1, 1) * q.y() + h.at<double>(1, 2);
    const double w = h.at<double>(2, 0) * q.x() + h.at<double>(2, 1) * q.y() + h.at<double>(2, 2);
    return Eigen::Vector2d(x / w, y / w);
  };
  std::vector<double> shifts, sharpness, values;
  double s = 0, t = 0, dark = 0, bright = 0, rise = 0;
  for (int i = 0;; ++i) {
    const int k = profile(i, &s, &t, &dark, &bright, &rise);
    if (k < 0) break;
    if (k > 3) continue;
    const EdgeCurve& e = edges[static_cast<size_t>(k)];
    // The profile's place in the tag's frame: a fraction f along edge k, the inward unit there.
    const Eigen::Vector2d a(frame[k].x, frame[k].y), b(frame[(k + 1) % 4].x, frame[(k + 1) % 4].y);
    const double f = s / e.length;
    const double cell_along = f * n;  // cells from corner k
    const int index = static_cast<int>(std::floor(cell_along));
    const double within = cell_along - index;
    if (index < 1 || index > kTagBorderCells - 2 || within < 0.3 || within > 0.7) continue;  // a data cell's middle
    const Eigen::Vector2d on = a + f * (b - a), centre(0.5 * n, 0.5 * n);
    Eigen::Vector2d inward = Eigen::Vector2d(-(b - a).y(), (b - a).x()).normalized();
    if (inward.dot(centre - on) < 0) inward = -inward;
    const Eigen::Vector2d p_out = map(on), p_in = map(on + inward), p_cell = map(on + 1.5 * inward),
                          p_next = map(on + 2.5 * inward);
    const double mid = 0.5 * (dark + bright);
    // A white data cell beside the border, and a white one beyond it: a black one there would darken the white
    // cell's side of the line under a wide blur.
    if (!(SampleBilinear(image, p_cell.x(), p_cell.y()) > mid && SampleBilinear(image, p_next.x(), p_next.y()) > mid)) {
      continue;
    }
    const double c = (p_out - p_in).dot(e.n);
    if (!(c >= 4)) continue;
    // The inner edge's profile along the same normal: bright (the white cell) inside, dark (the border) outside.
    const Eigen::Vector2d base = e.a + s * e.u;
    const double half = std::min(0.4 * c, 12.0);
    const int nt = static_cast<int>(std::floor(2 * half / kProfileStepPx)) + 1;
    values.assign(static_cast<size_t>(nt), 0);
    bool ok = true;
    for (int j = 0; j < nt && ok; ++j) {
      const Eigen::Vector2d q = base + (-c - half + j * kProfileStepPx) * e.n;
      values[static_cast<size_t>(j)] = SampleBilinear(image, q.x(), q.y());
      ok = std::isfinite(values[static_cast<size_t>(j)]);
    }
    if (!ok) continue;
    const double in_bright = 0.5 * (values[0] + values[1]);
    const double in_dark = 0.5 * (values[static_cast<size_t>(nt - 1)] + values[static_cast<size_t>(nt - 2)]);
    // The outer crossing's level: the border is a dark line between two white cells, and crossings of one level
    // on a symmetric line lie symmetrically about its middle however much the blur joins its two edges.
    const double in_mid = mid;
    if (!(in_bright > in_mid && in_dark < in_mid)) continue;
    const double at = LevelCrossing(values, in_mid, false);
    if (!std::isfinite(at)) continue;
    const double t_in = -c - half + at * kProfileStepPx;
    shifts.push_back(0.5 * (c - (t - t_in)));
    sharpness.push_back(rise > 0 ? c / rise : 1e9);
  }
  if (shifts.size() < 8) return std::nan("");
  // Where the blur (the optics' and the refinement's smoothing) spans a third of the cell or more, the border's
  // two edges reach the cells beyond them, whose colours differ (a black data cell next to the white one), and
  // the line is no longer symmetric: on an independent tracer's webcam-like photos smoothed against moire (10-90%
  // widths 3.5-4.5 px, cells 6-7 px) the shifts came out -0.1 to -0.5 px against +0.42-0.45 px at widths of 2-2.5
  // px. Not measured there.
  std::nth_element(sharpness.begin(), sharpness.begin() + static_cast<long>(sharpness.size() / 2), sharpness.end());
  if (sharpness[sharpness.size() / 2] < kMinCellPerEdgeWidth) return std::nan("");
  std::nth_element(shifts.begin(), shifts.begin() + shifts.size() / 2, shifts.end());
  return shifts[shifts.size() / 2];
}

// One refinement pass from the current corners; false if any edge cannot be fitted. border_shift_px (if given):
// the outer crossings' shift into the tag measured on this pass (BorderShiftPx; NaN where it cannot be).
bool RefinePass(const cv::Mat& image, std::array<Eigen::Vector2d, 4>& px, double& rms_px, double* border_shift_px) {
  const Eigen::Vector2d centre = (px[0] + px[1] + px[2] + px[3]) / 4;
  double mean_edge = 0, min_edge = 1e18;
  for (int k = 0; k < 4; ++k) {
    const double len = (px[(k + 1) % 4] - px[k]).norm();
    mean_edge += len / 4;
    min_edge = std::min(min_edge, len);
  }
  if (!(min_edge >= kMinEdgePx)) return false;
  const double cell = mean_edge / kTagBorderCells;
  // Half-width of the profile: inside, the black border is one cell wide (data bits beyond it); outside, the
  // white quiet zone is at least one cell.
  const double half = std::clamp(0.6 * cell, 2.0, 12.0);
  const int nt = static_cast<int>(std::floor(2 * half / kProfileStepPx)) + 1;
  // Keep away from the corners, where the other edge's blur enters the profile.
  const double margin = std::max(2.0, 0.15 * cell);

  struct Profile {
    int edge;
    double s, t, contrast, dark, bright, rise;
  };
  std::array<EdgeCurve, 4> edges;
  std::vector<Profile> profiles;
  std::vector<double> values(static_cast<size_t>(nt));
  for (int k = 0; k < 4; ++k) {
    EdgeCurve& e = edges[static_cast<size_t>(k)];
    e.a = px[k];
    e.length = (px[(k + 1) % 4] - px[k]).norm();
    e.u = (px[(k + 1) % 4] - px[k]) / e.length;
    e.n = Eigen::Vector2d(-e.u.y(), e.u.x());
    if (e.n.dot(e.a + 0.5 * e.length * e.u - centre) < 0) e.n = -e.n;
    const int ns = std::clamp(static_cast<int>(e.length - 2 * margin), 8, 200);
    for (int i = 0; i < ns; ++i) {
      const double s = margin + (e.length - 2 * margin) * (i + 0.5) / ns;
      bool ok = true;
      for (int j = 0; j < nt && ok; ++j) {
        const Eigen::Vector2d p = e.a + s * e.u + (-half + j * kProfileStepPx) * e.n;
        values[static_cast<size_t>(j)] = SampleBilinear(image, p.x(), p.y());
        ok = std::isfinite(values[static_cast<size_t>(j)]);
      }
      if (!ok) continue;
      const double dark = 0.5 * (values[0] + values[1]);
      const double bright = 0.5 * (values[static_cast<size_t>(nt - 1)] + values[static_cast<size_t>(nt - 2)]);
      const double mid = 0.5 * (dark + bright);
      if (!(bright > dark)) continue;
      // The 50% crossing nearest to the steepest rise (dark inside, bright outside).
      const double at = LevelCrossing(values, mid, true);
      if (!std::isfinite(at)) continue;
      const double t = -half + at * kProfileStepPx;
      // The edge's 10-90% width (samples between those levels), the blur the border's two edges share.
      int between = 0;
      for (double v : values) between += v > dark + 0.1 * (bright - dark) && v < dark + 0.9 * (bright - dark);
      profiles.push_back({k, s, t, bright - dark, dark, bright, between * kProfileStepPx});
    }
  }
  if (profiles.empty()) return false;
  // Profiles with less than half the tag's typical contrast cross something else (occlusion, glare).
  std::vector<double> contrasts;
  for (const Profile& p : profiles) contrasts.push_back(p.contrast);
  std::nth_element(contrasts.begin(), contrasts.begin() + contrasts.size() / 2, contrasts.end());
  const double min_contrast = 0.5 * contrasts[contrasts.size() / 2];
  // The crossings' shift into the tag (BorderShiftPx): zero where the patch is linear in light.
  if (border_shift_px) {
    *border_shift_px = BorderShiftPx(image, px, edges,
                                     [&](int i, double* s, double* t, double* dark, double* bright, double* rise) {
                                       if (i >= static_cast<int>(profiles.size())) return -1;
                                       const Profile& p = profiles[static_cast<size_t>(i)];
                                       *s = p.s;
                                       *t = p.t;
                                       *dark = p.dark;
                                       *bright = p.bright;
                                       *rise = p.rise;
                                       return p.contrast >= min_contrast ? p.edge : 4;
                                     });
  }
  double sum2 = 0;
  int count = 0;
  for (int k = 0; k < 4; ++k) {
    std::vector<Eigen::Vector2d> st;
    for (const Profile& p : profiles) {
      if (p.edge == k && p.contrast >= min_contrast) st.emplace_back(p.s, p.t);
    }
    EdgeCurve& e = edges[static_cast<size_t>(k)];
    if (!FitEdge(st, e)) return false;
    sum2 += e.rms * e.rms * e.points;
    count += e.points;
  }
  // Corner k joins edge k-1 (from corner k-1) and edge k (from corner k): Newton on both curve equations.
  std::array<Eigen::Vector2d, 4> refined;
  for (int k = 0; k < 4; ++k) {
    const EdgeCurve& e1 = edges[static_cast<size_t>((k + 3) % 4)];
    const EdgeCurve& e2 = edges[static_cast<size_t>(k)];
    Eigen::Vector2d p = px[k];
    for (int it = 0; it < 8; ++it) {
      Eigen::Vector2d g1, g2;
      const Eigen::Vector2d f(e1.F(p, &g1), e2.F(p, &g2));
      Eigen::Matrix2d j;
      j.row(0) = g1.transpose();
      j.row(1) = g2.transpose();
      if (std::abs(j.determinant()) < 1e-6) return false;
      const Eigen::Vector2d step = j.inverse() * f;
      p -= step;
      if (step.norm() < 1e-6) break;
    }
    if (!p.allFinite() || (p - px[k]).norm() > 0.5 * cell) return false;
    refined[static_cast<size_t>(k)] = p;
  }
  px = refined;
  rms_px = std::sqrt(sum2 / std::max(count, 1));
  return true;
}

}  // namespace

double SampleBilinear(const cv::Mat& image, double x, double y) {
  if (!(x >= 0 && y >= 0 && x <= image.cols - 1 && y <= image.rows - 1) || image.cols < 2 || image.rows < 2) {
    return std::nan("");
  }
  const int x0 = std::min(static_cast<int>(x), image.cols - 2), y0 = std::min(static_cast<int>(y), image.rows - 2);
  const double fx = x - x0, fy = y - y0;
  double v00, v01, v10, v11;
  if (image.depth() == CV_32F) {
    const float* r0 = image.ptr<float>(y0);
    const float* r1 = image.ptr<float>(y0 + 1);
    v00 = r0[x0], v01 = r0[x0 + 1], v10 = r1[x0], v11 = r1[x0 + 1];
  } else if (image.depth() == CV_16U) {
    const uint16_t* r0 = image.ptr<uint16_t>(y0);
    const uint16_t* r1 = image.ptr<uint16_t>(y0 + 1);
    v00 = r0[x0], v01 = r0[x0 + 1], v10 = r1[x0], v11 = r1[x0 + 1];
  } else {
    const uint8_t* r0 = image.ptr<uint8_t>(y0);
    const uint8_t* r1 = image.ptr<uint8_t>(y0 + 1);
    v00 = r0[x0], v01 = r0[x0 + 1], v10 = r1[x0], v11 = r1[x0 + 1];
  }
  return (1 - fy) * ((1 - fx) * v00 + fx * v01) + fy * ((1 - fx) * v10 + fx * v11);
}

cv::Mat SmoothedPatch(const cv::Mat& image, cv::Rect roi, double sigma_px, cv::Point* origin, double gamma) {
  roi &= cv::Rect(0, 0, image.cols, image.rows);
  *origin = roi.tl();
  cv::Mat patch;
  image(roi).convertTo(patch, CV_32F);
  if (gamma != 1 && !patch.empty()) {
    // Code values to light, (code / full scale)^gamma, kept on the code values' scale.
    const double full = image.depth() == CV_8U ? 255.0 : image.depth() == CV_16U ? 65535.0 : 1.0;
    cv::max(patch, 0.0, patch);
    patch *= 1.0 / full;
    cv::pow(patch, gamma, patch);
    patch *= full;
  }
  if (sigma_px > 0 && !patch.empty()) cv::GaussianBlur(patch, patch, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REFLECT);
  return patch;
}

std::vector<DetectedTag> RunAprilTag(const cv::Mat& gray8, int decimate, int max_hamming, int threads) {
  const std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> family(tag36h11_create(), tag36h11_destroy);
  const std::unique_ptr<apriltag_detector_t, void (*)(apriltag_detector_t*)> detector(apriltag_detector_create(),
                                                                                      apriltag_detector_destroy);
  apriltag_detector_add_family_bits(detector.get(), family.get(), max_hamming);
  detector->quad_decimate = 1;
  detector->quad_sigma = 0;
  detector->refine_edges = true;
  detector->nthreads = threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  cv::Mat small;
  if (decimate > 1) {
    cv::resize(gray8, small, cv::Size(gray8.cols / decimate, gray8.rows / decimate), 0, 0, cv::INTER_AREA);
  } else {
    small = gray8.clone();
  }
  cv::GaussianBlur(small, small, cv::Size(0, 0), 0.8);
  image_u8_t im{small.cols, small.rows, static_cast<int32_t>(small.step[0]), small.ptr<uint8_t>(0)};
  zarray_t* found = apriltag_detector_detect(detector.get(), &im);
  std::vector<DetectedTag> out;
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(found, i, &det);
    DetectedTag t;
    t.id = det->id;
    t.hamming = det->hamming;
    t.decision_margin = det->decision_margin;
    // AprilTag puts pixel centres at +0.5 (dependencies.md); curvecheck at integers. Pixel i of the shrunk copy
    // averages full-resolution pixels decimate*i .. decimate*i + decimate - 1.
    for (int k = 0; k < 4; ++k) {
      t.px[static_cast<size_t>(k)] =
          decimate * Eigen::Vector2d(det->p[k][0] - 0.5, det->p[k][1] - 0.5) + Eigen::Vector2d::Constant(0.5 * (decimate - 1));
    }
    out.push_back(t);
  }
  apriltag_detections_destroy(found);
  return out;
}

bool RefineTagCorners(const cv::Mat& image, DetectedTag& tag, double sigma_px, double gamma) {
  // The tag's neighbourhood: its corners plus the profile half-width (<= 12 px), the possible corner error and
  // 3 sigma of filter support.
  Eigen::Vector2d lo = tag.px[0], hi = tag.px[0];
  for (const Eigen::Vector2d& p : tag.px) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // The smoothing stays within half the border's width (3 sigma <= a cell / 2): wider, it joins the border's two
  // edges and the data cells beyond, whose colours differ, and moves the edges.
  double mean_edge = 0;
  for (int k = 0; k < 4; ++k) mean_edge += (tag.px[(k + 1) % 4] - tag.px[k]).norm() / 4;
  sigma_px = std::min(sigma_px, mean_edge / kTagBorderCells / kCellPerSigma);
  const int pad = 16 + static_cast<int>(std::ceil(3 * sigma_px));
  const cv::Rect roi(static_cast<int>(std::floor(lo.x())) - pad, static_cast<int>(std::floor(lo.y())) - pad,
                     static_cast<int>(std::ceil(hi.x() - lo.x())) + 2 * pad + 1,
                     static_cast<int>(std::ceil(hi.y() - lo.y())) + 2 * pad + 1);
  cv::Point origin;
  const cv::Mat patch = SmoothedPatch(image, roi, sigma_px, &origin, gamma);
  if (patch.cols < 2 || patch.rows < 2) return false;
  const Eigen::Vector2d shift(origin.x, origin.y);
  std::array<Eigen::Vector2d, 4> px;
  for (int k = 0; k < 4; ++k) px[static_cast<size_t>(k)] = tag.px[static_cast<size_t>(k)] - shift;
  double rms = 0, border_shift = std::nan("");
  for (int pass = 0; pass < 2; ++pass) {
    if (!RefinePass(patch, px, rms, pass == 1 ? &border_shift : nullptr)) return false;
  }
  for (int k = 0; k < 4; ++k) tag.px[static_cast<size_t>(k)] = px[static_cast<size_t>(k)] + shift;
  tag.edge_rms_px = rms;
  tag.border_shift_px = border_shift;
  tag.smoothing_px = sigma_px;
  return true;
}

TagTone MeasureTagTone(const cv::Mat& image, const std::vector<DetectedTag>& tags) {
  TagTone tone;
  // Up to 24 tags, evenly through the list; each refined without smoothing at every exponent of the ladder.
  constexpr size_t kMaxTags = 24;
  const size_t step = std::max<size_t>(1, (tags.size() + kMaxTags - 1) / kMaxTags);
  for (double gamma : {1.0, 1.5, 2.0, 2.5, 3.0}) {
    std::vector<double> shifts;
    for (size_t i = 0; i < tags.size(); i += step) {
      DetectedTag probe = tags[i];
      if (RefineTagCorners(image, probe, 0, gamma) && std::isfinite(probe.border_shift_px)) {
        shifts.push_back(probe.border_shift_px);
      }
    }
    if (shifts.size() < 3) break;
    std::nth_element(shifts.begin(), shifts.begin() + static_cast<long>(shifts.size() / 2), shifts.end());
    tone.ladder.emplace_back(gamma, shifts[shifts.size() / 2]);
    tone.tags = std::max(tone.tags, static_cast<int>(shifts.size()));
    if (tone.ladder.back().second <= 0) break;  // the zero is passed
  }
  if (tone.ladder.empty()) return tone;
  tone.shift_px = tone.ladder.front().second;
  if (tone.ladder.front().second <= 0) {
    tone.gamma = 1;  // no compression of the highlights to undo (a linear photo)
  } else if (tone.ladder.back().second > 0) {
    tone.gamma = tone.ladder.back().first;  // still short at the ladder's top (or where it stopped): its top
  } else {
    const auto& [g0, b0] = tone.ladder[tone.ladder.size() - 2];
    const auto& [g1, b1] = tone.ladder.back();
    tone.gamma = g0 + (g1 - g0) * b0 / (b0 - b1);
  }
  return tone;
}

}  // namespace curvecheck::detect_internal
