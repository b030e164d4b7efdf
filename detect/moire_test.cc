// MeasureMoire on images with a known periodic component, and why the prefilter does not move a corner. The
// moire of real display pixels in synthetic photos, and the detection with and without the prefilter, are in
// detect_test.cc (Moire*).
#include "detect/moire.h"

#include <gtest/gtest.h>

#include <cmath>
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

// The prefilter does not move an X-corner: a blurred X-junction of two edges crossing at 70 deg, at a sub-pixel
// position, refined by cornerSubPix after a Gaussian of sigma 3 px is within 0.02 px of the truth (the corner is
// point-symmetric, moire.h), and no farther from it than without the prefilter (measured: 0.028 px without, the
// sampled edges' pixel-locking, which the smoothing reduces).
TEST(Moire, SymmetricPrefilterKeepsTheCorner) {
  const cv::Point2d truth(100.37, 90.81);
  const double a1 = 0.3, a2 = 0.3 + 70 * M_PI / 180;
  cv::Mat img(200, 200, CV_32F);
  constexpr int kSuper = 8;  // area sampling: 8 x 8 points per pixel
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
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.7);  // the optics
  const cv::Point2d guess(truth.x + 1.3, truth.y - 0.9);
  const cv::Point2d plain = detect_internal::RefineXCorner(img, 0, guess, 15);
  const cv::Point2d smoothed = detect_internal::RefineXCorner(img, 3.0, guess, 15);
  EXPECT_LT(cv::norm(plain - truth), 0.04);
  EXPECT_LT(cv::norm(smoothed - truth), 0.02);
  EXPECT_LE(cv::norm(smoothed - truth), cv::norm(plain - truth) + 0.002);
}

}  // namespace
}  // namespace curvecheck
