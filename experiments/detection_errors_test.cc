// DetectionErrorsOf on errors whose parts are known: a smooth field of stated RMS, a pixel-locking signature and
// seeded independent noise, on a grid of points over a 1000 x 600 px image, two photos.
#include "experiments/detection_errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace curvecheck::experiments {
namespace {

constexpr int kWidth = 1000, kHeight = 600;

struct Sample {
  std::vector<Eigen::Vector2d> at, err;
  std::vector<int> photo;
};

// A 40 x 24 grid of true positions `spacing` px apart in each of two photos; the error at x' = 2x/(w-1) - 1, y'
// likewise: `field` times the smooth field (0.3 x'^2 - 0.2 x' y', 0.25 y' + 0.1 x'^3), plus `locking` sin 2 pi t
// per coordinate t of the true position, plus independent N(0, noise^2) per coordinate.
Sample Make(double field, double locking, double noise, unsigned seed, double spacing = 24.37) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  Sample s;
  for (int p = 0; p < 2; ++p) {
    for (int j = 0; j < 24; ++j) {
      for (int i = 0; i < 40; ++i) {
        const Eigen::Vector2d t(12.5 + spacing * i + 3.3 * p, 12.5 + spacing * j);
        const double x = 2 * t.x() / (kWidth - 1) - 1, y = 2 * t.y() / (kHeight - 1) - 1;
        const Eigen::Vector2d smooth(0.3 * x * x - 0.2 * x * y, 0.25 * y + 0.1 * x * x * x);
        const Eigen::Vector2d lock(std::sin(2 * M_PI * t.x()), std::sin(2 * M_PI * t.y()));
        const Eigen::Vector2d e = field * smooth + locking * lock + noise * Eigen::Vector2d(g(rng), g(rng));
        s.at.push_back(t + e);
        s.err.push_back(e);
        s.photo.push_back(p);
      }
    }
  }
  return s;
}

double Rms(const std::vector<Eigen::Vector2d>& v) {
  double sum = 0;
  for (const Eigen::Vector2d& e : v) sum += e.squaredNorm();
  return std::sqrt(sum / (2.0 * static_cast<double>(v.size())));
}

DetectionErrors Of(const Sample& s) { return DetectionErrorsOf(s.at, s.err, s.photo, kWidth, kHeight); }

TEST(DetectionErrors, TheSmoothPartIsTheFieldsRmsAndNoiseLeaksOnlyThroughTheBasis) {
  // The field alone (degree 3): the smooth part is all of it, per photo (degree 2) all but the cubic term.
  const Sample field = Make(0.1, 0, 0, 1);
  const DetectionErrors f = Of(field);
  EXPECT_EQ(f.points, 1920);
  EXPECT_NEAR(f.rms_px, Rms(field.err), 1e-12);
  EXPECT_NEAR(f.smooth_rms_px, f.rms_px, 1e-9);
  EXPECT_NEAR(f.smooth_beyond_noise_px, f.rms_px, 1e-9);
  EXPECT_LT(f.per_photo_smooth_rms_px, f.rms_px);
  EXPECT_GT(f.per_photo_smooth_rms_px, 0.8 * f.rms_px);

  // Noise alone, 0.1 px: 10 field functions per coordinate over 1920 points take about 0.1 sqrt(10 / 1920) =
  // 0.0072 px of it (a chi-square with 20 dof over 3840: within 0.0035-0.011 at better than 99.9%); less that
  // expected leak what is left is the leak's own scatter, at most about 0.0072 x 0.9 at 99.9%.
  const DetectionErrors n = Of(Make(0, 0, 0.1, 2));
  EXPECT_NEAR(n.rms_px, 0.1, 0.005);
  EXPECT_GT(n.smooth_rms_px, 0.0035);
  EXPECT_LT(n.smooth_rms_px, 0.011);
  EXPECT_LT(n.smooth_beyond_noise_px, 0.0065);

  // Both: the field's RMS comes back under noise five times its size, to within the leak.
  const DetectionErrors b = Of(Make(0.1, 0, 0.1, 3));
  const double leak = 0.1 * std::sqrt(10.0 / 1920);
  EXPECT_NEAR(b.smooth_rms_px, std::sqrt(f.smooth_rms_px * f.smooth_rms_px + leak * leak), 2.5 * leak);
  EXPECT_NEAR(b.smooth_beyond_noise_px, f.smooth_rms_px, 0.1 * f.smooth_rms_px);

  // A pixel-locking signature 0.05 sin 2 pi t on points 24.37 px apart changes phase fast between neighbours: the
  // field takes little of it. On points 25.01 px apart (nearly one phase) it beats once across the image and the
  // field takes most of it, as the header says.
  const DetectionErrors fast = Of(Make(0, 0.05, 0, 6)), slow = Of(Make(0, 0.05, 0, 6, 25.01));
  EXPECT_LT(fast.smooth_rms_px, 0.1 * fast.rms_px);
  EXPECT_GT(slow.smooth_rms_px, 0.5 * slow.rms_px);
}

// A bias of each coordinate that depends on both phases in a 2 x 2 cell (0.03 sin pi t_x sin pi t_y in x, 0.02
// cos pi t_x in y... as a Bayer cell makes) with 0.005 px noise: the budget's model (own phase only) leaves most of
// the x part, the cell's model leaves the noise. A signature of the own phase (0.05 sin 2 pi t) both models take.
TEST(DetectionErrors, TheCellSignatureTakesWhatTheOwnPhaseModelLeaves) {
  Sample s = Make(0, 0, 0.005, 7);
  for (size_t i = 0; i < s.err.size(); ++i) {
    const Eigen::Vector2d t = s.at[i] - s.err[i];
    const Eigen::Vector2d bias(0.03 * std::sin(M_PI * t.x()) * std::sin(M_PI * t.y()),
                               0.02 * std::cos(M_PI * t.x()));
    s.err[i] += bias;
    s.at[i] += bias;
  }
  const DetectionErrors e = Of(s);
  EXPECT_GT(e.signature_remainder_px, 0.01);
  EXPECT_NEAR(e.cell_signature_remainder_px, 0.005, 0.0006);
  const DetectionErrors own = Of(Make(0, 0.05, 0.005, 8));
  EXPECT_NEAR(own.signature_remainder_px, 0.005, 0.0006);
  EXPECT_NEAR(own.cell_signature_remainder_px, 0.005, 0.0006);
}

TEST(DetectionErrors, TooFewPointsGiveNaNNotZero) {
  const Sample s = Make(0.1, 0, 0.1, 4);
  const std::vector<Eigen::Vector2d> at(s.at.begin(), s.at.begin() + 19), err(s.err.begin(), s.err.begin() + 19);
  const std::vector<int> photo(s.photo.begin(), s.photo.begin() + 19);
  const DetectionErrors e = DetectionErrorsOf(at, err, photo, kWidth, kHeight);
  EXPECT_EQ(e.points, 19);
  EXPECT_TRUE(std::isnan(e.rms_px));
  EXPECT_TRUE(std::isnan(e.smooth_rms_px));
}

}  // namespace
}  // namespace curvecheck::experiments
