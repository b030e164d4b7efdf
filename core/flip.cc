#include "core/flip.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"

namespace curvecheck {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Linear sRGB -> XYZ from the sRGB primaries and the D65 white (chromaticities of IEC 61966-2-1): the columns
// are the primaries' XYZ at Y = 1, scaled so that RGB (1, 1, 1) is the white point with Y = 1.
struct ColourSpace {
  Eigen::Matrix3d xyz_from_rgb, rgb_from_xyz;
  Eigen::Vector3d white;  // Xn, Yn = 1, Zn

  ColourSpace() {
    auto xyz = [](double x, double y) { return Eigen::Vector3d(x / y, 1.0, (1.0 - x - y) / y); };
    Eigen::Matrix3d primaries;
    primaries << xyz(0.64, 0.33), xyz(0.30, 0.60), xyz(0.15, 0.06);
    white = xyz(0.3127, 0.3290);
    const Eigen::Vector3d scale = primaries.inverse() * white;
    xyz_from_rgb = primaries * scale.asDiagonal();
    rgb_from_xyz = xyz_from_rgb.inverse();
  }
};
const ColourSpace& Space() {
  static const ColourSpace space;
  return space;
}

double SrgbToLinear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

// CIELAB's companding function f(t) (CIE 15), applied to X/Xn, Y/Yn, Z/Zn.
double LabF(double t) {
  constexpr double d = 6.0 / 29.0;
  return t > d * d * d ? std::cbrt(t) : t / (3 * d * d) + 4.0 / 29.0;
}

// Hunt-adjusted CIELAB (L, a L/100, b L/100) of a linear RGB colour.
Eigen::Vector3d HuntLab(const Eigen::Vector3d& rgb) {
  const ColourSpace& s = Space();
  const Eigen::Vector3d n = (s.xyz_from_rgb * rgb).cwiseQuotient(s.white);
  const double fx = LabF(n.x()), fy = LabF(n.y()), fz = LabF(n.z());
  const double L = 116 * fy - 16;
  return {L, 0.01 * L * 500 * (fx - fy), 0.01 * L * 200 * (fy - fz)};
}

double HyAB(const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
  return std::abs(p.x() - q.x()) + std::hypot(p.y() - q.y(), p.z() - q.z());
}

// The image in the opponent space YyCxCz (linear in XYZ): Yy = 116 Y/Yn - 16, Cx = 500 (X/Xn - Y/Yn),
// Cz = 200 (Y/Yn - Z/Zn). Grey images have Cx = Cz = 0 exactly, and `grey` says so (their filtering is skipped).
struct Opponent {
  cv::Mat yy, cx, cz;  // CV_32FC1
  bool grey = false;
};

Opponent ToOpponent(const cv::Mat& image) {
  std::array<float, 256> lut;
  for (int i = 0; i < 256; ++i) lut[i] = static_cast<float>(SrgbToLinear(i / 255.0));
  auto linear = [&](const cv::Mat& m, int row, int col, int ch) -> double {
    if (m.depth() == CV_8U) return lut[m.ptr<uint8_t>(row)[col * m.channels() + ch]];
    return SrgbToLinear(std::clamp(static_cast<double>(m.ptr<float>(row)[col * m.channels() + ch]), 0.0, 1.0));
  };
  Opponent o;
  o.grey = image.channels() == 1;
  o.yy.create(image.size(), CV_32FC1);
  o.cx = cv::Mat::zeros(image.size(), CV_32FC1);
  o.cz = cv::Mat::zeros(image.size(), CV_32FC1);
  const ColourSpace& s = Space();
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& rows) {
    for (int r = rows.start; r < rows.end; ++r) {
      float* yy = o.yy.ptr<float>(r);
      float* cx = o.cx.ptr<float>(r);
      float* cz = o.cz.ptr<float>(r);
      for (int c = 0; c < image.cols; ++c) {
        if (o.grey) {
          yy[c] = static_cast<float>(116 * linear(image, r, c, 0) - 16);
          continue;
        }
        const Eigen::Vector3d rgb(linear(image, r, c, 2), linear(image, r, c, 1), linear(image, r, c, 0));  // BGR
        const Eigen::Vector3d n = (s.xyz_from_rgb * rgb).cwiseQuotient(s.white);
        yy[c] = static_cast<float>(116 * n.y() - 16);
        cx[c] = static_cast<float>(500 * (n.x() - n.y()));
        cz[c] = static_cast<float>(200 * (n.y() - n.z()));
      }
    }
  });
  return o;
}

// Contrast sensitivity function of one channel: a1 sqrt(pi/b1) exp(-pi^2 x^2/b1) + a2 sqrt(pi/b2) exp(...).
struct Csf {
  double a1, b1, a2, b2;
};
constexpr Csf kCsfAchromatic{1, 0.0047, 0, 1e-5}, kCsfRedGreen{1, 0.0053, 0, 1e-5},
    kCsfBlueYellow{34.1, 0.04, 13.5, 0.025};
constexpr double kCsfMaxB = 0.04;

// The channel filtered with its CSF, sampled at 1/ppd deg, radius px, normalised to sum 1. Each Gaussian is
// separable; the blue-yellow sum of two is filtered as two separable passes.
cv::Mat CsfFilter(const cv::Mat& channel, const Csf& csf, double ppd, int radius) {
  struct Term {
    double weight;
    cv::Mat kernel;
    double sum;
  };
  std::vector<Term> terms;
  for (auto [a, b] : {std::pair{csf.a1, csf.b1}, std::pair{csf.a2, csf.b2}}) {
    if (a == 0) continue;
    cv::Mat k(2 * radius + 1, 1, CV_64F);
    double sum = 0;
    for (int i = -radius; i <= radius; ++i) {
      const double x = i / ppd;
      k.at<double>(i + radius) = std::exp(-kPi * kPi * x * x / b);
      sum += k.at<double>(i + radius);
    }
    terms.push_back({a * std::sqrt(kPi / b), k, sum});
  }
  double total = 0;  // sum of the 2D kernel: weight * (1D sum)^2 per term
  for (const Term& t : terms) total += t.weight * t.sum * t.sum;
  cv::Mat out = cv::Mat::zeros(channel.size(), CV_32FC1), part;
  for (const Term& t : terms) {
    cv::sepFilter2D(channel, part, CV_32F, t.kernel * (t.weight / total), t.kernel, cv::Point(-1, -1), 0,
                    cv::BORDER_REPLICATE);
    out += part;
  }
  return out;
}

// Hunt-adjusted CIELAB of the filtered opponent image, per channel (CV_32FC1 each); the filtered colour is taken
// back to linear RGB and clamped to [0, 1] first.
std::array<cv::Mat, 3> FilteredHuntLab(const Opponent& o, double ppd) {
  const int radius = static_cast<int>(std::ceil(3 * std::sqrt(kCsfMaxB / (2 * kPi * kPi)) * ppd));
  const cv::Mat yy = CsfFilter(o.yy, kCsfAchromatic, ppd, radius);
  const cv::Mat cx = o.grey ? o.cx : CsfFilter(o.cx, kCsfRedGreen, ppd, radius);
  const cv::Mat cz = o.grey ? o.cz : CsfFilter(o.cz, kCsfBlueYellow, ppd, radius);
  std::array<cv::Mat, 3> lab;
  for (cv::Mat& m : lab) m.create(yy.size(), CV_32FC1);
  const ColourSpace& s = Space();
  cv::parallel_for_(cv::Range(0, yy.rows), [&](const cv::Range& rows) {
    for (int r = rows.start; r < rows.end; ++r) {
      for (int c = 0; c < yy.cols; ++c) {
        const double ny = (yy.at<float>(r, c) + 16) / 116.0;
        const Eigen::Vector3d n(ny + cx.at<float>(r, c) / 500.0, ny, ny - cz.at<float>(r, c) / 200.0);
        const Eigen::Vector3d rgb = (s.rgb_from_xyz * n.cwiseProduct(s.white)).cwiseMax(0.0).cwiseMin(1.0);
        const Eigen::Vector3d h = HuntLab(rgb);
        for (int k = 0; k < 3; ++k) lab[k].at<float>(r, c) = static_cast<float>(h[k]);
      }
    }
  });
  return lab;
}

// Edge (first derivative of a Gaussian) or point (second derivative) responses along x and y of the luminance,
// positive weights summing to 1 and negative ones to -1; returns the magnitude sqrt(rx^2 + ry^2).
cv::Mat FeatureMagnitude(const cv::Mat& luminance, double ppd, bool points) {
  const double sigma = 0.5 * FlipConstants::kEdgeWidthDeg * ppd;
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  cv::Mat g(2 * radius + 1, 1, CV_64F), d(2 * radius + 1, 1, CV_64F);
  for (int i = -radius; i <= radius; ++i) {
    const double e = std::exp(-i * i / (2 * sigma * sigma));
    g.at<double>(i + radius) = e;
    d.at<double>(i + radius) = points ? (i * i / (sigma * sigma) - 1) * e : -i * e;
  }
  g /= cv::sum(g)[0];  // the across-direction Gaussian sums to 1, so the 2D sign sums are those of d
  double positive = 0, negative = 0;
  for (int i = 0; i < d.rows; ++i) (d.at<double>(i) > 0 ? positive : negative) += d.at<double>(i);
  for (int i = 0; i < d.rows; ++i) d.at<double>(i) /= d.at<double>(i) > 0 ? positive : -negative;
  cv::Mat rx, ry, magnitude;
  cv::sepFilter2D(luminance, rx, CV_32F, d, g, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  cv::sepFilter2D(luminance, ry, CV_32F, g, d, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  cv::magnitude(rx, ry, magnitude);
  return magnitude;
}

// Features see the luminance Y/Yn = (Yy + 16)/116 of the unfiltered image.
cv::Mat Luminance(const Opponent& o) {
  cv::Mat y;
  o.yy.convertTo(y, CV_32F, 1.0 / 116, 16.0 / 116);
  return y;
}

void CheckImages(const cv::Mat& reference, const cv::Mat& test) {
  const int type = reference.type();
  if (reference.empty() || test.empty())
    throw Error("FLIP", "an image is empty", "pass two images of the same size");
  if (reference.size() != test.size() || test.type() != type)
    throw Error("FLIP",
                fmt::format("the images differ in size or type ({}x{} type {} against {}x{} type {})",
                            reference.cols, reference.rows, type, test.cols, test.rows, test.type()),
                "compare images of the same size and pixel type");
  if (type != CV_8UC1 && type != CV_8UC3 && type != CV_32FC1 && type != CV_32FC3)
    throw Error("FLIP", fmt::format("pixel type {} is not supported", type),
                "pass 8-bit or float images with 1 (grey) or 3 (BGR) channels");
}

}  // namespace

FlipEvaluator::FlipEvaluator(const cv::Mat& reference, double ppd) {
  CheckImages(reference, reference);
  if (!std::isfinite(ppd) || ppd <= 0)
    throw Error("FLIP", fmt::format("pixels per degree {} is not positive", ppd),
                "give the viewer's pixels per degree (FlipPixelsPerDegree)");
  type_ = reference.type();
  size_ = reference.size();
  ppd_ = ppd;
  const Opponent ref = ToOpponent(reference);
  const std::array<cv::Mat, 3> lab = FilteredHuntLab(ref, ppd);
  for (int k = 0; k < 3; ++k) lab_[k] = lab[k];
  const cv::Mat y = Luminance(ref);
  edges_ = FeatureMagnitude(y, ppd, false);
  points_ = FeatureMagnitude(y, ppd, true);
}

FlipResult FlipEvaluator::Compare(const cv::Mat& test) const {
  if (test.empty() || test.size() != size_ || test.type() != type_)
    throw Error("FLIP",
                fmt::format("the images differ in size or type ({}x{} type {} against {}x{} type {})", size_.width,
                            size_.height, type_, test.cols, test.rows, test.type()),
                "compare images of the same size and pixel type");
  const Opponent tst = ToOpponent(test);
  // Colour: HyAB of the filtered, Hunt-adjusted colours, raised to q_c and redistributed to [0, 1].
  const std::array<cv::Mat, 3> lab_tst = FilteredHuntLab(tst, ppd_);
  const double cmax =
      std::pow(HyAB(HuntLab({0, 1, 0}), HuntLab({0, 0, 1})), FlipConstants::kQc);  // green against blue
  const double knee = FlipConstants::kPc * cmax;
  const cv::Mat y_tst = Luminance(tst);
  const cv::Mat edge_tst = FeatureMagnitude(y_tst, ppd_, false), point_tst = FeatureMagnitude(y_tst, ppd_, true);

  FlipResult result;
  result.error.create(size_, CV_32FC1);
  cv::parallel_for_(cv::Range(0, size_.height), [&](const cv::Range& rows) {
    for (int r = rows.start; r < rows.end; ++r) {
      for (int c = 0; c < size_.width; ++c) {
        const Eigen::Vector3d p(lab_[0].at<float>(r, c), lab_[1].at<float>(r, c), lab_[2].at<float>(r, c));
        const Eigen::Vector3d q(lab_tst[0].at<float>(r, c), lab_tst[1].at<float>(r, c), lab_tst[2].at<float>(r, c));
        const double power = std::pow(HyAB(p, q), FlipConstants::kQc);
        const double colour = power < knee ? FlipConstants::kPt / knee * power
                                           : FlipConstants::kPt + (power - knee) / (cmax - knee) * (1 - FlipConstants::kPt);
        const double feature_difference = std::max(std::abs(edges_.at<float>(r, c) - edge_tst.at<float>(r, c)),
                                                   std::abs(points_.at<float>(r, c) - point_tst.at<float>(r, c)));
        const double feature = std::pow(feature_difference / std::sqrt(2.0), FlipConstants::kQf);
        result.error.at<float>(r, c) = static_cast<float>(std::pow(colour, 1 - feature));
      }
    }
  });
  double lo = 0;
  cv::minMaxLoc(result.error, &lo, &result.max);
  result.mean = cv::mean(result.error)[0];
  return result;
}

FlipResult ComputeFlip(const cv::Mat& reference, const cv::Mat& test, double ppd) {
  CheckImages(reference, test);
  return FlipEvaluator(reference, ppd).Compare(test);
}

double FlipPixelsPerDegree(double distance_mm, double pixel_pitch_mm) {
  if (!(distance_mm > 0) || !(pixel_pitch_mm > 0) || !std::isfinite(distance_mm) || !std::isfinite(pixel_pitch_mm))
    throw Error("FLIP", fmt::format("viewing distance {} mm or pixel pitch {} mm is not positive", distance_mm,
                                    pixel_pitch_mm),
                "give a positive distance and pitch");
  return distance_mm * (kPi / 180) / pixel_pitch_mm;
}

}  // namespace curvecheck
