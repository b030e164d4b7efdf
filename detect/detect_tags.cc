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

// One refinement pass from the current corners; false if any edge cannot be fitted.
bool RefinePass(const cv::Mat& image, std::array<Eigen::Vector2d, 4>& px, double& rms_px) {
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
    double s, t, contrast;
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
      int steepest = 0;
      for (int j = 1; j + 1 < nt; ++j) {
        if (values[static_cast<size_t>(j + 1)] - values[static_cast<size_t>(j)] >
            values[static_cast<size_t>(steepest + 1)] - values[static_cast<size_t>(steepest)]) {
          steepest = j;
        }
      }
      int best = -1;
      for (int j = 0; j + 1 < nt; ++j) {
        const double v0 = values[static_cast<size_t>(j)], v1 = values[static_cast<size_t>(j + 1)];
        if (v0 < mid && v1 >= mid && (best < 0 || std::abs(j - steepest) < std::abs(best - steepest))) best = j;
      }
      if (best < 0) continue;
      const double v0 = values[static_cast<size_t>(best)], v1 = values[static_cast<size_t>(best + 1)];
      const double t = -half + (best + (mid - v0) / (v1 - v0)) * kProfileStepPx;
      profiles.push_back({k, s, t, bright - dark});
    }
  }
  if (profiles.empty()) return false;
  // Profiles with less than half the tag's typical contrast cross something else (occlusion, glare).
  std::vector<double> contrasts;
  for (const Profile& p : profiles) contrasts.push_back(p.contrast);
  std::nth_element(contrasts.begin(), contrasts.begin() + contrasts.size() / 2, contrasts.end());
  const double min_contrast = 0.5 * contrasts[contrasts.size() / 2];
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

cv::Mat SmoothedPatch(const cv::Mat& image, cv::Rect roi, double sigma_px, cv::Point* origin) {
  roi &= cv::Rect(0, 0, image.cols, image.rows);
  *origin = roi.tl();
  cv::Mat patch;
  image(roi).convertTo(patch, CV_32F);
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

bool RefineTagCorners(const cv::Mat& image, DetectedTag& tag, double sigma_px) {
  // The tag's neighbourhood: its corners plus the profile half-width (<= 12 px), the possible corner error and
  // 3 sigma of filter support.
  Eigen::Vector2d lo = tag.px[0], hi = tag.px[0];
  for (const Eigen::Vector2d& p : tag.px) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const int pad = 16 + static_cast<int>(std::ceil(3 * sigma_px));
  const cv::Rect roi(static_cast<int>(std::floor(lo.x())) - pad, static_cast<int>(std::floor(lo.y())) - pad,
                     static_cast<int>(std::ceil(hi.x() - lo.x())) + 2 * pad + 1,
                     static_cast<int>(std::ceil(hi.y() - lo.y())) + 2 * pad + 1);
  cv::Point origin;
  const cv::Mat patch = SmoothedPatch(image, roi, sigma_px, &origin);
  if (patch.cols < 2 || patch.rows < 2) return false;
  const Eigen::Vector2d shift(origin.x, origin.y);
  std::array<Eigen::Vector2d, 4> px;
  for (int k = 0; k < 4; ++k) px[static_cast<size_t>(k)] = tag.px[static_cast<size_t>(k)] - shift;
  double rms = 0;
  for (int pass = 0; pass < 2; ++pass) {
    if (!RefinePass(patch, px, rms)) return false;
  }
  for (int k = 0; k < 4; ++k) tag.px[static_cast<size_t>(k)] = px[static_cast<size_t>(k)] + shift;
  tag.edge_rms_px = rms;
  return true;
}

}  // namespace curvecheck::detect_internal
