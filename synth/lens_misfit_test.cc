#include "synth/lens_misfit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "synth/ray_grid.h"

namespace curvecheck {
namespace {

std::filesystem::path Datasets() {
  const char* src = std::getenv("CURVECHECK_SOURCE_DIR");
  return std::filesystem::path(src ? src : ".") / "datasets";
}

Imaging Ilc24(double rms, double length, uint64_t seed) {
  Imaging g = ImagingFromPreset(ImagingPreset::kIlc24);
  g.lens_misfit_px = rms;
  g.lens_misfit_length = length;
  g.lens_seed = seed;
  return g;
}

// RMS over the image as stated (per coordinate), at the stated width and scaled with the imager; the clean
// preset has none.
TEST(LensMisfit, RmsAsStatedAndScaledWithTheImager) {
  EXPECT_FALSE(LensMisfit(ImagingFromPreset(ImagingPreset::kClean), 6000, 4000).active());
  EXPECT_DOUBLE_EQ(ImagingFromPreset(ImagingPreset::kIlc24).lens_misfit_px, 0.1);
  Imaging g = Ilc24(0.1, 0.2, 7);
  g.lens_misfit_reference_width = 6000;
  for (int w : {6000, 1500}) {
    const int h = w * 2 / 3;
    const LensMisfit m(g, w, h);
    double sx = 0, sy = 0;
    const int n = 200;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d d = m.At({(i + 0.5) * w / n - 0.5, (j + 0.5) * h / n - 0.5});
        sx += d.x() * d.x(), sy += d.y() * d.y();
      }
    }
    const double want = 0.1 * w / 6000.0;
    std::cout << "width " << w << ": RMS x " << std::sqrt(sx / (n * n)) << ", y " << std::sqrt(sy / (n * n))
              << " px (stated " << want << ")\n";
    EXPECT_NEAR(std::sqrt(sx / (n * n)), want, 0.01 * want);
    EXPECT_NEAR(std::sqrt(sy / (n * n)), want, 0.01 * want);
  }
}

// The field's correlation falls with distance as the Gaussian covariance of length L says: averaged over 40
// lenses, the correlation at lag L is exp(-1/2) = 0.61 and at 3 L about 0 (exp(-4.5) = 0.011), within the
// spread of 40 lenses.
TEST(LensMisfit, CorrelationLengthAsStated) {
  const int w = 3000, h = 2000;
  const double length = 0.1;  // 300 px
  double c1 = 0, c3 = 0;
  const int lenses = 40;
  for (int seed = 1; seed <= lenses; ++seed) {
    const LensMisfit m(Ilc24(0.1, length, static_cast<uint64_t>(seed)), w, h);
    double s00 = 0, s01 = 0, s03 = 0;
    int k = 0;
    for (int j = 0; j < 20; ++j) {
      for (int i = 0; i < 20; ++i) {
        const Eigen::Vector2d p(100 + i * 50.0, 100 + j * 90.0);
        const double a = m.At(p).x();
        s00 += a * a, s01 += a * m.At(p + Eigen::Vector2d(length * w, 0)).x();
        s03 += a * m.At(p + Eigen::Vector2d(3 * length * w, 0)).x();
        ++k;
      }
    }
    c1 += s01 / s00 / lenses, c3 += s03 / s00 / lenses;
  }
  std::cout << "correlation at L " << c1 << " (Gaussian: 0.607), at 3 L " << c3 << " (0.011)\n";
  EXPECT_NEAR(c1, std::exp(-0.5), 0.12);
  EXPECT_NEAR(c3, 0.0, 0.12);
}

// ModelPixelOf inverts TrueImageOf; the ray table through the misfit reprojects (model, then misfit) to within
// 0.001 px, and the misfit moves the image by its own size.
TEST(LensMisfit, InverseAndRayTable) {
  const CameraModel cam = ReadCameraModel(Datasets() / "cameras/default-24mp-opencv8.cameramodel");
  const LensMisfit m(Ilc24(0.5, 0.2, 3), cam.width, cam.height);
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(10, 20), Eigen::Vector2d(3000, 2000), Eigen::Vector2d(5990, 3990)}) {
    EXPECT_LT((m.TrueImageOf(m.ModelPixelOf(p)) - p).norm(), 1e-9);
  }
  const RayGrid grid(cam, 16, 4, &m);
  const double err = grid.MeasureErrorPx(cam, 5000, 3, &m);
  const double without = grid.MeasureErrorPx(cam, 5000, 3);
  std::cout << "ray grid with a 0.5 px misfit: worst error " << err << " px; against the bare model " << without
            << " px\n";
  EXPECT_LT(err, 0.001);
  EXPECT_GT(without, 0.5);
}

}  // namespace
}  // namespace curvecheck
