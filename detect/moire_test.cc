// MeasureMoire on images with a known periodic component, and why the prefilter does not move a corner. The
// moire of real display pixels in synthetic photos, and the detection with and without the prefilter, are in
// detect_test.cc (Moire*).
#include "detect/moire.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <random>

#include "core/error.h"
#include "detect/detect_board.h"

namespace curvecheck {
namespace {

// 400 x 300 px of level 200 with a cosine of `contrast` x 200 and period `period_px` along direction `angle_rad`,
// plus Gaussian noise of `noise` levels (16-bit, so that quantization stays below the noise).
cv::Mat Striped(double period_px, double angle_rad, double contrast, double noise) {
  cv::Mat img(300, 400, CV_16U);
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss(0, noise);
  const double fx = std::cos(angle_rad) / period_px, fy = std::sin(angle_rad) / period_px;
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      const double v = 200 * (1 + contrast * std::cos(2 * M_PI * (fx * x + fy * y))) + gauss(rng);
      img.at<uint16_t>(y, x) = static_cast<uint16_t>(std::lround(std::clamp(v * 100, 0.0, 65535.0)));
    }
  }
  return img;
}

// Period and contrast of a cosine are recovered (contrast within 10%, period within a DFT bin of 32 px patches),
// also between bins and at an angle; noise alone is not moire.
TEST(Moire, MeasuresPeriodAndContrastOfAPeriodicComponent) {
  for (const double period : {2.5, 4.0, 7.3}) {
    for (const double angle : {0.0, 0.6}) {
      const MoireMeasure m = MeasureMoire(Striped(period, angle, 0.1, 1.0));
      EXPECT_GT(m.patches, 50);
      EXPECT_TRUE(m.present) << period;
      EXPECT_NEAR(m.contrast, 0.1, 0.01) << period << " " << angle;
      // One bin of 32 px patches is 1/32 cycles/px.
      EXPECT_NEAR(1 / m.period_px, 1 / period, 0.75 / 32) << period << " " << angle;
      ASSERT_FALSE(m.components.empty());
      EXPECT_NEAR(m.needed_sigma_px, MoireFilterSigmaPx(m.period_px, m.contrast, 0.005), 1e-9);
    }
  }
  const MoireMeasure noise_only = MeasureMoire(Striped(4, 0, 0, 2.0));
  EXPECT_FALSE(noise_only.present);
  EXPECT_LT(noise_only.contrast, 0.005);
  // A weak component (1%) under the 2% limit is measured but not present.
  const MoireMeasure weak = MeasureMoire(Striped(4, 0, 0.01, 0.2));
  EXPECT_NEAR(weak.contrast, 0.01, 0.002);
  EXPECT_FALSE(weak.present);
}

// Only bright areas count: a photo that is dark (or an edge through every patch) gives no patches.
TEST(Moire, NoBrightAreaNoMeasure) {
  cv::Mat dark(300, 400, CV_8U, cv::Scalar(0));
  EXPECT_EQ(MeasureMoire(dark).patches, 0);
  EXPECT_FALSE(MeasureMoire(dark).present);
  cv::Mat stripes(300, 400, CV_8U, cv::Scalar(0));  // 8 px bars: every 32 px patch holds edges
  for (int x = 0; x < stripes.cols; ++x) {
    if ((x / 8) % 2 == 0) stripes.col(x).setTo(255);
  }
  EXPECT_EQ(MeasureMoire(stripes).patches, 0);
  EXPECT_THROW(MeasureMoire(cv::Mat(100, 100, CV_8UC3)), Error);
  MoireOptions bad;
  bad.patch_px = 8;
  EXPECT_THROW(MeasureMoire(dark, bad), Error);
}

TEST(Moire, FilterSigmaReachesTheResidualContrast) {
  const double sigma = MoireFilterSigmaPx(3.0, 0.4, 0.005);
  EXPECT_NEAR(0.4 * std::exp(-2 * M_PI * M_PI * sigma * sigma / 9.0), 0.005, 1e-12);
  EXPECT_EQ(MoireFilterSigmaPx(3.0, 0.004, 0.005), 0);
}

// The broadband texture: white noise of a known relative standard deviation, or a display's gaps under one point
// sample per pixel (a pixel is lit with probability 0.7: sqrt(0.7 x 0.3) / 0.7 = 65.5% of the mean), is measured
// within 10%; smoothing starts at the 5% limit, and the sigma it chooses brings the noise to 2% (checked on the
// smoothed image itself). A strong periodic moire with 1% noise is not texture: its leakage stays off the floor.
TEST(Moire, BroadbandTextureIsMeasuredAndSmoothedToTheResidual) {
  for (const double s : {0.01, 0.1, 0.3}) {
    const cv::Mat img = Striped(4, 0, 0, 200 * s);
    const MoireMeasure m = MeasureMoire(img);
    std::printf("white noise %.2f: texture %.4f, sigma %.2f px\n", s, m.texture, m.texture_sigma_px);
    EXPECT_FALSE(m.present) << s;
    EXPECT_NEAR(m.texture, s, 0.1 * s) << s;
    if (s < 0.05) {
      EXPECT_EQ(m.texture_sigma_px, 0);
      continue;
    }
    EXPECT_NEAR(m.texture_sigma_px, TextureFilterSigmaPx(m.texture, 0.02), 1e-12);
    cv::Mat f, smoothed;
    img.convertTo(f, CV_64F, 0.01);
    cv::GaussianBlur(f, smoothed, cv::Size(0, 0), m.texture_sigma_px);
    cv::Scalar mean, sd;
    cv::meanStdDev(smoothed(cv::Rect(40, 40, img.cols - 80, img.rows - 80)), mean, sd);
    EXPECT_NEAR(sd[0] / mean[0], 0.02, 0.002) << s;
  }
  cv::Mat lit(300, 400, CV_8U);
  std::mt19937 rng(5);
  std::bernoulli_distribution on(0.7);
  for (int y = 0; y < lit.rows; ++y) {
    for (int x = 0; x < lit.cols; ++x) lit.at<uint8_t>(y, x) = on(rng) ? 85 : 0;
  }
  const MoireMeasure sampled = MeasureMoire(lit);
  std::printf("one sample per pixel at fill 0.7: texture %.4f (expected %.4f); strong moire: texture %.4f\n",
              sampled.texture, std::sqrt(0.7 * 0.3) / 0.7, MeasureMoire(Striped(7.16, 0.3, 0.35, 2.0)).texture);
  EXPECT_GT(sampled.patches, 50);
  EXPECT_NEAR(sampled.texture, std::sqrt(0.7 * 0.3) / 0.7, 0.066);
  EXPECT_GT(sampled.texture_sigma_px, 5);
  const MoireMeasure strong = MeasureMoire(Striped(7.16, 0.3, 0.35, 2.0));
  EXPECT_TRUE(strong.present);
  EXPECT_LT(strong.texture, 0.02);
  EXPECT_EQ(strong.texture_sigma_px, 0);
  EXPECT_EQ(TextureFilterSigmaPx(0.01, 0.02), 0);
  EXPECT_NEAR(TextureFilterSigmaPx(0.2, 0.02), 0.2 / (2 * std::sqrt(M_PI) * 0.02), 1e-12);
}

// An X-junction of two edges crossing at 70 deg at `truth` (levels 220 and 20), area-sampled (8 x 8 points per
// pixel) and blurred by the optics (sigma 0.7 px).
cv::Mat XCorner(const cv::Point2d& truth, double roll = 0.3, double crossing_deg = 70) {
  const double a1 = roll, a2 = roll + crossing_deg * M_PI / 180;
  cv::Mat img(200, 200, CV_32F);
  constexpr int kSuper = 8;
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      double v = 0;
      for (int j = 0; j < kSuper; ++j) {
        for (int i = 0; i < kSuper; ++i) {
          const double dx = x - 0.5 + (i + 0.5) / kSuper - truth.x, dy = y - 0.5 + (j + 0.5) / kSuper - truth.y;
          const double s1 = -std::sin(a1) * dx + std::cos(a1) * dy, s2 = -std::sin(a2) * dx + std::cos(a2) * dy;
          v += (s1 > 0) == (s2 > 0) ? 220 : 20;
        }
      }
      img.at<float>(y, x) = static_cast<float>(v / (kSuper * kSuper));
    }
  }
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.7);
  return img;
}

// The prefilter does not move an X-corner: a blurred X-junction of two edges crossing at 70 deg, at a sub-pixel
// position, refined by cornerSubPix after a Gaussian of sigma 3 px is within 0.02 px of the truth (the corner is
// point-symmetric, moire.h), and no farther from it than without the prefilter (measured: 0.028 px without, the
// sampled edges' pixel-locking, which the smoothing reduces).
TEST(Moire, SymmetricPrefilterKeepsTheCorner) {
  const cv::Point2d truth(100.37, 90.81);
  const cv::Mat img = XCorner(truth);
  const cv::Point2d guess(truth.x + 1.3, truth.y - 0.9);
  const cv::Point2d plain = detect_internal::RefineXCorner(img, 0, guess, 15);
  const cv::Point2d smoothed = detect_internal::RefineXCorner(img, 3.0, guess, 15);
  EXPECT_LT(cv::norm(plain - truth), 0.04);
  EXPECT_LT(cv::norm(smoothed - truth), 0.02);
  EXPECT_LE(cv::norm(smoothed - truth), cv::norm(plain - truth) + 0.002);
}

// The closing the refinement uses where a display's gaps darken the bright areas (detect.cc DetectBoard,
// detect_board.h ClosedAlongEdges): the parallelogram of 0.75 x the board's edge vectors (here 40 px squares) keeps
// a clean X-corner where the refinement puts it on the image itself at any roll, where a 15 px square rounds the
// black tips off and moves it (by pixels where the refinement's window is smaller than the square); and on the
// same corner with 30% of the pixels dark (one point sample per pixel of a display at fill 0.7) it fills the gaps:
// the corners refined on it are far closer to the truth than on the speckled image (sums over the 8 cases: 0.20
// against 2.84 px, measured), at the refinement's sigma of 3 px.
TEST(Moire, ClosingAlongTheEdgesFillsTheGapsAndKeepsTheCorner) {
  const cv::Point2d truth(100.37, 90.81), guess(truth.x + 1.3, truth.y - 0.9);
  const cv::Mat square = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(15, 15));
  std::mt19937 rng(11);
  std::bernoulli_distribution dark(0.3);
  double worst_square = 0, sum_speckled = 0, sum_filled = 0;
  for (const double roll : {0.0, 0.3, 0.52, 0.78}) {
    for (const double crossing : {90.0, 70.0}) {
      const double a1 = roll, a2 = roll + crossing * M_PI / 180;
      // Edge vectors one 40 px square long, scaled as the refinement scales them.
      const cv::Point2d u = 0.75 * 40 * cv::Point2d(std::cos(a1), std::sin(a1));
      const cv::Point2d v = 0.75 * 40 * cv::Point2d(std::cos(a2), std::sin(a2));
      const cv::Mat img = XCorner(truth, roll, crossing);
      cv::Mat by_square;
      cv::morphologyEx(img, by_square, cv::MORPH_CLOSE, square);
      const cv::Mat by_edges = detect_internal::ClosedAlongEdges(img, u, v);
      const cv::Point2d plain = detect_internal::RefineXCorner(img, 3.0, guess, 12);
      const cv::Point2d edges = detect_internal::RefineXCorner(by_edges, 3.0, guess, 12);
      const double e_plain = cv::norm(plain - truth), e_edges = cv::norm(edges - truth);
      const double e_square = cv::norm(detect_internal::RefineXCorner(by_square, 3.0, guess, 12) - truth);
      cv::Mat speckled = img.clone();
      for (int y = 0; y < speckled.rows; ++y) {
        for (int x = 0; x < speckled.cols; ++x) {
          if (dark(rng)) speckled.at<float>(y, x) = 20;
        }
      }
      const double e_speckled = cv::norm(detect_internal::RefineXCorner(speckled, 3.0, guess, 12) - truth);
      const double e_filled =
          cv::norm(detect_internal::RefineXCorner(detect_internal::ClosedAlongEdges(speckled, u, v), 3.0, guess, 12) -
                   truth);
      std::printf("roll %.2f, crossing %.0f deg: clean %.4f px, closed along the edges %.4f (%.4f from the clean "
                  "refinement), by a square %.4f; speckled %.4f, closed along the edges %.4f\n",
                  roll, crossing, e_plain, e_edges, cv::norm(edges - plain), e_square, e_speckled, e_filled);
      EXPECT_LT(cv::norm(edges - plain), 0.03) << roll << " " << crossing;  // 0.0007-0.0156 px measured
      EXPECT_LT(e_filled, 0.1) << roll << " " << crossing;                 // 0.0014-0.0672 px
      sum_speckled += e_speckled, sum_filled += e_filled;
      worst_square = std::max(worst_square, e_square);
    }
  }
  EXPECT_LT(sum_filled, 0.5 * sum_speckled);
  EXPECT_GT(worst_square, 0.1);  // why the square is not used (10.8 px at 45 deg roll, 70 deg crossing)
}

}  // namespace
}  // namespace curvecheck
