#include "core/flip.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "core/error.h"
#include "core/viewing.h"

namespace curvecheck {
namespace {

// The thesis's 49" 5120x1440 monitor at 100 cm: about 75 px/deg.
constexpr double kPpd100cm = 1000 * M_PI / 180 / (1196.0 / 5120);

cv::Mat Uniform(int code, int size = 32) { return cv::Mat(size, size, CV_8UC1, cv::Scalar(code)); }

// A grey test image with detail at all scales: white noise blurred at several scales, summed (about 1/f).
cv::Mat Texture(int size, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  cv::Mat sum = cv::Mat::zeros(size, size, CV_32F);
  for (int octave = 0; octave < 5; ++octave) {
    cv::Mat noise(size, size, CV_32F);
    for (int r = 0; r < size; ++r)
      for (int c = 0; c < size; ++c) noise.at<float>(r, c) = u(rng);
    const double sigma = 0.5 * (1 << octave);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), sigma);
    cv::normalize(noise, noise, -1, 1, cv::NORM_MINMAX);
    sum += noise * (0.2 * (1 << octave) / 16.0);
  }
  cv::Mat out;
  cv::normalize(sum, out, 0, 255, cv::NORM_MINMAX, CV_8U);
  return out;
}

TEST(Flip, IdenticalImagesGiveExactlyZero) {
  const cv::Mat t = Texture(96, 1);
  const FlipResult r = ComputeFlip(t, t.clone(), kPpd100cm);
  EXPECT_EQ(r.max, 0.0);
  EXPECT_EQ(r.mean, 0.0);
}

// Uniform black against uniform white has no features and every filter leaves a uniform image alone, so FLIP is
// the colour term alone, computed here from the paper's equations with the published CIELAB values of the sRGB
// primaries (D65): L* 100 against 0 (HyAB 100), and the largest difference, Hunt-adjusted green (87.7347,
// -86.1827, 83.1793) against blue (32.3026, 79.1952, -107.8602). 100^0.7 = 25.1 lies above p_c cmax, so it maps
// into the top 5%: FLIP = 0.95 + 0.05 (25.1 - 0.4 cmax) / (0.6 cmax) = 0.967, not 1.
TEST(Flip, BlackAgainstWhiteFromTheEquations) {
  auto hunt = [](double L, double a, double b) { return cv::Vec3d(L, a * L / 100, b * L / 100); };
  const cv::Vec3d g = hunt(87.7347, -86.1827, 83.1793), b = hunt(32.3026, 79.1952, -107.8602);
  const double cmax = std::pow(std::abs(g[0] - b[0]) + std::hypot(g[1] - b[1], g[2] - b[2]), 0.7);
  const double expected = 0.95 + 0.05 * (std::pow(100.0, 0.7) - 0.4 * cmax) / (0.6 * cmax);
  EXPECT_NEAR(expected, 0.967, 5e-4);
  const FlipResult r = ComputeFlip(Uniform(0), Uniform(255), kPpd100cm);
  EXPECT_NEAR(r.mean, expected, 2e-4);
  EXPECT_NEAR(r.max, expected, 2e-4);
  // Symmetric in its colour term.
  EXPECT_NEAR(ComputeFlip(Uniform(255), Uniform(0), kPpd100cm).mean, expected, 2e-4);
}

// A small uniform difference stays below the knee: (HyAB^0.7) * 0.95 / (0.4 cmax), with L* from the sRGB curve.
TEST(Flip, SmallUniformGreyDifferenceBelowTheKnee) {
  auto lstar = [](int code) {
    const double c = code / 255.0;
    const double y = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
    return y > std::pow(6.0 / 29, 3) ? 116 * std::cbrt(y) - 16 : 116 * (y / (3 * std::pow(6.0 / 29, 2)) + 4.0 / 29) - 16;
  };
  auto hunt = [](double L, double a, double b) { return cv::Vec3d(L, a * L / 100, b * L / 100); };
  const cv::Vec3d g = hunt(87.7347, -86.1827, 83.1793), b = hunt(32.3026, 79.1952, -107.8602);
  const double cmax = std::pow(std::abs(g[0] - b[0]) + std::hypot(g[1] - b[1], g[2] - b[2]), 0.7);
  const double dl = lstar(130) - lstar(120);
  const double expected = 0.95 / (0.4 * cmax) * std::pow(dl, 0.7);
  EXPECT_NEAR(ComputeFlip(Uniform(120), Uniform(130), kPpd100cm).mean, expected, 1e-3 * expected);
}

// A vertical black/white edge moved by one pixel: a clear error at the edge, exactly zero beyond the reach of
// the filters (CSF radius ceil(0.135 ppd) = 11 px, feature radius ceil(0.123 ppd) = 10 px at 75 px/deg).
TEST(Flip, OnePixelEdgeShiftIsFoundAtTheEdge) {
  cv::Mat a = Uniform(0, 96), b = Uniform(0, 96);
  a.colRange(48, 96).setTo(255);
  b.colRange(49, 96).setTo(255);
  const FlipResult r = ComputeFlip(a, b, kPpd100cm);
  const cv::Mat row = r.error.row(40);
  EXPECT_GT(row.at<float>(48), 0.3);  // the pixel that changed from white to black
  double near_edge = 0, far = 0;
  for (int c = 0; c < 96; ++c) {
    if (std::abs(c - 48) <= 1) near_edge = std::max<double>(near_edge, row.at<float>(c));
    if (std::abs(c - 48) > 13) far = std::max<double>(far, row.at<float>(c));
  }
  EXPECT_GT(near_edge, 0.3);
  EXPECT_EQ(far, 0.0);
  // Smaller than black against white everywhere, and concentrated: the mean over the image is far below the peak.
  EXPECT_LT(r.max, 0.967);
  EXPECT_LT(r.mean, 0.1 * r.max);
}

// Growing blur of a textured image gives a growing mean FLIP.
TEST(Flip, GrowingBlurGivesGrowingError) {
  const cv::Mat t = Texture(128, 7);
  double previous = 0;
  for (double sigma : {0.5, 0.8, 1.2, 1.8, 2.7, 4.0}) {
    cv::Mat blurred;
    cv::GaussianBlur(t, blurred, cv::Size(0, 0), sigma);
    const double e = ComputeFlip(t, blurred, kPpd100cm).mean;
    EXPECT_GT(e, previous) << "sigma " << sigma;
    previous = e;
  }
  EXPECT_GT(previous, 0.1);
}

// A colour change at the same luminance (Y/Yn, hence L*) is seen by the colour pipeline alone: a grey against a
// reddish and a bluish colour with Y equal to the grey's. Y = 0.2126 R + 0.7152 G + 0.0722 B for linear sRGB.
TEST(Flip, ColourChangeAtFixedLuminanceIsDetected) {
  auto encode = [](double linear) {
    return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
  };
  const double grey = 0.2;
  cv::Mat ref(32, 32, CV_32FC3, cv::Scalar::all(encode(grey)));
  // Red 0.5, blue 0.2, and G solving Y = 0.2 (BGR order in the Mat).
  const double g = (grey - 0.2126 * 0.5 - 0.0722 * 0.2) / 0.7152;
  ASSERT_GT(g, 0);
  cv::Mat test(32, 32, CV_32FC3, cv::Scalar(encode(0.2), encode(g), encode(0.5)));
  const FlipResult r = ComputeFlip(ref, test, kPpd100cm);
  EXPECT_GT(r.mean, 0.2);
  EXPECT_NEAR(r.max, r.mean, 1e-5);  // uniform: no features, the same everywhere
}

// Fine detail (a one-pixel checkerboard against the grey of the same mean light) is visible from close by and
// blends into grey from far away: fewer pixels per degree (a closer viewer) -> larger error.
TEST(Flip, CloserViewerSeesFineDetail) {
  // 160 px square; the error is averaged over the central 64 px, which the filters (radius at most 22 px) see
  // without the replicated border.
  cv::Mat checker(160, 160, CV_8UC1);
  for (int r = 0; r < 160; ++r)
    for (int c = 0; c < 160; ++c) checker.at<uint8_t>(r, c) = (r + c) % 2 ? 255 : 0;
  const cv::Mat grey = Uniform(188, 160);  // sRGB code of linear 0.5
  auto centre_mean = [&](double ppd) {
    return cv::mean(ComputeFlip(checker, grey, ppd).error(cv::Rect(48, 48, 64, 64)))[0];
  };
  double previous = 1;
  for (double ppd : {10.0, 20.0, 40.0, 80.0, 160.0}) {
    const double e = centre_mean(ppd);
    EXPECT_LT(e, previous) << ppd << " px/deg";
    previous = e;
  }
  EXPECT_GT(centre_mean(10), 2 * centre_mean(160));
}

TEST(Flip, RefusesMismatchedImagesAndBadPixelsPerDegree) {
  EXPECT_THROW(ComputeFlip(Uniform(0, 8), Uniform(0, 9), 60), Error);
  EXPECT_THROW(ComputeFlip(Uniform(0), cv::Mat(32, 32, CV_8UC3, cv::Scalar::all(0)), 60), Error);
  EXPECT_THROW(ComputeFlip(cv::Mat(), cv::Mat(), 60), Error);
  EXPECT_THROW(ComputeFlip(Uniform(0), Uniform(0), 0), Error);
  EXPECT_THROW(ComputeFlip(Uniform(0), Uniform(0), NAN), Error);
  EXPECT_THROW(ComputeFlip(cv::Mat(8, 8, CV_16UC1), cv::Mat(8, 8, CV_16UC1), 60), Error);
}

// FLIP's own formula: 0.7 m from a 0.7 m wide 3840 px monitor is 0.7 * 3840 / 0.7 * pi / 180 = 67.02 px/deg.
TEST(FlipPixelsPerDegree, AuthorsDefaultViewer) {
  EXPECT_NEAR(FlipPixelsPerDegree(700, 700.0 / 3840), 3840 * M_PI / 180, 1e-9);
  EXPECT_THROW(FlipPixelsPerDegree(0, 0.2), Error);
  EXPECT_THROW(FlipPixelsPerDegree(500, -1), Error);
}

// The viewer's pixels per degree uses the nearest point of the screen (thesis 3.3).
TEST(ViewerPixelsPerDegree, NearestPointOfTheScreen) {
  const Monitor curved = MonitorFromDiagonal("49 1000R", 5120, 1440, 49, 1000);
  const double pitch = curved.pixel_pitch_mm();
  // On the centre line, inside the sector: the nearest point is the screen centre.
  for (double d : {250.0, 600.0, 1000.0}) {
    const Eigen::Vector3d o(0, 0, -1000 + d);
    EXPECT_NEAR(NearestSurfaceDistanceMm(curved, o), d, 1e-6) << d;
    EXPECT_NEAR(ViewerPixelsPerDegree(curved, o), d * M_PI / 180 / pitch, 1e-6) << d;
  }
  // Off-centre inside the sector: the nearest point is on the radius through the viewpoint, R - rho away.
  const Eigen::Vector3d off(200, 0, -500);
  EXPECT_NEAR(NearestSurfaceDistanceMm(curved, off), 1000 - std::hypot(200.0, 500.0), 1e-6);
  // Above the screen: the vertical gap adds in quadrature.
  const Eigen::Vector3d above(0, curved.height_mm / 2 + 300, -600);
  EXPECT_NEAR(NearestSurfaceDistanceMm(curved, above), std::hypot(400.0, 300.0), 1e-6);
  // Flat, head-on: FLIP's own case; it agrees with the centre pixel's angular density to the small-angle error.
  const Monitor flat = MonitorFromDiagonal("27 flat", 3840, 2160, 27, 0);
  const Eigen::Vector3d front(0, 0, 700);
  EXPECT_NEAR(ViewerPixelsPerDegree(flat, front), 700 * M_PI / 180 / flat.pixel_pitch_mm(), 1e-6);
  EXPECT_NEAR(ViewerPixelsPerDegree(flat, front), DescribeViewing(flat, front).pixels_per_degree_horizontal, 1e-3);
  // A closer viewer has fewer pixels per degree.
  EXPECT_LT(ViewerPixelsPerDegree(curved, {0, 0, -750}), ViewerPixelsPerDegree(curved, {0, 0, 0}));
}

}  // namespace
}  // namespace curvecheck
