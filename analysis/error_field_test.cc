// The correction-error field against known fields and seeded noise: its noise estimate, its degree choice, its
// outlier handling, and the coverage of its simultaneous 95% band over seeded trials (with the binomial
// uncertainty of the count).
#include "analysis/error_field.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <iostream>
#include <random>

#include "core/test_util.h"

namespace curvecheck {
namespace {

using Field = std::function<Eigen::Vector2d(const Eigen::Vector2d&)>;  // of the normalized position

// A grid of cols x rows features over a 5120 x 1440 display, camera px per display px varying across the
// screen (0.6 at the edges to 0.8 in the middle, with a little shear) as on a curved screen seen from 1.5 m.
struct Scene {
  int cols = 24, rows = 7;
  bool with_nuisance = false;

  ErrorFieldInput Make(const Field& truth, double noise_px, uint64_t seed) const {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal(0, noise_px);
    ErrorFieldInput in;
    for (int j = 0; j < rows; ++j) {
      for (int i = 0; i < cols; ++i) {
        const Eigen::Vector2d d(200 + 4720.0 * i / (cols - 1), 100 + 1240.0 * j / (rows - 1));
        const Eigen::Vector2d x((d.x() - 2560) / 2360, (d.y() - 720) / 620);
        Eigen::Matrix2d jac;
        jac << 0.8 - 0.2 * x.x() * x.x(), 0.02 * x.x(), 0.01 * x.y(), 0.78;
        in.display_px.push_back(d);
        in.jacobian.push_back(jac);
        in.residual_px.push_back(jac * truth(x) + Eigen::Vector2d(normal(rng), normal(rng)));
      }
    }
    if (with_nuisance) {
      // An affine map of the camera image (6 directions), as a pose change would absorb: remove it from the
      // residuals as the verification's homography fit does.
      const int n = static_cast<int>(in.display_px.size());
      in.nuisance.resize(2 * n, 6);
      Eigen::VectorXd r(2 * n);
      for (int k = 0; k < n; ++k) {
        const Eigen::Vector2d q = in.display_px[static_cast<size_t>(k)] / 1000;
        in.nuisance.row(2 * k) << 1, 0, q.x(), q.y(), 0, 0;
        in.nuisance.row(2 * k + 1) << 0, 1, 0, 0, q.x(), q.y();
        r.segment<2>(2 * k) = in.residual_px[static_cast<size_t>(k)];
      }
      const Eigen::MatrixXd q = in.nuisance.householderQr().householderQ() * Eigen::MatrixXd::Identity(2 * n, 6);
      r -= q * (q.transpose() * r);
      for (int k = 0; k < n; ++k) in.residual_px[static_cast<size_t>(k)] = r.segment<2>(2 * k);
    }
    return in;
  }
};

Eigen::Vector2d Zero(const Eigen::Vector2d&) { return Eigen::Vector2d::Zero(); }
Eigen::Vector2d Smooth(const Eigen::Vector2d& x) {
  return {0.4 * x.x() * x.x() * x.x() - 0.2 * x.y(), 0.3 * x.x() * x.y() + 0.1 * std::cos(2 * x.x())};
}

double MaxDifference(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).norm());
  return m;
}

TEST(ErrorField, NoiseAloneIsMeasuredAsNoiseAndTheFieldStaysWithinItsBand) {
  const Scene scene;
  for (double noise : {0.03, 0.1, 0.4}) {
    const ErrorField f = EstimateErrorField(scene.Make(Zero, noise, 3));
    EXPECT_NEAR(f.noise_px, noise, 0.1 * noise) << noise;
    EXPECT_LE(f.degree_u, 2) << "noise alone chose degree " << f.degree_u;
    EXPECT_EQ(std::count(f.outlier.begin(), f.outlier.end(), true), 0);
    // The band scales with the noise: 0.4 / 0.78 display px per coordinate, spread over the few parameters.
    EXPECT_GT(f.band95_display_px, 0.05 * noise / 0.78);
    EXPECT_LT(f.band95_display_px, 2.0 * noise / 0.78);
    EXPECT_LE(MaxDifference(f.value, std::vector<Eigen::Vector2d>(f.value.size(), Eigen::Vector2d::Zero())),
              f.band95_display_px);
  }
}

TEST(ErrorField, ASmoothFieldIsRecoveredAtItsDegreeAndTheNoiseIsNotInflated) {
  const Scene scene;
  const ErrorFieldInput in = scene.Make(Smooth, 0.1, 5);
  const ErrorField f = EstimateErrorField(in);
  EXPECT_GE(f.degree_u, 3);
  EXPECT_NEAR(f.noise_px, 0.1, 0.012);
  std::vector<Eigen::Vector2d> truth;
  for (const Eigen::Vector2d& d : in.display_px) truth.push_back(Smooth({(d.x() - 2560) / 2360, (d.y() - 720) / 620}));
  EXPECT_LE(MaxDifference(f.value, truth), f.band95_display_px);
  EXPECT_LT(MaxDifference(f.value, truth), 0.15);
}

TEST(ErrorField, PlantedOutliersAreLeftOutAndDoNotMoveTheField) {
  const Scene scene;
  ErrorFieldInput in = scene.Make(Smooth, 0.1, 9);
  const ErrorField clean = EstimateErrorField(in);
  for (size_t k : {size_t{10}, size_t{50}, size_t{100}}) in.residual_px[k] += Eigen::Vector2d(3.0, -2.0);
  const ErrorField f = EstimateErrorField(in);
  EXPECT_TRUE(f.outlier[10] && f.outlier[50] && f.outlier[100]);
  EXPECT_EQ(std::count(f.outlier.begin(), f.outlier.end(), true), 3);
  EXPECT_LT(MaxDifference(f.value, clean.value), 0.5 * clean.band95_display_px);
}

// Coverage: over seeded trials, the band must hold max_i |f_hat_i - f_i| in about 95% of them. 120 trials:
// the binomial sd at 95% is 2.0%, so [88%, 99.5%] is a 3.5 sigma acceptance region below and the ceiling above.
void ExpectCoverage(const Scene& scene, const Field& truth_field, double noise) {
  // The target: what the estimator gives without noise (with nuisance directions, the part of the field they
  // cannot absorb).
  const ErrorField target = EstimateErrorField(scene.Make(truth_field, 0, 1));
  int covered = 0;
  const int trials = 120;
  for (int t = 0; t < trials; ++t) {
    ErrorFieldOptions o;
    o.draws = 200;
    o.seed = 1000 + static_cast<uint64_t>(t);
    const ErrorField f = EstimateErrorField(scene.Make(truth_field, noise, 100 + static_cast<uint64_t>(t)), o);
    covered += MaxDifference(f.value, target.value) <= f.band95_display_px ? 1 : 0;
  }
  const double rate = static_cast<double>(covered) / trials;
  ::testing::Test::RecordProperty("coverage", std::to_string(rate));
  std::cout << "band coverage " << covered << " of " << trials << "\n";
  EXPECT_GE(rate, 0.88) << covered << " of " << trials;
  EXPECT_LE(rate, 0.995) << covered << " of " << trials;
}

TEST(ErrorField, TheBandCoversTheFieldIn95PercentOfTrials) {
  ExpectCoverage(Scene{}, Smooth, 0.15);
}

TEST(ErrorField, TheBandCoversWhatTheNuisanceDirectionsLeaveOfTheField) {
  Scene scene;
  scene.with_nuisance = true;
  ExpectCoverage(scene, Smooth, 0.15);
}

// What the nuisance directions absorb (a pose change) is neither error nor uncertainty: the same residuals with
// the directions declared give a narrower band than without them, and the field's low-order part vanishes.
TEST(ErrorField, WhatTheNuisanceAbsorbsCarriesNoUncertainty) {
  Scene scene;
  scene.with_nuisance = true;
  const ErrorFieldInput with = scene.Make(Smooth, 0.03, 21);
  ErrorFieldInput without = with;
  without.nuisance.resize(0, 0);
  ErrorFieldOptions o;
  o.max_degree = 3;  // both at the same degree: Smooth needs 3
  const ErrorField a = EstimateErrorField(with, o), b = EstimateErrorField(without, o);
  ASSERT_EQ(a.degree_u, 3);
  ASSERT_EQ(b.degree_u, 3);
  EXPECT_LT(a.rms_sigma_display_px, 0.8 * b.rms_sigma_display_px)
      << a.rms_sigma_display_px << " vs " << b.rms_sigma_display_px;
}

TEST(ErrorField, TooFewFeaturesOrMismatchedSizesAreErrors) {
  ErrorFieldInput in = Scene{}.Make(Zero, 0.1, 1);
  in.jacobian.pop_back();
  EXPECT_THAT(testing::MessageOf([&] { EstimateErrorField(in); }), ::testing::HasSubstr("do not match"));
  ErrorFieldInput few;
  few.display_px = {{0, 0}, {1, 1}, {2, 0}};
  few.jacobian.assign(3, Eigen::Matrix2d::Identity());
  few.residual_px.assign(3, Eigen::Vector2d::Zero());
  EXPECT_THAT(testing::MessageOf([&] { EstimateErrorField(few); }), ::testing::HasSubstr("at least 4"));
}

}  // namespace
}  // namespace curvecheck

namespace curvecheck {
namespace {

// Pixel-locking of a known amplitude on top of a smooth field and noise, at camera positions whose spacing is
// not a whole number of pixels (the sub-pixel phase walks across the board, as on a real photo): the four
// coefficients come back within 3.5 of their sigmas over 24 seeds, their sigmas match their scatter, and the field,
// its noise and band are those of the field alone (the term is estimated beside them, not inside them).
TEST(ErrorField, PixelLockingIsRecoveredBesideTheField) {
  const Scene scene;
  const Eigen::Vector4d truth(0.045, -0.01, 0.04, 0.015);  // a_x, b_x, a_y, b_y, camera px
  PixelLocking expected;
  expected.estimated = true;
  expected.coefficients = truth;
  constexpr int kSeeds = 24;
  std::vector<double> z[4];
  for (uint64_t seed = 1; seed <= kSeeds; ++seed) {
    ErrorFieldInput clean = scene.Make(Smooth, 0.02, seed);
    ErrorFieldInput biased = clean;
    for (size_t i = 0; i < clean.display_px.size(); ++i) {
      // The camera image of the display: 0.3127 camera px per display px and an offset, so that the phases vary.
      const Eigen::Vector2d q = 0.3127 * clean.display_px[i] + Eigen::Vector2d(17.3, 211.8);
      clean.camera_px.push_back(q);
      biased.camera_px.push_back(q);
      biased.residual_px[i] += expected.BiasAt(q);
    }
    const ErrorField with = EstimateErrorField(biased), without = EstimateErrorField(clean);
    ErrorFieldInput biased_no_positions = biased;
    biased_no_positions.camera_px.clear();
    const ErrorField field_alone = EstimateErrorField(biased_no_positions);
    ASSERT_TRUE(with.pixel_locking.estimated);
    for (int k = 0; k < 4; ++k) {
      const double sigma = std::sqrt(with.pixel_locking.covariance(k, k));
      ASSERT_GT(sigma, 0);
      // 168 features at 0.02 px would give 0.002 px if the columns were orthogonal to the field; along x the
      // phase steps 0.17 cycle per column, slow enough for the chosen field to share part of it: up to 0.02.
      EXPECT_LT(sigma, 0.025) << "coefficient " << k;
      z[k].push_back((with.pixel_locking.coefficients(k) - truth(k)) / sigma);
    }
    EXPECT_LT(without.pixel_locking.Amplitude().maxCoeff(), 0.02) << "no bias, seed " << seed;
    // The verdict's field, noise and band are those of the field alone: the term is reported, not used there.
    EXPECT_EQ(with.noise_px, field_alone.noise_px) << seed;
    EXPECT_EQ(MaxDifference(with.value, field_alone.value), 0) << seed;
    EXPECT_EQ(with.band95_display_px, field_alone.band95_display_px) << seed;
  }
  for (int k = 0; k < 4; ++k) {
    double sum2 = 0;
    for (double v : z[k]) {
      EXPECT_LT(std::abs(v), 3.5) << "coefficient " << k;
      sum2 += v * v;
    }
    // The standardized errors' RMS is 1 when the covariance is right: over 24 draws sqrt(chi2_24 / 24) lies in
    // 0.6-1.46 with probability 99.9%.
    double mean = 0;
    for (double v : z[k]) mean += v / kSeeds;
    std::cout << "pixel-locking coefficient " << k << ": standardized error mean " << mean << ", RMS " << std::sqrt(sum2 / kSeeds) << "\n";
    EXPECT_GT(std::sqrt(sum2 / kSeeds), 0.6) << "coefficient " << k;
    EXPECT_LT(std::sqrt(sum2 / kSeeds), 1.46) << "coefficient " << k;
  }
}

TEST(ErrorField, WithoutCameraPositionsNoPixelLockingIsFitted) {
  const ErrorField f = EstimateErrorField(Scene().Make(Smooth, 0.05, 4));
  EXPECT_FALSE(f.pixel_locking.estimated);
  EXPECT_EQ(f.pixel_locking.BiasAt({10.25, 3.5}), Eigen::Vector2d::Zero());
}

}  // namespace
}  // namespace curvecheck
