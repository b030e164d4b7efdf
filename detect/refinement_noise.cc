// The random part of the refined corners' error (detect.h RefinementNoise; detect_board.h MeasureSquareNoise,
// MeasureRefinementNoise).
#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/stats.h"
#include "detect/detect_board.h"

namespace curvecheck::detect_internal {
namespace {

// Distance from c to the line through a and b.
double LineDistance(cv::Point2d c, cv::Point2d a, cv::Point2d b) {
  const cv::Point2d d = b - a;
  const double n = cv::norm(d);
  return n > 0 ? std::abs(d.x * (c.y - a.y) - d.y * (c.x - a.x)) / n : 0;
}

// The noise variance at relative brightness w (0 black, 1 white) from its values on black and white. Rising
// (vw >= vb: a linear sensor's shot and read noise, var = a L + c): linear in w, exact there. Falling (vb > vw: a
// tone curve's steep toe amplifies the dark noise, var ~ (a L + c) T'(L)^2, which falls fastest near black; the
// synthetic webcam chain: 3.9 DN on black, 1.1 on white, 1.4 at mid-gray): vw above a tenth of the way from black,
// the falling curve's lower end, so that the drawn noise does not exceed the photo's at the edges, where the
// corners are located (linear interpolation there drew it twice the photo's and the response 1.6 x the corners'
// random error).
double VarianceAt(double w, double vb, double vw) {
  if (vw >= vb) return vb + (vw - vb) * w;
  return w >= 0.1 ? vw : vb + (vw - vb) * (w / 0.1);
}

struct Interior {
  double mean = 0, ss = 0, lag_products = 0, lag_squares = 0, lag_correction = 0;
  int n = 0;
};

}  // namespace

RefinementNoise MeasureSquareNoise(const cv::Mat& photo, const CornerGrid& g) {
  RefinementNoise out;
  if (photo.empty() || photo.channels() != 1 || g.width < 2 || g.height < 2) return out;
  const cv::Mat& image = photo;
  std::vector<Interior> interiors;
  const auto at = [&](int i, int j) { return g.px[static_cast<size_t>(j * g.width + i)]; };
  for (int j = 0; j + 1 < g.height; ++j) {
    for (int i = 0; i + 1 < g.width; ++i) {
      const cv::Point2d p00 = at(i, j), p10 = at(i + 1, j), p01 = at(i, j + 1), p11 = at(i + 1, j + 1);
      const cv::Point2d c = 0.25 * (p00 + p10 + p01 + p11);
      const double d = std::min({LineDistance(c, p00, p10), LineDistance(c, p10, p11), LineDistance(c, p11, p01),
                                 LineDistance(c, p01, p00)});
      const int h = std::min(8, static_cast<int>(std::floor((d - 1.5) / std::sqrt(2.0))));
      if (h < 1) continue;
      const int cx = static_cast<int>(std::lround(c.x)), cy = static_cast<int>(std::lround(c.y));
      if (cx - h < 0 || cy - h < 0 || cx + h >= image.cols || cy + h >= image.rows) continue;
      cv::Mat patch;
      image(cv::Rect(cx - h, cy - h, 2 * h + 1, 2 * h + 1)).convertTo(patch, CV_64F);
      Interior in;
      in.n = patch.rows * patch.cols;
      in.mean = cv::mean(patch)[0];
      for (int y = 0; y < patch.rows; ++y) {
        for (int x = 0; x < patch.cols; ++x) {
          const double r = patch.at<double>(y, x) - in.mean;
          in.ss += r * r;
          if (x + 1 < patch.cols) {
            in.lag_products += r * (patch.at<double>(y, x + 1) - in.mean);
            in.lag_squares += 0.5 * (r * r + std::pow(patch.at<double>(y, x + 1) - in.mean, 2));
          }
          if (y + 1 < patch.rows) {
            in.lag_products += r * (patch.at<double>(y + 1, x) - in.mean);
            in.lag_squares += 0.5 * (r * r + std::pow(patch.at<double>(y + 1, x) - in.mean, 2));
          }
        }
      }
      in.lag_correction = 1.0 / (in.n - 1);
      interiors.push_back(in);
    }
  }
  if (interiors.size() < 16) return out;
  std::vector<double> means;
  for (const Interior& in : interiors) means.push_back(in.mean);
  std::sort(means.begin(), means.end());
  const double lo = means[means.size() / 10], hi = means[means.size() - 1 - means.size() / 10];
  const double mid = 0.5 * (lo + hi);
  double lag_products = 0, lag_squares = 0, lag_correction = 0, lag_weight = 0;
  for (int colour = 0; colour < 2; ++colour) {
    std::vector<const Interior*> of;
    for (const Interior& in : interiors) {
      if ((in.mean > mid) == (colour == 1)) of.push_back(&in);
    }
    std::vector<double> vars;
    for (const Interior* in : of) vars.push_back(in->ss / (in->n - 1));
    if (vars.size() < 8) return out;
    const double limit = 3 * Median(vars);
    double ss = 0, dof = 0, level = 0;
    int used = 0;
    for (const Interior* in : of) {
      if (in->ss / (in->n - 1) > limit) continue;
      ss += in->ss;
      dof += in->n - 1;
      level += in->mean;
      ++used;
      lag_products += in->lag_products;
      lag_squares += in->lag_squares;
      lag_correction += in->lag_correction * in->lag_squares;
      lag_weight += in->lag_squares;
    }
    if (used < 8 || dof <= 0) return out;
    (colour == 0 ? out.black_sd : out.white_sd) = std::sqrt(ss / dof);
    (colour == 0 ? out.black_level : out.white_level) = level / used;
    (colour == 0 ? out.black_patches : out.white_patches) = used;
  }
  if (!(out.white_level > out.black_level)) return out;
  out.correlation_lag1 =
      lag_squares > 0 ? std::clamp(lag_products / lag_squares + lag_correction / lag_weight, 0.0, 0.99) : 0;
  out.measured = true;
  return out;
}

void MeasureRefinementNoise(const cv::Mat& photo, const CornerGrid& refined, double sigma_px,
                            int draws, uint64_t seed, RefinementNoise& noise) {
  noise.response_px = 0;
  noise.corners = 0;
  noise.draws = 0;
  if (!noise.measured || refined.px.empty() || draws < 1) return;
  const CornerGrid& start = refined;
  // At most kMaxCorners corners, evenly through the grid (the response is a mean over corners: 120 corners and
  // four draws give it to about 2.5%); the noise is drawn only where their refinement reads: the half-window
  // (RefinementHalfWindowPx, as RefineXCorners), 4 px and the smoothing's 3 sigma
  // (detect_board.cc RefineXCorner).
  constexpr size_t kMaxCorners = 120;
  const size_t step = std::max<size_t>(1, (start.px.size() + kMaxCorners - 1) / kMaxCorners);
  std::vector<cv::Rect> reads;
  std::vector<std::pair<cv::Point2d, int>> chosen;  // position, half-window
  for (size_t idx = 0; idx < start.px.size(); idx += step) {
    const int i = static_cast<int>(idx) % start.width, j = static_cast<int>(idx) / start.width;
    const cv::Point2d p = start.px[idx];
    const int half = RefinementHalfWindowPx(start.px, start.width, start.height, i, j);
    const int r = half + 6 + static_cast<int>(std::ceil(3 * sigma_px));
    const cv::Rect roi =
        cv::Rect(static_cast<int>(std::floor(p.x)) - r, static_cast<int>(std::floor(p.y)) - r, 2 * r + 2, 2 * r + 2) &
        cv::Rect(0, 0, photo.cols, photo.rows);
    if (roi.area() == 0) continue;
    reads.push_back(roi);
    chosen.emplace_back(p, half);
  }
  // Per pixel standard deviation there, by the brightness (the photo smoothed by 1 px).
  const double vb = noise.black_sd * noise.black_sd;
  const double vw = noise.white_sd * noise.white_sd;
  // Each corner's region of the photo, as float (the photo is read there only).
  std::vector<cv::Mat> sds, bases;
  for (const cv::Rect& roi : reads) {
    bases.emplace_back();
    photo(roi).convertTo(bases.back(), CV_32F);
    cv::Mat bright;
    cv::GaussianBlur(bases.back(), bright, cv::Size(0, 0), 1.0, 1.0, cv::BORDER_REFLECT);
    cv::Mat sd(roi.size(), CV_32F);
    for (int y = 0; y < sd.rows; ++y) {
      for (int x = 0; x < sd.cols; ++x) {
        const double w = std::clamp(
            (bright.at<float>(y, x) - noise.black_level) / (noise.white_level - noise.black_level), 0.0, 1.0);
        sd.at<float>(y, x) = static_cast<float>(std::sqrt(std::max(0.0, VarianceAt(w, vb, vw))));
      }
    }
    sds.push_back(sd);
  }
  // Adjacent-pixel correlation rho of a Gaussian-filtered white noise: exp(-1 / (4 s^2)); the filtered noise
  // divided by its standard deviation, the kernel's sum of squares (per axis, squared).
  const double rho = noise.correlation_lag1;
  const double s = rho >= 0.05 ? std::min(3.0, 1.0 / (2.0 * std::sqrt(-std::log(rho)))) : 0.0;
  const int ksize = s > 0 ? (static_cast<int>(std::lround(s * 8 + 1)) | 1) : 1;
  double gain = 1;
  if (s > 0) {
    const cv::Mat k = cv::getGaussianKernel(ksize, s, CV_64F);
    gain = 1 / k.dot(k);
  }
  const int margin = ksize / 2 + 1;
  cv::RNG rng(seed);
  double sum2 = 0, sum4 = 0;  // per corner-draw q = |displacement|^2 / 2: sums of q and q^2
  long count = 0;
  // Each draw: per corner, its region plus noise, and the corner refined on it (in the region's coordinates).
  for (int d = 0; d < draws; ++d) {
    for (size_t k = 0; k < reads.size(); ++k) {
      const cv::Rect& roi = reads[k];
      cv::Mat white(roi.height + 2 * margin, roi.width + 2 * margin, CV_32F);
      rng.fill(white, cv::RNG::NORMAL, 0.0, 1.0);
      if (s > 0) {
        cv::GaussianBlur(white, white, cv::Size(ksize, ksize), s, s, cv::BORDER_REFLECT);
        white *= gain;
      }
      const cv::Mat noisy = bases[k] + white(cv::Rect(margin, margin, roi.width, roi.height)).mul(sds[k]);
      const auto& [p, half] = chosen[k];
      const cv::Point2d at(roi.x, roi.y);
      const cv::Point2d delta = RefineXCorner(noisy, sigma_px, p - at, half) + at - p;
      const double q = 0.5 * delta.dot(delta);
      sum2 += q;
      sum4 += q * q;
      ++count;
    }
  }
  noise.corners = static_cast<int>(chosen.size());
  noise.draws = draws;
  if (count == 0) return;
  const double n = static_cast<double>(count), mean = sum2 / n;
  noise.response_px = std::sqrt(mean);
  // The standard error of the mean square from the corner-draws' spread (x and y of one draw together: they may
  // be correlated), over 2 r (d r = d r^2 / 2 r).
  const double var = count > 1 ? std::max(0.0, (sum4 - n * mean * mean) / (n - 1)) : mean * mean * 2;
  noise.response_u_px = mean > 0 ? std::sqrt(var / n) / (2 * noise.response_px) : 0;
}

}  // namespace curvecheck::detect_internal
