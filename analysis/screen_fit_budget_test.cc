// The screen fit's uncertainty budget (screen_fit.h UncertaintyBudget) against ground truth: each row against a
// brute-force or exact figure on synthetic observations (the default scene's camera, cylinder only):
// - pixel pitch: a refit with the pitch scaled by (1 + d) scales R by exactly (1 + d), and the row is R u(p)/p;
// - lens calibration: the propagated covariance against S Sigma S^T with S from full nonlinear refits with each
//   intrinsic perturbed (central differences), for a correlated synthetic Sigma;
// - detector systematic: injected smooth bias fields from the row's own family move the radius by an RMS that
//   matches the row (the linearization is the refit), a radial field the family holds is covered;
// - pixel-locking: an injected sin(2 pi phase) bias of known amplitude is recovered within its sigma, the
//   correction removes the radius shift that bias causes, and under noise alone the correction scatters as the
//   row's pixel-locking share says.
// What it does not prove: that the real detectors' bias is smooth (the assumption the row states).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_internal.h"
#include "analysis/screen_fit_test_util.h"
#include "core/error.h"
#include "core/test_util.h"
#include "core/screen_geometry.h"
#include "core/look_at.h"
#include "pattern/feature_id.h"
#include "synth/lens_misfit.h"
#include "synth/scene.h"
#include "synth/synthetic_camera.h"

namespace curvecheck {
namespace {

using testing::DisplayGrid;
using testing::Observe;
using testing::SceneSurface;

constexpr double kPi = 3.14159265358979323846;

SyntheticScene DefaultScene() {
  return LoadScene(std::filesystem::path(std::getenv("CURVECHECK_SOURCE_DIR")) / "datasets/scenes/default.yaml");
}

FitOptions CylinderOnly() {
  FitOptions o;
  o.models = {ScreenModelKind::kCylinder};
  o.heldout_folds = 0;
  return o;
}

const BudgetComponent& Row(const ModelFit& f, const std::string& name) {
  for (const BudgetComponent& c : f.budget.components) {
    if (c.name == name) return c;
  }
  throw std::runtime_error("no budget row " + name);
}

PhotoObservations Clean(const SyntheticScene& scene, double noise_px = 0, uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  return Observe(scene, DisplayGrid(scene.monitor, 31, 9), noise_px, rng, SceneSurface(scene));
}

TEST(UncertaintyBudgetTest, CoverageFactorIsStudentT) {
  EXPECT_NEAR(StudentTCoverageFactor(0.95, std::numeric_limits<double>::infinity()), 1.959964, 1e-6);
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 3), 3.182, 0.01);  // tables: t_0.975(3) = 3.1824
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 10), 2.2281, 2e-3);
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 100), 1.9840, 1e-4);
  EXPECT_NEAR(StudentTCoverageFactor(0.6827, 1e9), 1.0, 1e-3);
}

TEST(UncertaintyBudgetTest, CoverageFactorConvolvesTheRectangularRow) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  using D = RowDistribution;
  // Normal rows alone: Student's t at their Welch-Satterthwaite dof (two rows of 1 at 10 dof each: 20 dof).
  EXPECT_NEAR(CoverageFactor(0.95, {{1, kInf, D::kNormal}, {2, kInf, D::kNormal}}), 1.959964, 1e-6);
  double dof = 0;
  EXPECT_NEAR(CoverageFactor(0.95, {{1, 10, D::kNormal}, {1, 10, D::kNormal}}, &dof),
              StudentTCoverageFactor(0.95, 20), 1e-9);
  EXPECT_NEAR(dof, 20, 1e-9);
  // The rectangular row alone: p sqrt(3) (JCGM 100 G.2.3: 1.65 for 95%), whatever its size.
  EXPECT_NEAR(CoverageFactor(0.95, {{0.3, kInf, D::kRectangular}}), 0.95 * std::sqrt(3.0), 1e-9);
  EXPECT_NEAR(CoverageFactor(0.6827, {{7, kInf, D::kRectangular}, {0, 5, D::kNormal}}), 0.6827 * std::sqrt(3.0),
              1e-9);
  // A second rectangular row joins the normal part (the largest stays rectangular).
  EXPECT_NEAR(CoverageFactor(0.95, {{1, kInf, D::kRectangular}, {1e-9, kInf, D::kRectangular}}), 0.95 * std::sqrt(3.0),
              1e-6);
  // Mixed: the factor's interval holds p of N(0, u_n^2) + U(-a, a), by seeded Monte Carlo (2e6 draws: binomial
  // sigma 1.5e-4 at 95%, 3.3e-4 at 68%).
  std::mt19937_64 rng(16);
  for (const double ratio : {0.3, 1.0, 3.0}) {  // u(rectangular) / u(normal)
    for (const double p : {0.95, 0.6827}) {
      const double un = 1, ur = ratio, a = std::sqrt(3.0) * ur, uc = std::hypot(un, ur);
      const double k = CoverageFactor(p, {{un, kInf, D::kNormal}, {ur, kInf, D::kRectangular}});
      // Between the two pure cases (at 95% the rectangle's is the smaller, at 68% the larger: 1.18 against 1).
      const double normal_k = StudentTCoverageFactor(p, kInf), rect_k = p * std::sqrt(3.0);
      EXPECT_LT(k, std::max(normal_k, rect_k) + 1e-12) << ratio << " " << p;
      EXPECT_GT(k, std::min(normal_k, rect_k) - 1e-12) << ratio << " " << p;
      std::normal_distribution<double> normal(0, un);
      std::uniform_real_distribution<double> uniform(-a, a);
      constexpr int kDraws = 2000000;
      int inside = 0;
      for (int i = 0; i < kDraws; ++i) inside += std::abs(normal(rng) + uniform(rng)) <= k * uc ? 1 : 0;
      const double sigma = std::sqrt(p * (1 - p) / kDraws);
      EXPECT_NEAR(static_cast<double>(inside) / kDraws, p, 4 * sigma) << "u_r/u_n " << ratio << ", p " << p;
    }
  }
  // Finite dof widen the normal part as Student's t does: between the infinite-dof factor and t alone.
  const double k10 = CoverageFactor(0.95, {{1, 10, D::kNormal}, {1, kInf, D::kRectangular}});
  EXPECT_GT(k10, CoverageFactor(0.95, {{1, kInf, D::kNormal}, {1, kInf, D::kRectangular}}));
  EXPECT_LT(k10, StudentTCoverageFactor(0.95, 10));
  EXPECT_THROW(CoverageFactor(1.0, {{1, kInf, D::kNormal}}), Error);
  EXPECT_THROW(CoverageFactor(0.95, {{-1, kInf, D::kNormal}}), Error);
  EXPECT_THROW(CoverageFactor(0.95, {{std::nan(""), kInf, D::kRectangular}}), Error);
}

// The misfit's lag statistics are weighted by the inverse of their estimated covariance. An estimate with a
// negative eigenvalue -mu is off by at least mu (Weyl), so no direction is weighted above 1 / mu; a positive
// definite estimate well above 1e-6 of its largest eigenvalue is inverted exactly.
TEST(UncertaintyBudgetTest, EstimatedCovarianceWeightFloorsWhatTheEstimateCannotKnow) {
  using screen_fit_internal::EstimatedCovarianceWeight;
  // A rotation, so that the eigenvectors are not the axes.
  const Eigen::Matrix3d v = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Matrix3d pd = v * Eigen::Vector3d(2.0, 0.5, 1e-3).asDiagonal() * v.transpose();
  const std::optional<Eigen::MatrixXd> w_pd = EstimatedCovarianceWeight(pd);
  ASSERT_TRUE(w_pd.has_value());
  EXPECT_LT((*w_pd * pd - Eigen::Matrix3d::Identity()).norm(), 1e-9);
  // Eigenvalues 1, 1e-4 and -0.01: the last two are weighted 1 / 0.01, not 1 / 1e-6 (the floor until 2026-12-06).
  const Eigen::Matrix3d indefinite = v * Eigen::Vector3d(1.0, 1e-4, -0.01).asDiagonal() * v.transpose();
  const std::optional<Eigen::MatrixXd> w = EstimatedCovarianceWeight(indefinite);
  ASSERT_TRUE(w.has_value());
  EXPECT_NEAR(v.col(0).dot(*w * v.col(0)), 1.0, 1e-9);
  EXPECT_NEAR(v.col(1).dot(*w * v.col(1)), 100.0, 1e-6);
  EXPECT_NEAR(v.col(2).dot(*w * v.col(2)), 100.0, 1e-6);
  EXPECT_LT((*w - w->transpose()).norm(), 1e-9);
  // Nothing to weight by.
  EXPECT_FALSE(EstimatedCovarianceWeight(Eigen::Matrix3d::Zero()).has_value());
  EXPECT_FALSE(EstimatedCovarianceWeight(-Eigen::Matrix3d::Identity()).has_value());
  EXPECT_FALSE(EstimatedCovarianceWeight(Eigen::MatrixXd(0, 0)).has_value());
}

// A sampled row (a stated misfit's, NormalisedField) is convolved with the rest by averaging over its draws:
// against closed forms and the unsampled rows it reproduces.
TEST(UncertaintyBudgetTest, CoverageFactorAveragesOverASampledRow) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  using D = RowDistribution;
  const auto phi = [](double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); };
  // A two-point row (+-u) alone: every draw lies at u, so the 95% interval is +- u.
  const std::vector<double> one = {1.0};
  EXPECT_NEAR(CoverageFactor(0.95, {{2, kInf, D::kSampled, &one}}), 1.0, 1e-9);
  // With a normal row of the same u: P(|+-1 + N(0, 1)| <= c) = Phi(c - 1) - Phi(-c - 1), solved by bisection here.
  double lo = 0, hi = 10;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (phi(mid - 1) - phi(-mid - 1) < 0.95 ? lo : hi) = mid;
  }
  EXPECT_NEAR(CoverageFactor(0.95, {{1, kInf, D::kNormal}, {1, kInf, D::kSampled, &one}}), lo / std::sqrt(2.0),
              1e-9);
  // The row's draws at the normal distribution's quantiles (magnitudes at (i + 0.5) / m): as the normal row it
  // stands for, alone and with a rectangular row or a Student's t part (to the draws' discreteness, 1e-3).
  std::vector<double> normal;
  constexpr int kM = 2000;
  for (int i = 0; i < kM; ++i) {
    const double p = 0.5 + 0.5 * (i + 0.5) / kM;
    double a = 0, b = 10;
    for (int j = 0; j < 100; ++j) {
      const double mid = 0.5 * (a + b);
      (phi(mid) < p ? a : b) = mid;
    }
    normal.push_back(a);
  }
  for (const double p : {0.95, kCoverage68}) {
    EXPECT_NEAR(CoverageFactor(p, {{1.5, kInf, D::kSampled, &normal}}), StudentTCoverageFactor(p, kInf), 3e-3);
    for (const double ratio : {0.3, 1.0, 3.0}) {
      EXPECT_NEAR(CoverageFactor(p, {{1, kInf, D::kSampled, &normal}, {ratio, kInf, D::kRectangular}}),
                  CoverageFactor(p, {{1, kInf, D::kNormal}, {ratio, kInf, D::kRectangular}}), 1e-3)
          << ratio;
      // The normal part of 8 dof is widened to u t_p(8) / z_p, normal; with the row's: sqrt(z^2 + r^2 t^2) / u_c.
      const double z = StudentTCoverageFactor(p, kInf), t = StudentTCoverageFactor(p, 8);
      EXPECT_NEAR(CoverageFactor(p, {{1, kInf, D::kSampled, &normal}, {ratio, 8, D::kNormal}}),
                  std::sqrt(z * z + ratio * ratio * t * t) / std::hypot(1.0, ratio), 2e-3)
          << ratio;
    }
  }
  // Without its draws a sampled row is normal; a zero row is ignored.
  EXPECT_NEAR(CoverageFactor(0.95, {{1, kInf, D::kSampled}}), StudentTCoverageFactor(0.95, kInf), 1e-12);
  EXPECT_NEAR(CoverageFactor(0.95, {{1, kInf, D::kNormal}, {0, kInf, D::kSampled, &one}}),
              StudentTCoverageFactor(0.95, kInf), 1e-9);
}

TEST(UncertaintyBudgetTest, RowsArePresentAndCombineInQuadrature) {
  const SyntheticScene scene = DefaultScene();
  const ScreenFitResult r = FitScreen(scene.monitor, scene.camera, {Clean(scene, 0.05)}, CylinderOnly());
  const ModelFit& f = r.Chosen();
  ASSERT_TRUE(f.budget.computed) << f.budget.note;
  ASSERT_EQ(f.budget.components.size(), 5u);
  double sum = 0;
  for (const BudgetComponent& c : f.budget.components) sum += c.radius_mm * c.radius_mm;
  EXPECT_NEAR(f.budget.combined.radius_mm, std::sqrt(sum), 1e-9 * std::sqrt(sum));
  EXPECT_NEAR(*f.radius_sigma_mm, f.budget.combined.radius_mm, 1e-9 * f.budget.combined.radius_mm);
  // The noise row is the covariance's figure; the combined sigma is larger.
  EXPECT_NEAR(Row(f, "detection noise").curvature_per_mm, f.curvature_noise_sigma_per_mm, 1e-15);
  EXPECT_GT(f.curvature_sigma_per_mm, f.curvature_noise_sigma_per_mm);
  // No covariance given: the lens row is 0 and says why.
  EXPECT_EQ(Row(f, "lens calibration").radius_mm, 0);
  EXPECT_NE(Row(f, "lens calibration").assumption.find("taken as exact"), std::string::npos);
  // The interval is k +- t u_c(k), inverted.
  const double k = f.curvature_per_mm, t = f.budget.coverage_factor;
  EXPECT_NEAR(f.radius_ci95_mm[0], 1 / (k + t * f.curvature_sigma_per_mm), 1e-9);
  EXPECT_NEAR(f.radius_ci95_mm[1], 1 / (k - t * f.curvature_sigma_per_mm), 1e-9);
  // ~500 residual dof and type B rows, the pitch row rectangular: the factor from the rows' distributions, between
  // the rectangular row's 1.645 and the normal quantile.
  std::vector<CoverageRow> rows;
  for (const BudgetComponent& c : f.budget.components) rows.push_back({c.curvature_per_mm, c.dof, c.distribution});
  EXPECT_NEAR(t, CoverageFactor(0.95, rows), 1e-12);
  EXPECT_EQ(Row(f, "pixel pitch").distribution, RowDistribution::kRectangular);
  EXPECT_EQ(Row(f, "detection noise").distribution, RowDistribution::kNormal);
  EXPECT_GT(t, 1.645);
  EXPECT_LT(t, 1.96);
  // The 68% interval likewise, with its own factor (between 1 and the rectangle's 1.18).
  const double t68 = f.budget.coverage_factor68;
  EXPECT_NEAR(t68, CoverageFactor(kCoverage68, rows), 1e-12);
  EXPECT_GT(t68, 1.0);
  EXPECT_LT(t68, 0.6827 * std::sqrt(3.0));
  EXPECT_NEAR(f.radius_ci68_mm[0], 1 / (k + t68 * f.curvature_sigma_per_mm), 1e-9);
  EXPECT_NEAR(f.radius_ci68_mm[1], 1 / (k - t68 * f.curvature_sigma_per_mm), 1e-9);
  // The camera's axis-frame sigma is the combined one.
  EXPECT_NEAR(f.cameras[0].position_in_screen_sigma_mm.z(), f.budget.combined.position_in_axis_mm.z(), 1e-9);
}

// Row 2's smooth bias b is the detector's measured scatter (without the pixel-locking signature) unless stated, and
// the row's radius share is proportional to it.
TEST(UncertaintyBudgetTest, SmoothBiasFollowsTheMeasuredScatterUnlessStated) {
  const SyntheticScene scene = DefaultScene();
  const auto fit = [&](double noise_px, const FitOptions& o) {
    return FitScreen(scene.monitor, scene.camera, {Clean(scene, noise_px, 7)}, o).Chosen();
  };
  FitOptions measured = CylinderOnly();
  measured.smooth_bound_from_neighbours = false;  // the scatter itself (the next tests: what neighbours share)
  ASSERT_FALSE(measured.smooth_bias_px.has_value());
  const ModelFit a = fit(0.05, measured), b = fit(0.1, measured);
  ASSERT_TRUE(a.budget.computed && b.budget.computed);
  for (const ModelFit* f : {&a, &b}) {
    // b is the noise row's scatter (the residuals without the signature), exactly.
    EXPECT_DOUBLE_EQ(f->budget.systematic_bound_px, f->budget.pixel_locking.noise_px);
    EXPECT_NE(f->budget.systematic_bound_reason.find("scatter"), std::string::npos);
    EXPECT_NE(Row(*f, "detector systematic").source.find(f->budget.systematic_bound_reason), std::string::npos);
  }
  // The scatter measures the injected noise (0.05 px per coordinate, ~500 residuals: +-3%), and doubles with it.
  EXPECT_NEAR(a.budget.systematic_bound_px, 0.05, 0.005);
  EXPECT_NEAR(b.budget.systematic_bound_px / a.budget.systematic_bound_px, 2.0, 0.15);
  // The smooth share is linear in b: the same scene, so the ratio of the shares is that of the b's.
  EXPECT_NEAR((b.budget.smooth_share_curvature_per_mm / a.budget.smooth_share_curvature_per_mm) /
                  (b.budget.systematic_bound_px / a.budget.systematic_bound_px),
              1.0, 0.05);
  // A fraction scales it; a stated b replaces it (0: no smooth share).
  FitOptions half = measured;
  half.smooth_bias_scatter_fraction = 0.5;
  const ModelFit h = fit(0.05, half);
  EXPECT_NEAR(h.budget.systematic_bound_px, 0.5 * h.budget.pixel_locking.noise_px, 1e-15);
  FitOptions stated = measured;
  stated.smooth_bias_px = 0.02;
  const ModelFit s = fit(0.1, stated);
  EXPECT_EQ(s.budget.systematic_bound_px, 0.02);
  EXPECT_NE(s.budget.systematic_bound_reason.find("stated"), std::string::npos);
  stated.smooth_bias_px = 0;
  EXPECT_EQ(fit(0.1, stated).budget.smooth_share_curvature_per_mm, 0);
  // Out of range: a clear error naming the flag.
  stated.smooth_bias_px = -0.01;
  EXPECT_THROW(stated.Check("test"), Error);
  half.smooth_bias_scatter_fraction = std::nan("");
  EXPECT_THROW(half.Check("test"), Error);
}

// Where the photos measured the random part r of their detections' error (detect.h RefinementNoise), b bounds only
// the rest: b^2 = max(0, s^2 - r^2) + 1.645 u (SmoothBoundPx), at most s. The photos' r^2 are pooled by their
// samples, and so are the standard uncertainties of their r^2.
TEST(UncertaintyBudgetTest, SmoothBiasLeavesOutTheMeasuredRandomPart) {
  using screen_fit_internal::SmoothBoundPx;
  // The bound alone: nothing random leaves b = s; all of it random leaves the 95% bound of the estimates' noise.
  EXPECT_DOUBLE_EQ(SmoothBoundPx(0.1, 500, 0, 0).bound_px, 0.1);
  const double u_r2 = std::sqrt(2.0 / 3000) * 0.01;  // r^2 = 0.01 px^2 from 3000 normal coordinates
  const auto all = SmoothBoundPx(0.1, 500, 0.1, u_r2);
  EXPECT_DOUBLE_EQ(all.difference_px2, 0);
  EXPECT_NEAR(all.margin_px2, 1.645 * std::sqrt(2e-4 / 500 + 2e-4 / 3000), 1e-15);
  EXPECT_NEAR(all.bound_px, std::sqrt(all.margin_px2), 1e-15);
  EXPECT_LT(all.bound_px, 0.35 * 0.1);
  EXPECT_NEAR(SmoothBoundPx(0.1, 1e12, 0.06, 0).bound_px, 0.08, 1e-4);  // 0.08^2 = 0.1^2 - 0.06^2
  EXPECT_DOUBLE_EQ(SmoothBoundPx(0.1, 500, 0.2, u_r2).difference_px2, 0);
  // A less certain r widens the bound.
  EXPECT_GT(SmoothBoundPx(0.1, 500, 0.06, 10 * u_r2).bound_px, SmoothBoundPx(0.1, 500, 0.06, u_r2).bound_px);
  // Through the fit: independent noise of 0.05 px, the random part stated as measured by two photos' detections.
  const SyntheticScene scene = DefaultScene();
  PhotoObservations a = Clean(scene, 0.05, 7), b = Clean(scene, 0.05, 8);
  a.random_error_px = 0.04;
  a.random_error_u_px = 0.002;
  a.random_error_samples = 1000;
  b.random_error_px = 0.06;
  b.random_error_u_px = 0.001;
  b.random_error_samples = 3000;
  FitOptions response = CylinderOnly();
  response.smooth_bound_from_neighbours = false;
  const ModelFit f = FitScreen(scene.monitor, scene.camera, {a, b}, response).Chosen();
  ASSERT_TRUE(f.budget.computed);
  const double pooled = std::sqrt((1000 * 0.04 * 0.04 + 3000 * 0.06 * 0.06) / 4000);
  const double pooled_u_r2 = std::hypot(1000 * 2 * 0.04 * 0.002, 3000 * 2 * 0.06 * 0.001) / 4000;
  const double s = f.budget.pixel_locking.noise_px;
  const double dof = Row(f, "detection noise").dof;
  EXPECT_NEAR(f.budget.systematic_bound_px, SmoothBoundPx(s, dof, pooled, pooled_u_r2).bound_px, 1e-15);
  EXPECT_LT(f.budget.systematic_bound_px, 0.6 * s);
  EXPECT_NE(f.budget.systematic_bound_reason.find("random part r = " + fmt::format("{:.4f}", pooled)),
            std::string::npos)
      << f.budget.systematic_bound_reason;
  // The smooth share follows b (the same fit without the measurement: b = s).
  PhotoObservations a0 = a, b0 = b;
  a0.random_error_samples = b0.random_error_samples = 0;
  const ModelFit g = FitScreen(scene.monitor, scene.camera, {a0, b0}, response).Chosen();
  EXPECT_DOUBLE_EQ(g.budget.systematic_bound_px, g.budget.pixel_locking.noise_px);
  EXPECT_NEAR((f.budget.smooth_share_curvature_per_mm / g.budget.smooth_share_curvature_per_mm) /
                  (f.budget.systematic_bound_px / g.budget.systematic_bound_px),
              1.0, 0.05);
}

// The photo plus a smooth field over the image, RMS 0.04 px per coordinate before a fit absorbs part of it.
PhotoObservations WithSmoothField(const SyntheticScene& scene, PhotoObservations photo) {
  const double w_img = scene.camera.width, h_img = scene.camera.height;
  for (Eigen::Vector2d& q : photo.detected_px) {
    const double x = 2 * q.x() / w_img - 1, y = 2 * q.y() / h_img - 1;
    q += 0.04 * std::sqrt(2.0) * Eigen::Vector2d(std::sin(2.5 * kPi * x) * std::cos(1.5 * kPi * y),
                                                  std::cos(2.0 * kPi * x + 0.7) * std::sin(1.5 * kPi * y));
  }
  return photo;
}

// By default b bounds only the part of the scatter that neighbouring features share (WhiteScatterPx: second
// differences along the lattice). Independent errors leave b at the 95% bound of the two estimates' difference; a
// smooth field that the fit does not absorb is kept whole; the difference's stated uncertainty is its spread.
TEST(UncertaintyBudgetTest, SmoothBiasBoundsWhatNeighboursShare) {
  using screen_fit_internal::SmoothBoundFromPart;
  const SyntheticScene scene = DefaultScene();
  const FitOptions o = CylinderOnly();
  ASSERT_TRUE(o.smooth_bound_from_neighbours);
  // White noise of 0.05 px, 24 seeds: w measures it, b is the margin alone.
  std::vector<double> difference, u;
  for (uint64_t seed = 1; seed <= 24; ++seed) {
    const ModelFit f = FitScreen(scene.monitor, scene.camera, {Clean(scene, 0.05, seed)}, o).Chosen();
    ASSERT_TRUE(f.budget.computed);
    const UncertaintyBudget& b = f.budget;
    const double s = b.pixel_locking.noise_px;
    ASSERT_GT(b.white_scatter_triples, 400);  // 31 x 9 features: rows, columns and diagonals
    EXPECT_NEAR(b.white_scatter_px, 0.05, 0.006) << seed;
    EXPECT_LT(b.systematic_bound_px, 0.5 * s) << seed;
    EXPECT_NEAR(b.systematic_bound_px, SmoothBoundFromPart(s, b.white_scatter_px, b.white_scatter_u_difference_px2).bound_px,
                1e-15);
    difference.push_back(s * s - b.white_scatter_px * b.white_scatter_px);
    u.push_back(b.white_scatter_u_difference_px2);
    if (seed == 1) {
      EXPECT_NE(b.systematic_bound_reason.find("neighbouring corners share"), std::string::npos) << b.systematic_bound_reason;
      EXPECT_NE(Row(f, "detector systematic").source.find(fmt::format("w = {:.4f} px", b.white_scatter_px)),
                std::string::npos);
    }
  }
  double mean = 0, var = 0;
  for (double d : difference) mean += d / 24;
  for (double d : difference) var += (d - mean) * (d - mean) / 23;
  std::sort(u.begin(), u.end());
  const double u_median = 0.5 * (u[11] + u[12]);
  // The spread over seeds against the stated u (24 seeds know an SD to +-15%).
  EXPECT_GT(std::sqrt(var) / u_median, 0.6) << std::sqrt(var) << " " << u_median;
  EXPECT_LT(std::sqrt(var) / u_median, 1.5) << std::sqrt(var) << " " << u_median;
  // Unbiased: within one standard error (the fit's pixel-locking shapes taken out of the second differences' share;
  // without that, +3.6e-5 px^2 here, 1.9 standard errors).
  EXPECT_LT(std::abs(mean), u_median / std::sqrt(24.0)) << mean;
  // White noise of 0.03 px and a smooth field over the image (RMS 0.04 px per coordinate before the fit absorbs
  // part of it): w is the white part, b at least what the fit left of the field.
  const PhotoObservations photo = WithSmoothField(scene, Clean(scene, 0.03, 5));
  const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
  ASSERT_TRUE(f.budget.computed);
  const double s = f.budget.pixel_locking.noise_px;
  EXPECT_NEAR(f.budget.white_scatter_px, 0.03, 0.004);
  ASSERT_GT(s, 0.036);  // what the fit left of the field shows in the residuals
  // b^2 at least the field's share of s^2 less twice the standard uncertainty of s^2 - w^2 (w's own scatter: 0.0327
  // px here with 30 signature columns removed, 9% over the white 0.03).
  const double b = f.budget.systematic_bound_px;
  EXPECT_GT(b * b, s * s - 0.03 * 0.03 - 2 * f.budget.white_scatter_u_difference_px2)
      << s << " " << f.budget.white_scatter_px << " " << b << " " << f.budget.white_scatter_u_difference_px2;
  // Switched off, b is the scatter (no random part measured).
  FitOptions off = o;
  off.smooth_bound_from_neighbours = false;
  const ModelFit g = FitScreen(scene.monitor, scene.camera, {photo}, off).Chosen();
  EXPECT_DOUBLE_EQ(g.budget.systematic_bound_px, g.budget.pixel_locking.noise_px);
  EXPECT_EQ(g.budget.white_scatter_triples, 0);
}

// The detection-noise row's independence is tested on the lattice (NoiseIndependenceCheck). White noise passes
// the test, its z centred on 0 with unit spread (24 seeds); a y error that alternates from row to row of the board
// (the detector's error at 3 m, 40 deg: docs/bench/validity_bench.txt, fortieth section) fails it, negatively
// correlated along the screen's columns and positively along its rows; a smooth field that the fit leaves fails it
// with positive correlation.
TEST(UncertaintyBudgetTest, DetectionNoiseIndependenceIsTested) {
  const SyntheticScene scene = DefaultScene();
  const FitOptions o = CylinderOnly();
  constexpr int kSeeds = 24;
  int independent = 0;
  Eigen::Matrix2d z_sum = Eigen::Matrix2d::Zero(), z2_sum = Eigen::Matrix2d::Zero();
  for (uint64_t seed = 1; seed <= kSeeds; ++seed) {
    const ModelFit f = FitScreen(scene.monitor, scene.camera, {Clean(scene, 0.05, seed)}, o).Chosen();
    const UncertaintyBudget::NoiseIndependence& ni = f.budget.noise_independence;
    ASSERT_TRUE(ni.tested) << seed;
    // 31 x 9 corners: 30 x 9 pairs along the screen's rows, 31 x 8 along its columns.
    EXPECT_EQ(ni.pairs[0], 270);
    EXPECT_EQ(ni.pairs[1], 248);
    ASSERT_TRUE(ni.z.allFinite());
    independent += ni.independent ? 1 : 0;
    z_sum += ni.z;
    z2_sum += ni.z.cwiseAbs2();
    // What the fit makes of independent errors: slightly negative (-H_ab), a few hundredths.
    EXPECT_LT(ni.null_correlation.maxCoeff(), 0) << seed;
    EXPECT_GT(ni.null_correlation.minCoeff(), -0.1) << seed;
    if (seed == 1) {
      EXPECT_NE(Row(f, "detection noise").assumption.find(ni.summary), std::string::npos);
      EXPECT_NE(ni.summary.find("consistent with independence"), std::string::npos) << ni.summary;
    }
  }
  // Four z per seed at |z| < 3: a seed fails by chance with probability ~1%.
  EXPECT_GE(independent, kSeeds - 2);
  // Each z has mean 0 and variance 1 under independence: over 24 seeds the mean within 4 standard errors (0.2) of
  // 0, the mean square within 0.45-1.8 (chi-square of 24 dof: 1st and 99.9th percentiles 0.45 and 2.1).
  std::cerr << "mean z " << (z_sum / kSeeds).transpose() << ", mean z^2 " << (z2_sum / kSeeds).transpose() << "\n";
  EXPECT_LT((z_sum / kSeeds).cwiseAbs().maxCoeff(), 0.8) << z_sum / kSeeds;
  EXPECT_GT((z2_sum / kSeeds).minCoeff(), 0.45) << z2_sum / kSeeds;
  EXPECT_LT((z2_sum / kSeeds).maxCoeff(), 2.1) << z2_sum / kSeeds;
  // White noise of 0.03 px and a y error of +-0.05 px alternating from row to row of the board.
  PhotoObservations photo = Clean(scene, 0.03, 7);
  ASSERT_EQ(photo.detected_px.size(), 31u * 9u);
  for (size_t k = 0; k < photo.detected_px.size(); ++k) photo.detected_px[k].y() += (k / 31) % 2 ? 0.05 : -0.05;
  const ModelFit alternating = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
  const UncertaintyBudget::NoiseIndependence& na = alternating.budget.noise_independence;
  ASSERT_TRUE(na.tested);
  EXPECT_FALSE(na.independent);
  // y: its alternating part's share of y's variance, 0.05^2 / (0.05^2 + 0.03^2) = 0.74, with the sign of the step.
  EXPECT_NEAR(na.correlation(1, 1), -0.74, 0.1) << na.summary;  // along the screen's columns
  EXPECT_NEAR(na.correlation(1, 0), 0.74, 0.1) << na.summary;   // along its rows
  EXPECT_LT(na.z(1, 1), -8) << na.summary;
  EXPECT_LT(std::abs(na.z(0, 0)), 3) << na.summary;  // x untouched
  EXPECT_LT(std::abs(na.z(0, 1)), 3) << na.summary;
  EXPECT_NE(Row(alternating, "detection noise").assumption.find("not independent"), std::string::npos);
  // A smooth field over the image (the test above's): positively correlated.
  const UncertaintyBudget::NoiseIndependence ns =
      FitScreen(scene.monitor, scene.camera, {WithSmoothField(scene, Clean(scene, 0.03, 5))}, o)
          .Chosen()
          .budget.noise_independence;
  ASSERT_TRUE(ns.tested);
  EXPECT_FALSE(ns.independent);
  EXPECT_GT(ns.z.maxCoeff(), 3) << ns.summary;
  EXPECT_GT(ns.z.minCoeff(), -3) << ns.summary;
}

TEST(UncertaintyBudgetTest, PixelPitchRowIsTheExactScaling) {
  const SyntheticScene scene = DefaultScene();
  const PhotoObservations photo = Clean(scene);
  FitOptions o = CylinderOnly();
  o.pitch_tolerance_relative = 0.003;
  const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
  const double r = *f.radius_mm;
  EXPECT_NEAR(Row(f, "pixel pitch").radius_mm, r * 0.003 / std::sqrt(3.0), 1e-9 * r);
  // The photos scale with the pitch: the same detections on a monitor with a 1% larger pitch give a 1% larger R.
  Monitor bigger = scene.monitor;
  bigger.width_mm *= 1.01;
  bigger.height_mm *= 1.01;
  const ModelFit g = FitScreen(bigger, scene.camera, {photo}, o).Chosen();
  EXPECT_NEAR(*g.radius_mm / r, 1.01, 1e-6) << r << " " << *g.radius_mm;
  EXPECT_NEAR(g.cameras[0].position_in_centre_mm.z() / f.cameras[0].position_in_centre_mm.z(), 1.01, 1e-6);
  EXPECT_NEAR(Row(f, "pixel pitch").position_in_centre_mm.z(),
              f.cameras[0].position_in_centre_mm.z() * 0.003 / std::sqrt(3.0), 1e-6);
}

TEST(UncertaintyBudgetTest, LensRowMatchesBruteForceRefits) {
  const SyntheticScene scene = DefaultScene();
  const PhotoObservations photo = Clean(scene);
  const int n = static_cast<int>(scene.camera.intrinsics.size());
  // A correlated covariance: sigma_i = 0.5 px for fx, fy, cx, cy and 2e-4 for the distortion terms, with a
  // seeded correlation (A A^T, A = diag(sigma) (I + 0.3 R), R uniform in [-1, 1]).
  Eigen::VectorXd sig(n);
  for (int i = 0; i < n; ++i) sig[i] = i < 4 ? 0.5 : 2e-4;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uni(-1, 1);
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) a(i, j) += 0.3 * uni(rng);
  }
  a = sig.asDiagonal() * a;
  const Eigen::MatrixXd sigma = a * a.transpose();
  FitOptions o = CylinderOnly();
  o.intrinsics_covariance = sigma;
  o.intrinsics_covariance_source = "test";
  const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
  // Brute force: dk/dc_i and dc/dc_i by refitting with c_i +- its sigma.
  Eigen::MatrixXd s(4, n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector4d q[2];
    for (int side = 0; side < 2; ++side) {
      CameraModel cam = scene.camera;
      cam.intrinsics[static_cast<size_t>(i)] += (side == 0 ? 1 : -1) * sig[i];
      const ModelFit g = FitScreen(scene.monitor, cam, {photo}, CylinderOnly()).Chosen();
      q[side] << g.curvature_per_mm, g.cameras[0].position_in_centre_mm;
    }
    s.col(i) = (q[0] - q[1]) / (2 * sig[i]);
  }
  const Eigen::MatrixXd cov = s * sigma * s.transpose();
  const BudgetComponent& lens = Row(f, "lens calibration");
  EXPECT_NEAR(lens.curvature_per_mm, std::sqrt(cov(0, 0)), 0.03 * std::sqrt(cov(0, 0)));
  for (int ax = 0; ax < 3; ++ax) {
    EXPECT_NEAR(lens.position_in_centre_mm[ax], std::sqrt(cov(1 + ax, 1 + ax)), 0.03 * std::sqrt(cov(1 + ax, 1 + ax)))
        << ax;
  }
  std::cout << "lens row u(R) " << lens.radius_mm << " mm, brute force "
            << std::sqrt(cov(0, 0)) / (f.curvature_per_mm * f.curvature_per_mm) << " mm\n";
  EXPECT_GT(lens.radius_mm, 0.1);  // the test means something: the lens moves R measurably
}

// A smooth bias field (a Legendre combination, as the row's family) of RMS b_px per coordinate.
std::vector<Eigen::Vector2d> Field(const CameraModel& cam, const std::vector<Eigen::Vector2d>& at, int degree, double b_px,
                                   std::mt19937_64& rng) {
  const Eigen::MatrixXd basis = LegendreFieldBasis(at, cam.width, cam.height, degree);
  std::normal_distribution<double> unit(0, 1);
  Eigen::VectorXd ax(basis.cols()), ay(basis.cols());
  for (long i = 0; i < basis.cols(); ++i) ax[i] = unit(rng), ay[i] = unit(rng);
  const Eigen::VectorXd fx = basis * ax, fy = basis * ay;
  const double rms = std::sqrt((fx.squaredNorm() + fy.squaredNorm()) / (2.0 * fx.size()));
  std::vector<Eigen::Vector2d> out;
  for (long i = 0; i < fx.size(); ++i) out.emplace_back(b_px * fx[i] / rms, b_px * fy[i] / rms);
  return out;
}

// Fits of the photo with each of `fields` smooth bias fields of the row's family (RMS b_px, drawn from rng) added.
std::vector<ModelFit> FitsWithInjectedFields(const SyntheticScene& scene, const PhotoObservations& photo,
                                             const FitOptions& o, double b_px, int fields, std::mt19937_64& rng) {
  std::vector<ModelFit> out;
  for (int d = 0; d < fields; ++d) {
    PhotoObservations biased = photo;
    const auto field = Field(scene.camera, photo.detected_px, o.systematic_field_degree, b_px, rng);
    for (size_t i = 0; i < field.size(); ++i) biased.detected_px[i] += field[i];
    out.push_back(FitScreen(scene.monitor, scene.camera, {biased}, o).Chosen());
  }
  return out;
}

// The radius before the pixel-locking correction (the reported one less it).
double UncorrectedRadiusMm(const ModelFit& f) {
  return 1 / (f.curvature_per_mm - f.budget.pixel_locking_correction_curvature_per_mm);
}

TEST(UncertaintyBudgetTest, SystematicRowMatchesTheRadiusShiftOfInjectedFields) {
  const SyntheticScene scene = DefaultScene();
  const PhotoObservations photo = Clean(scene);
  constexpr double kBiasPx = 0.05;
  FitOptions o = CylinderOnly();
  o.smooth_bias_px = kBiasPx;  // the stated smooth bias: the injected fields' RMS
  const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
  const BudgetComponent& sys = Row(f, "detector systematic");
  EXPECT_NEAR(f.budget.systematic_bound_px, kBiasPx, 1e-12) << f.budget.systematic_bound_reason;
  std::mt19937_64 rng(99);  // not the row's seed
  double sum2 = 0, worst = 0;
  constexpr int kFields = 30;
  for (const ModelFit& g : FitsWithInjectedFields(scene, photo, o, kBiasPx, kFields, rng)) {
    const double shift = *g.radius_mm - *f.radius_mm;
    sum2 += shift * shift;
    worst = std::max(worst, std::abs(shift));
  }
  const double rms = std::sqrt(sum2 / kFields);
  std::cout << "systematic row u(R) " << sys.radius_mm << " mm; injected fields: RMS shift " << rms << " mm, largest "
            << worst << " mm\n";
  // 30 draws: the RMS is known to ~13% (1 sigma); the bound neither misses nor exceeds it by more than 3x.
  EXPECT_GT(sys.radius_mm, 0.7 * rms);
  EXPECT_LT(sys.radius_mm, 1.4 * rms);
  EXPECT_LT(worst, 3 * sys.radius_mm);
  // A radial field (a lens-like bias, degree 3, in the family's span): its shift is covered at k = 2.
  PhotoObservations radial = photo;
  std::vector<Eigen::Vector2d> v;
  double ms = 0;
  for (const Eigen::Vector2d& q : photo.detected_px) {
    const Eigen::Vector2d x(2 * q.x() / (scene.camera.width - 1) - 1, 2 * q.y() / (scene.camera.height - 1) - 1);
    v.push_back(x * x.squaredNorm());
    ms += x.squaredNorm() * x.squaredNorm() * x.squaredNorm() / 2;
  }
  for (size_t i = 0; i < v.size(); ++i) radial.detected_px[i] += kBiasPx * v[i] / std::sqrt(ms / v.size());
  const double shift = *FitScreen(scene.monitor, scene.camera, {radial}, o).Chosen().radius_mm - *f.radius_mm;
  std::cout << "radial field: shift " << shift << " mm\n";
  EXPECT_LT(std::abs(shift), 2 * sys.radius_mm);
}

// The default scene's board seen from the distance along the camera's axis (near 3 m, the camera at quarter
// resolution) where its horizontal corner spacing at the centre is 0.01 px above a whole number of pixels: the x
// phases beat slowly and symmetrically across the image, so the pixel-locking shapes' refit projections are
// themselves smooth fields and the fit absorbs much of an x signature into the curvature.
constexpr int kNx = 31, kNy = 9;
double CentreSpacing(const SyntheticScene& scene) {
  std::mt19937_64 rng(1);
  const PhotoObservations p = Observe(scene, DisplayGrid(scene.monitor, kNx, kNy), 0, rng, SceneSurface(scene));
  const int i = (kNy / 2) * kNx + kNx / 2;
  return p.detected_px[static_cast<size_t>(i + 1)].x() - p.detected_px[static_cast<size_t>(i)].x();
}
SyntheticScene NearWholeSpacingScene(SyntheticScene scene) {
  const Eigen::Vector3d at_1_5m = scene.screen_from_cam.translation;
  const auto spacing_at = [&](double d) {
    scene.screen_from_cam.translation = at_1_5m * d;
    return CentreSpacing(scene);
  };
  // The translation scaled by d (the frame's origin is on the axis, so not the distance itself): secant steps on
  // the spacing to the whole number below the one at d = 2, plus 0.01 px.
  const double target = std::floor(spacing_at(2)) + 0.01;
  double d0 = 2, d1 = 2.05, f0 = spacing_at(d0) - target, f1 = spacing_at(d1) - target;
  for (int it = 0; it < 8 && std::abs(f1) > 1e-4; ++it) {
    const double d2 = d1 - f1 * (d1 - d0) / (f1 - f0);
    d0 = d1, f0 = f1, d1 = d2, f1 = spacing_at(d1) - target;
  }
  scene.screen_from_cam.translation = at_1_5m * d1;
  EXPECT_NEAR(CentreSpacing(scene) - std::floor(CentreSpacing(scene)), 0.01, 0.002);
  return scene;
}

// Where the pixel-locking shapes' refit projections are smooth (NearWholeSpacingScene: a frontal board from near
// 3 m at quarter resolution), the corrected estimate answers a smooth bias field through G - G S M (the fitted
// signature takes up part of the field), not through G: smooth fields of the row's family, injected noise-free,
// move the corrected radius by an RMS that the row's smooth share matches. Measured: share 2.75 mm, corrected R
// 3.17 mm RMS, uncorrected 3.21 mm: the signature takes up little of a degree-3 field even here, so this test
// checks the row at this geometry; it does not tell G from G - G S M.
TEST(UncertaintyBudgetTest, SmoothRowFollowsTheCorrectedEstimateWhereTheSignatureIsSmooth) {
  SyntheticScene scene = DefaultScene();
  scene.camera = ScaledCamera(scene.camera, 0.25);
  scene = NearWholeSpacingScene(scene);
  const PhotoObservations photo = Clean(scene);
  constexpr double kBiasPx = 0.05;
  FitOptions o = CylinderOnly();
  o.smooth_bias_px = kBiasPx;
  const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
  const double k2 = f.curvature_per_mm * f.curvature_per_mm;
  const double share_mm = f.budget.smooth_share_curvature_per_mm / k2;
  std::mt19937_64 rng(99);
  double sum2 = 0, sum2_uncorrected = 0;
  constexpr int kFields = 30;
  for (const ModelFit& g : FitsWithInjectedFields(scene, photo, o, kBiasPx, kFields, rng)) {
    sum2 += std::pow(*g.radius_mm - *f.radius_mm, 2) / kFields;
    sum2_uncorrected += std::pow(UncorrectedRadiusMm(g) - UncorrectedRadiusMm(f), 2) / kFields;
  }
  std::cout << "smooth share of u(R) " << share_mm << " mm; injected fields move the corrected R by "
            << std::sqrt(sum2) << " mm RMS, the uncorrected R by " << std::sqrt(sum2_uncorrected) << " mm\n";
  EXPECT_GT(share_mm, 0.7 * std::sqrt(sum2));
  EXPECT_LT(share_mm, 1.4 * std::sqrt(sum2));
}

// The detector's pixel-locking signature as the budget models it, added to detections: per coordinate c,
// b(c, 0) sin 2 pi q + b(c, 1) cos 2 pi q (the period of 1 px) + b(c, 2) sin pi q + b(c, 3) cos pi q (2 px).
// A sin(2 pi q / T + psi) is the pair (A cos psi, A sin psi) of period T (SinCos).
using Signature = Eigen::Matrix<double, 2, 4>;
void AddSignature(const Signature& b, std::vector<Eigen::Vector2d>* detected_px) {
  for (Eigen::Vector2d& q : *detected_px) {
    for (int c = 0; c < 2; ++c) {
      const double p1 = 2 * kPi * q[c], p2 = kPi * q[c];
      q[c] += b(c, 0) * std::sin(p1) + b(c, 1) * std::cos(p1) + b(c, 2) * std::sin(p2) + b(c, 3) * std::cos(p2);
    }
  }
}
Eigen::RowVector2d SinCos(double amplitude, double psi) {
  return amplitude * Eigen::RowVector2d(std::cos(psi), std::sin(psi));
}

// The display positions whose true images form a regular grid of kNx x kNy corners, spacing_px apart in x and
// y, centred on the image of the screen's centre: a pattern corrected exactly for the camera's viewpoint (what
// curvecheck checks), whose rows and columns are straight and evenly spaced in the photo. Newton steps on the display
// position of each corner (the projection's Jacobian by central differences).
std::vector<Eigen::Vector2d> CorrectedBoard(const SyntheticScene& scene, double spacing_px) {
  const auto image_of = [&](const Eigen::Vector2d& display_px) {
    const Eigen::Vector3d p = TrueSurfacePointInScreen(scene, UvFromDisplayPx(scene.monitor, display_px));
    return ProjectPoints(scene.camera, {scene.screen_from_cam.Inverse() * p}).front();
  };
  const Eigen::Vector2d centre_display(0.5 * scene.monitor.width_px - 0.5, 0.5 * scene.monitor.height_px - 0.5);
  const Eigen::Vector2d centre = image_of(centre_display);
  std::vector<Eigen::Vector2d> out;
  for (int j = 0; j < kNy; ++j) {
    for (int i = 0; i < kNx; ++i) {
      const Eigen::Vector2d target = centre + spacing_px * Eigen::Vector2d(i - (kNx - 1) / 2.0, j - (kNy - 1) / 2.0);
      Eigen::Vector2d d = centre_display;
      for (int it = 0; it < 8; ++it) {
        Eigen::Matrix2d jac;
        for (int a = 0; a < 2; ++a) {
          const Eigen::Vector2d h = Eigen::Vector2d::Unit(a) * 0.5;
          jac.col(a) = image_of(d + h) - image_of(d - h);
        }
        d += jac.inverse() * (target - image_of(d));
      }
      out.push_back(d);
    }
  }
  return out;
}
// The pixel-locking correction where the product works: a pattern corrected for the camera's viewpoint, a
// regular grid in the photo (CorrectedBoard), seen frontally from near 3 m at quarter resolution. The rows then
// share nearly one phase and the fit absorbs much of the signature: a signature of 0.05 px per coefficient (drawn
// per seed) moves the uncorrected radius by some 20-30 mm RMS, against 3-6 mm of noise. Over 16 seeds with 0.03 px
// noise the corrected radius's error, in units of its combined standard uncertainty, has an RMS within 0.6-1.4
// and at least 13 of 16 within the 95% interval (a binomial tail of 0.7% for a correct 95%): with the shapes'
// phases taken at the fit's predictions (until the twentieth session, 2026-12-05) the RMS was 2.15 at a spacing
// of 14.25 px. At a spacing of 14.02 px (all rows within 0.18 of a period of one phase) the y coefficients are
// nearly undetermined: without the prior the regression gives amplitudes of 2.5 px and an RMS of 2.95 (2.45 with
// the phases at the predictions); with it the coefficients stay within the prior and the interval holds.
TEST(UncertaintyBudgetTest, PixelLockingCorrectionHoldsOnACorrectedBoard) {
  SyntheticScene scene = DefaultScene();
  scene.camera = ScaledCamera(scene.camera, 0.25);
  scene.screen_from_cam.translation *= 2;  // 1.5 m -> 3 m
  constexpr int kSeeds = 16;
  constexpr double kNoisePx = 0.03, kCoefficientPx = 0.05;
  for (double spacing : {14.25, 14.02}) {
    const std::vector<Eigen::Vector2d> board = CorrectedBoard(scene, spacing);
    std::mt19937_64 unused(1);
    const PhotoObservations exact = Observe(scene, board, 0, unused, SceneSurface(scene));
    const double r0 = *FitScreen(scene.monitor, scene.camera, {exact}, CylinderOnly()).Chosen().radius_mm;
    EXPECT_NEAR(r0, 1 / scene.truth.curvature_per_mm, 0.01);
    for (double prior : {FitOptions{}.pixel_locking_prior_px, 0.0}) {
      if (prior == 0 && spacing != 14.02) continue;
      FitOptions o = CylinderOnly();
      o.smooth_bias_px = 0;  // the rows tested: noise and the signature's correction
      o.pixel_locking_prior_px = prior;
      std::mt19937_64 rng(5);
      std::normal_distribution<double> coefficient(0, kCoefficientPx);
      double z2 = 0, uncorrected2 = 0, u = 0, amplitude = 0;
      int in95 = 0;
      for (int seed = 1; seed <= kSeeds; ++seed) {
        std::mt19937_64 noise(static_cast<uint64_t>(seed));
        PhotoObservations photo = Observe(scene, board, kNoisePx, noise, SceneSurface(scene));
        Signature b;
        for (double& x : b.reshaped()) x = coefficient(rng);
        AddSignature(b, &photo.detected_px);
        const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
        const double uc = f.budget.combined.radius_mm, z = (*f.radius_mm - r0) / uc;
        z2 += z * z / kSeeds;
        in95 += std::abs(z) < f.budget.coverage_factor;
        uncorrected2 += std::pow(UncorrectedRadiusMm(f) - r0, 2) / kSeeds;
        u += uc / kSeeds;
        amplitude = std::max(amplitude, f.budget.pixel_locking.amplitude_px.maxCoeff());
      }
      std::cout << "spacing " << spacing << " px, prior " << prior << " px: uncorrected R off by "
                << std::sqrt(uncorrected2) << " mm RMS; corrected: RMS z " << std::sqrt(z2) << ", " << in95 << "/"
                << kSeeds << " in the 95% interval, mean u(R) " << u << " mm; largest fitted amplitude " << amplitude
                << " px\n";
      if (prior > 0) {
        // At 14.02 px the cross-phase terms (screen_fit_internal.h SignatureLayout) are nearly undetermined too and
        // hold about their prior: u(R) 8.1 mm, against 3.2 mm at 14.25 px (2026-12-07).
        EXPECT_GT(std::sqrt(uncorrected2), (spacing < 14.1 ? 2 : 3) * u)
            << spacing << ": the signature must matter for the test to fail";
        EXPECT_GT(std::sqrt(z2), 0.6) << spacing;
        EXPECT_LT(std::sqrt(z2), 1.4) << spacing;
        EXPECT_GE(in95, 13) << spacing;
        EXPECT_LT(amplitude, 4 * prior) << spacing;
      } else {
        EXPECT_GT(amplitude, 1.0) << "without the prior the nearly undetermined coefficients run off";
      }
    }
  }
}

// The colour filter array's 2 x 2 cell and the checkerboard corner's polarity (screen_fit_internal.h
// SignatureLayout), on the corrected board from 3 m at quarter resolution: a detector error of the polarity p (+-1 by
// row + column) times 0.05 px in x and -0.04 px in y, p sin(phase x) 0.03 px in x, and the cross terms 0.04
// cos(phase x) sin(phase y) px in x and 0.03 sin(phase x) px in y (the phases in 2 px), with 0.03 px noise, 16
// seeds. The fit finds p's coefficients (each within 4 of its sigma; over the seeds the mean within 4 standard
// errors, the scatter below 1.5 sigma, sigma below the effect) and the corrected radius's error has an RMS of
// 0.6-1.4 of its combined standard uncertainty, at least 13 of 16 intervals holding the truth, at two spacings:
// 14.25 px, where the phases spread over the period, and 13.95 px, nearly seven periods of 2 px (the validity
// bench's frontal geometry, there with the lens's distortion and the camera's jitter). This board is exactly regular
// in the photo, its phases drift linearly, and at 13.95 px the cross terms are smooth fields the curvature takes
// up: they stay within their prior and u(R) is some 22 mm (2026-12-07), the price of not knowing them. Under ids
// that are not a checkerboard's no polarity is fitted.
TEST(UncertaintyBudgetTest, CellAndPolarityTermsAreFittedAndCorrectedFor) {
  SyntheticScene scene = DefaultScene();
  scene.camera = ScaledCamera(scene.camera, 0.25);
  scene.screen_from_cam.translation *= 2;  // 1.5 m -> 3 m
  constexpr int kSeeds = 16;
  constexpr double kTwoPi = 6.283185307179586;
  for (const double spacing : {14.25, 13.95}) {
    const std::vector<Eigen::Vector2d> board = CorrectedBoard(scene, spacing);
    std::mt19937_64 unused(1);
    const PhotoObservations exact = Observe(scene, board, 0, unused, SceneSurface(scene));
    ASSERT_EQ(exact.ids.size(), board.size());
    const double r0 = *FitScreen(scene.monitor, scene.camera, {exact}, CylinderOnly()).Chosen().radius_mm;
    FitOptions o = CylinderOnly();
    o.smooth_bias_px = 0;  // the rows tested: noise and the signature's correction
    const Eigen::Vector2d polarity(0.05, -0.04);
    double z2 = 0, uncorrected2 = 0, u = 0;
    int in95 = 0;
    std::array<std::vector<double>, 2> estimate;
    Eigen::Vector2d sigma = Eigen::Vector2d::Zero();
    for (int seed = 1; seed <= kSeeds; ++seed) {
      std::mt19937_64 noise(static_cast<uint64_t>(seed));
      PhotoObservations photo = Observe(scene, board, 0.03, noise, SceneSurface(scene));
      for (size_t k = 0; k < photo.ids.size(); ++k) {
        const std::optional<long> index = CornerIndexOfId(photo.ids[k]);
        ASSERT_TRUE(index) << photo.ids[k];
        const long row = *index / kNx, col = *index % kNx;
        const double p = (row + col) % 2 == 0 ? 1 : -1;
        const Eigen::Vector2d q = exact.detected_px[k];
        const double fx = kTwoPi * (q.x() / 2 - std::floor(q.x() / 2));
        const double fy = kTwoPi * (q.y() / 2 - std::floor(q.y() / 2));
        photo.detected_px[k] += Eigen::Vector2d(polarity.x() * p + 0.03 * p * std::sin(fx) +
                                                    0.04 * std::cos(fx) * std::sin(fy),
                                                polarity.y() * p + 0.03 * std::sin(fx));
      }
      const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
      const ResidualPixelLocking& pl = f.budget.pixel_locking;
      ASSERT_EQ(pl.polarity_corners, static_cast<int>(board.size())) << seed;
      for (int c = 0; c < 2; ++c) {
        EXPECT_NEAR(pl.polarity_px[c], polarity[c], 4 * pl.polarity_sigma_px[c]) << seed << " " << c;
        estimate[c].push_back(pl.polarity_px[c]);
        sigma[c] += pl.polarity_sigma_px[c] / kSeeds;
      }
      const double uc = f.budget.combined.radius_mm, z = (*f.radius_mm - r0) / uc;
      z2 += z * z / kSeeds;
      in95 += std::abs(z) < f.budget.coverage_factor;
      uncorrected2 += std::pow(UncorrectedRadiusMm(f) - r0, 2) / kSeeds;
      u += uc / kSeeds;
      if (seed == 1) {
        PhotoObservations renamed = photo;
        for (std::string& id : renamed.ids) id = "f" + id.substr(1);
        EXPECT_EQ(
            FitScreen(scene.monitor, scene.camera, {renamed}, o).Chosen().budget.pixel_locking.polarity_corners, 0);
      }
    }
    std::cout << "cell and polarity terms, spacing " << spacing << " px: uncorrected R off by "
              << std::sqrt(uncorrected2) << " mm RMS; corrected: RMS z " << std::sqrt(z2) << ", " << in95 << "/"
              << kSeeds << " in the 95% interval, mean u(R) " << u << " mm\n";
    EXPECT_GT(std::sqrt(z2), 0.6) << spacing;
    EXPECT_LT(std::sqrt(z2), 1.4) << spacing;
    EXPECT_GE(in95, 13) << spacing;
    // p's coefficient over the seeds: its mean within 4 standard errors of the truth, its scatter below 1.5 times the
    // stated sigma and the sigma below the effect (the polarity is seen).
    for (int c = 0; c < 2; ++c) {
      double mean = 0, var = 0;
      for (const double e : estimate[c]) mean += e / kSeeds;
      for (const double e : estimate[c]) var += (e - mean) * (e - mean) / (kSeeds - 1);
      std::cout << "  polarity " << c << ": mean " << mean << " px (truth " << polarity[c] << "), sd " << std::sqrt(var)
                << ", mean sigma " << sigma[c] << "\n";
      EXPECT_NEAR(mean, polarity[c], 4 * sigma[c] / std::sqrt(double{kSeeds})) << spacing << " " << c;
      EXPECT_LT(std::sqrt(var), 1.5 * sigma[c]) << spacing << " " << c;
      EXPECT_LT(sigma[c], std::abs(polarity[c])) << spacing << " " << c;
    }
  }
}

// The lens-model-misfit row: with independent noise only, the measured misfit is near 0 and the row small; with
// a smooth field added (the row's family, and a field of another family: the synthetic camera's random-cosine
// lens misfit), the RMS is recovered and the row covers the radius shift the fields cause.
TEST(UncertaintyBudgetTest, LensMisfitIsMeasuredFromTheResidualsAndCoversItsShift) {
  const SyntheticScene scene = DefaultScene();
  constexpr double kNoise = 0.05, kField = 0.1;
  FitOptions o = CylinderOnly();
  const PhotoObservations noisy = Clean(scene, kNoise, 5);
  const ModelFit f0 = FitScreen(scene.monitor, scene.camera, {noisy}, o).Chosen();
  std::cout << "noise only: misfit estimate " << f0.budget.misfit_estimate_px << " px, bound "
            << f0.budget.misfit_bound_px << " px, kappa " << f0.budget.misfit_kappa << ", row u(R) "
            << Row(f0, "lens model misfit").radius_mm << " mm\n";
  EXPECT_LT(f0.budget.misfit_estimate_px, 0.3 * kField);
  EXPECT_GE(f0.budget.misfit_bound_px, f0.budget.misfit_estimate_px);
  const double r0 = *FitScreen(scene.monitor, scene.camera, {Clean(scene)}, o).Chosen().radius_mm;
  for (int family = 0; family < 2; ++family) {
    std::mt19937_64 rng(17);
    double est = 0, shift2 = 0, row2 = 0;
    constexpr int kFields = 12;
    for (int d = 0; d < kFields; ++d) {
      PhotoObservations biased = Clean(scene, kNoise, 100 + static_cast<uint64_t>(d));
      PhotoObservations clean = Clean(scene);
      std::vector<Eigen::Vector2d> field;
      if (family == 0) {
        field = Field(scene.camera, clean.detected_px, o.misfit_field_degree, kField, rng);
      } else {
        Imaging g = ImagingFromPreset(ImagingPreset::kIlc24);
        g.lens_misfit_px = kField;
        g.lens_seed = static_cast<uint64_t>(d + 1);
        const LensMisfit m(g, scene.camera.width, scene.camera.height);
        for (const Eigen::Vector2d& q : clean.detected_px) field.push_back(m.At(q));
      }
      for (size_t i = 0; i < field.size(); ++i) biased.detected_px[i] += field[i];
      const ModelFit g = FitScreen(scene.monitor, scene.camera, {biased}, o).Chosen();
      est += g.budget.misfit_estimate_px / kFields;
      shift2 += (*g.radius_mm - r0) * (*g.radius_mm - r0) / kFields;
      row2 += Row(g, "lens model misfit").radius_mm * Row(g, "lens model misfit").radius_mm / kFields;
    }
    std::cout << (family == 0 ? "Legendre fields" : "random-cosine fields (synth)") << " of RMS " << kField
              << " px: mean estimate " << est << " px; RMS radius shift " << std::sqrt(shift2) << " mm, row u(R) "
              << std::sqrt(row2) << " mm (RMS over " << kFields << " fields)\n";
    if (family == 0) {
      EXPECT_NEAR(est, kField, 0.25 * kField);
    }
    // The shift includes the noise's own (about the noise row); the row must not fall short of the shift.
    EXPECT_GT(std::sqrt(row2) + Row(f0, "detection noise").radius_mm, 0.7 * std::sqrt(shift2));
  }
}

// The calibration's stated misfit (FitOptions::stated_lens_misfit_px, as curvecheck calibrate writes it beside the
// model) against the radius shifts of the true lens's fields: 24 lenses of the synthetic camera's family (a
// Gaussian field of RMS 0.1 px at a length of 0.2 x the width, synth/lens_misfit.h), noise-free observations, so
// that each shift is the field's own. The row is the stated field's unless the residuals' field is significantly
// larger (noise-free, it often is here), and its u(R) is the RMS of the shifts within their sampling error
// (24 fields: the RMS to +-15% at 1 sigma); it scales with the stated RMS exactly. Without the statement the row
// from the residuals alone covers them too: its RMS within the same bounds and 20 or more of the 24 shifts inside
// 1.96 of it. (Until 2026-12-06 it did not: 0.94 mm RMS against shifts of 1.40 mm, 16 of 24 inside; the lag
// statistics' generalized least squares weighted directions of their estimated covariance that the estimate
// could not know by up to 1e6 / its largest eigenvalue, EstimatedCovarianceWeight.)
TEST(UncertaintyBudgetTest, StatedLensMisfitRowMatchesTheRadiusShiftsOfTheLensFields) {
  const SyntheticScene scene = DefaultScene();
  constexpr double kField = 0.1;
  Imaging g = ImagingFromPreset(ImagingPreset::kIlc24);
  g.lens_misfit_px = kField;
  FitOptions o = CylinderOnly();
  o.stated_lens_misfit_px = kField;
  o.stated_lens_misfit_length_px = g.lens_misfit_length * scene.camera.width;
  o.stated_lens_misfit_source = "test";
  const PhotoObservations clean = Clean(scene);
  const ModelFit f0 = FitScreen(scene.monitor, scene.camera, {clean}, o).Chosen();
  const double r0 = *f0.radius_mm;
  const double row0 = Row(f0, "lens model misfit").radius_mm;
  EXPECT_EQ(f0.budget.misfit_row_basis, "calibration");
  EXPECT_EQ(Row(f0, "lens model misfit").type, "B");
  EXPECT_NEAR(f0.budget.stated_misfit_share_curvature_per_mm / (f0.curvature_per_mm * f0.curvature_per_mm), row0,
              1e-6 * row0);
  // Twice the stated RMS: twice the row (the field's propagation is linear).
  FitOptions twice = o;
  twice.stated_lens_misfit_px = 2 * kField;
  const ModelFit f2 = FitScreen(scene.monitor, scene.camera, {clean}, twice).Chosen();
  EXPECT_NEAR(Row(f2, "lens model misfit").radius_mm, 2 * row0, 1e-6 * row0);
  constexpr int kLenses = 24;
  double shift2 = 0, row2 = 0, photo_row2 = 0;
  int inside = 0, photo_inside = 0;
  FitOptions photo_only = o;
  photo_only.stated_lens_misfit_px = 0;
  for (int d = 0; d < kLenses; ++d) {
    g.lens_seed = static_cast<uint64_t>(d + 1);
    const LensMisfit m(g, scene.camera.width, scene.camera.height);
    PhotoObservations biased = clean;
    for (Eigen::Vector2d& q : biased.detected_px) q += m.At(q);
    const ModelFit f = FitScreen(scene.monitor, scene.camera, {biased}, o).Chosen();
    const ModelFit p = FitScreen(scene.monitor, scene.camera, {biased}, photo_only).Chosen();
    const double shift = *f.radius_mm - r0, row = Row(f, "lens model misfit").radius_mm;
    shift2 += shift * shift / kLenses;
    row2 += row * row / kLenses;
    photo_row2 += Row(p, "lens model misfit").radius_mm * Row(p, "lens model misfit").radius_mm / kLenses;
    if (std::abs(shift) <= 1.96 * row) ++inside;  // the row alone: the shift is the field's alone
    if (std::abs(*p.radius_mm - r0) <= 1.96 * Row(p, "lens model misfit").radius_mm) ++photo_inside;
  }
  std::cout << "stated misfit " << kField << " px at " << o.stated_lens_misfit_length_px << " px: row u(R) "
            << std::sqrt(row2) << " mm (noise-free: " << row0 << "), RMS radius shift " << std::sqrt(shift2)
            << " mm over " << kLenses << " lenses; " << inside << " inside 1.96 sigma; the row from the residuals "
            << "alone " << std::sqrt(photo_row2) << " mm RMS, " << photo_inside << " inside 1.96 of it\n";
  EXPECT_GT(std::sqrt(row2), 0.7 * std::sqrt(shift2));
  EXPECT_LT(std::sqrt(row2), 1.4 * std::sqrt(shift2));
  EXPECT_GE(inside, 20);  // 95% of 24: 22.8; P(X < 20) = 3% for a 95% interval
  EXPECT_GT(std::sqrt(photo_row2), 0.7 * std::sqrt(shift2));
  EXPECT_LT(std::sqrt(photo_row2), 1.4 * std::sqrt(shift2));
  EXPECT_GE(photo_inside, 20);
}

// The random-feature bases have the covariances they state: the mean of phi_a . phi_b over features is
// exp(-d^2 / 2 L^2) (Gaussian) and J0(2 pi d / P) (ring, negative beyond 0.38 P) within the features' sampling
// error, ~1/sqrt(2 x features).
TEST(UncertaintyBudgetTest, FieldBasesHaveTheirStatedCovariances) {
  constexpr int kFeatures = 20000;
  constexpr double kScale = 40;  // px: L and P
  std::vector<Eigen::Vector2d> points = {{100, 200}};
  for (double d : {0.0, 10.0, 20.0, 30.0, 40.0, 60.0}) points.emplace_back(100 + 0.6 * d, 200 + 0.8 * d);
  const Eigen::MatrixXd g = GaussianFieldFeatures(kScale, kFeatures, 3).At(points);
  const Eigen::MatrixXd r = RingFieldFeatures(kScale, kFeatures, 4).At(points);
  for (size_t i = 1; i < points.size(); ++i) {
    const double d = (points[i] - points[0]).norm();
    const double cg = g.row(0).dot(g.row(static_cast<long>(i))), cr = r.row(0).dot(r.row(static_cast<long>(i)));
    EXPECT_NEAR(cg, std::exp(-d * d / (2 * kScale * kScale)), 0.03) << "d " << d;
    EXPECT_NEAR(cr, std::cyl_bessel_j(0.0, 2 * M_PI * d / kScale), 0.03) << "d " << d;
  }
  EXPECT_LT(r.row(0).dot(r.row(3)), -0.2);  // d = 0.5 P: J0(pi) = -0.30
  // A row depends on its point only: the fit evaluates a photo's points at a time and must get the rows of the
  // basis over all points (bit for bit: the budget's numbers may not depend on how the points were grouped).
  const FieldFeatures ring_features = RingFieldFeatures(kScale, kFeatures, 4);
  for (size_t i = 0; i < points.size(); ++i) {
    const FieldBasis one = ring_features.At({points[i]});
    EXPECT_EQ(one.rows(), 1);
    EXPECT_TRUE((one.row(0).array() == r.row(static_cast<long>(i)).array()).all()) << "point " << i;
  }
  // A budget component's basis (MisfitComponentFeatures: its family's, the budget's seeds) and its stated covariance
  // (MisfitComponentCovariance, what calibrate/projection_compare.cc adds cell to cell): variance s^2 times the
  // family's correlation, which the basis reproduces.
  FitOptions o;
  o.misfit_features = kFeatures;
  for (const UncertaintyBudget::FieldFamily family :
       {UncertaintyBudget::FieldFamily::kGaussian, UncertaintyBudget::FieldFamily::kRing}) {
    UncertaintyBudget::FieldComponent c;
    c.family = family;
    c.length_px = kScale;
    c.variance_px2 = 2.5;
    const bool ring = family == UncertaintyBudget::FieldFamily::kRing;
    const Eigen::MatrixXd phi = MisfitComponentFeatures(c, o).At(points);
    for (size_t i = 0; i < points.size(); ++i) {
      const double d = (points[i] - points[0]).norm();
      const double expected =
          ring ? std::cyl_bessel_j(0.0, 2 * M_PI * d / kScale) : std::exp(-d * d / (2 * kScale * kScale));
      EXPECT_NEAR(MisfitComponentCovariance(c, d), 2.5 * expected, 1e-12) << (ring ? "ring" : "gaussian") << " d " << d;
      EXPECT_NEAR(2.5 * phi.row(0).dot(phi.row(static_cast<long>(i))), 2.5 * expected, 2.5 * 0.03)
          << (ring ? "ring" : "gaussian") << " d " << d;
    }
  }
}

// A band-pass correlated error (ring fields, covariance J0(2 pi d / P): the beat of the features' spacing against a
// pixel grid, whose correlation changes sign) is measured as one: the row takes a ring component for it, covers
// the radius shift such fields cause, and is not several times that shift (Gaussian fields fitted to the same
// correlation put power at long range, where it moves the radius: the realistic camera's frontal trials in the
// validity bench came out with radius sigmas ~2x their scatter).
TEST(UncertaintyBudgetTest, BandPassErrorIsMeasuredAsARingAndNotAsALongRangeField) {
  const SyntheticScene scene = DefaultScene();
  constexpr double kNoise = 0.05, kField = 0.1;
  FitOptions o = CylinderOnly();
  const PhotoObservations clean = Clean(scene);
  const double r0 = *FitScreen(scene.monitor, scene.camera, {clean}, o).Chosen().radius_mm;
  const ModelFit f0 = FitScreen(scene.monitor, scene.camera, {Clean(scene, kNoise, 5)}, o).Chosen();
  const double period = 8 * f0.budget.misfit_spacing_px;
  ASSERT_GT(period, 0);
  std::mt19937_64 rng(23);
  std::normal_distribution<double> unit(0, 1);
  double shift2 = 0, row2 = 0;
  int rings = 0;
  constexpr int kFields = 12;
  for (int d = 0; d < kFields; ++d) {
    const Eigen::MatrixXd basis = RingFieldFeatures(period, 400, 1000 + static_cast<unsigned>(d)).At(clean.detected_px);
    Eigen::VectorXd ax(basis.cols()), ay(basis.cols());
    for (long i = 0; i < basis.cols(); ++i) ax[i] = unit(rng), ay[i] = unit(rng);
    const Eigen::VectorXd fx = basis * ax, fy = basis * ay;
    const double rms = std::sqrt((fx.squaredNorm() + fy.squaredNorm()) / (2.0 * static_cast<double>(fx.size())));
    PhotoObservations biased = Clean(scene, kNoise, 200 + static_cast<uint64_t>(d));
    for (size_t i = 0; i < biased.detected_px.size(); ++i) {
      biased.detected_px[i] += kField / rms * Eigen::Vector2d(fx[static_cast<long>(i)], fy[static_cast<long>(i)]);
    }
    const ModelFit g = FitScreen(scene.monitor, scene.camera, {biased}, o).Chosen();
    for (const UncertaintyBudget::FieldComponent& c : g.budget.misfit_components) {
      if (c.family == UncertaintyBudget::FieldFamily::kRing && c.variance_px2 > 0.25 * kField * kField) ++rings;
    }
    shift2 += (*g.radius_mm - r0) * (*g.radius_mm - r0) / kFields;
    row2 += Row(g, "lens model misfit").radius_mm * Row(g, "lens model misfit").radius_mm / kFields;
  }
  const double noise_row = Row(f0, "detection noise").radius_mm;
  std::cout << "ring fields of RMS " << kField << " px, period " << period << " px: a ring of variance > "
            << 0.25 * kField * kField << " px^2 taken in " << rings << " of " << kFields << "; RMS radius shift "
            << std::sqrt(shift2) << " mm, row u(R) " << std::sqrt(row2) << " mm, noise row " << noise_row << " mm\n";
  // The component's identity is the weaker claim (9 of 12 since the lag statistics are weighted by their own
  // covariance, 12 of 12 under independent weights, when the row was 0.70 of the shift); the radius is the claim.
  EXPECT_GE(rings, kFields * 3 / 4);
  EXPECT_GT(std::sqrt(row2) + noise_row, 0.7 * std::sqrt(shift2));
  EXPECT_LT(std::sqrt(row2), 1.5 * std::sqrt(shift2));
}

// Model choice under a lens model misfit (issue 16): one photo from 1.5 m at 30 deg yaw (where the validity bench
// saw richer models chosen in 22 of 48 trials, their intervals missing the truth), detections through a true lens
// that departs from the model by random-cosine fields of 0.1 px RMS (synth/lens_misfit, a new lens per trial) plus
// 0.05 px of noise, every model a candidate. Measured (seeds 300-307, lenses 700-707): the white-noise choice
// (max_lens_misfit_relative 0) took a richer model in 6 of 8 trials, the choice with the misfit as a correlated
// error in 2 (both of whose intervals held the truth), and the chosen interval held the truth in 8 of 8. A real
// lean of 0.3 deg, beyond what the field explains, is still found.
TEST(UncertaintyBudgetTest, LensMisfitIsNotTakenForScreenShape) {
  SyntheticScene scene = DefaultScene();
  const Eigen::Vector3d centre = ScreenCentreInScreen(scene.monitor);
  const Eigen::Vector3d at =
      centre + 1500 * (Eigen::AngleAxisd(30 * kPi / 180, Eigen::Vector3d::UnitY()) * Eigen::Vector3d::UnitZ());
  scene.screen_from_cam = ScreenFromCamLookAt(at, centre, Eigen::Vector3d::UnitY());
  const double true_radius = 1 / scene.monitor.curvature_per_mm;
  constexpr double kNoise = 0.05, kField = 0.1;
  constexpr int kTrials = 8;
  FitOptions adjusted;
  adjusted.detection_noise_px = kNoise;
  FitOptions white = adjusted;
  white.max_lens_misfit_relative = 0;
  const auto photo = [&](int trial, const testing::SurfaceFn& surface) {
    std::mt19937_64 rng(300 + static_cast<uint64_t>(trial));
    PhotoObservations p = Observe(scene, DisplayGrid(scene.monitor, 31, 9), kNoise, rng, surface);
    Imaging g = ImagingFromPreset(ImagingPreset::kIlc24);
    g.lens_misfit_px = kField;
    g.lens_seed = 700 + static_cast<uint64_t>(trial);
    const LensMisfit m(g, scene.camera.width, scene.camera.height);
    for (Eigen::Vector2d& q : p.detected_px) q += m.At(q);
    return p;
  };
  int richer_adjusted = 0, richer_white = 0, covered = 0;
  double mean_field = 0;
  for (int t = 0; t < kTrials; ++t) {
    const PhotoObservations p = photo(t, SceneSurface(scene));
    const ScreenFitResult a = FitScreen(scene.monitor, scene.camera, {p}, adjusted);
    const ScreenFitResult w = FitScreen(scene.monitor, scene.camera, {p}, white);
    const ModelFit& c = a.Chosen();
    std::cout << "trial " << t << ": lens field " << a.lens_field_px << " px; adjusted " << c.model << " R "
              << (c.radius_mm ? *c.radius_mm : 0) << " [" << c.radius_ci95_mm[0] << ", " << c.radius_ci95_mm[1]
              << "]; white " << w.Chosen().model << " R " << (w.Chosen().radius_mm ? *w.Chosen().radius_mm : 0)
              << "\n";
    mean_field += a.lens_field_px / kTrials;
    EXPECT_TRUE(c.adequate) << c.adequacy_note;
    richer_adjusted += c.model != "cylinder";
    richer_white += w.Chosen().model != "cylinder";
    covered += c.radius_mm && c.radius_ci95_mm[0] <= true_radius && true_radius <= c.radius_ci95_mm[1];
  }
  // The field is measured in the misfit family (Legendre, degree 6) and as the smallest over the candidates: a
  // random-cosine field of 0.1 px puts part of its energy outside the family, so the figure is below 0.1 px.
  EXPECT_GT(mean_field, 0.2 * kField);
  EXPECT_LT(mean_field, 1.5 * kField);
  EXPECT_LE(richer_adjusted, 2);
  EXPECT_LE(2 * richer_adjusted, richer_white);
  EXPECT_GE(covered, kTrials - 1);
  EXPECT_GE(richer_white, 4) << "the white-noise choice no longer errs here: the test cannot fail";
  // A lean of 0.3 deg (the cylinder's residuals 0.5 px, five times the field) is still a shape.
  const ScreenFitResult lean = FitScreen(scene.monitor, scene.camera, {photo(0, testing::AxisLeanSurface(scene, 0.3))},
                                         adjusted);
  EXPECT_EQ(lean.Chosen().model, "cylinder+lean") << lean.choice_reason;
}

// Amplitude of the least-squares fit of (1, sin 2 pi phi, cos 2 pi phi) to the residuals of one coordinate, phi the
// detection's subpixel phase: the regression on the unprojected shapes that the budget used until 2026-12-05.
double UnprojectedAmplitude(const PhotoObservations& photo, const ModelFit& f, int c) {
  Eigen::MatrixXd x(static_cast<long>(photo.detected_px.size()), 3);
  Eigen::VectorXd y(x.rows());
  for (long i = 0; i < x.rows(); ++i) {
    const double q = photo.detected_px[static_cast<size_t>(i)][c], phase = 2 * kPi * (q - std::floor(q));
    x.row(i) << 1, std::sin(phase), std::cos(phase);
    y[i] = f.residual_px[0][static_cast<size_t>(i)][c];
  }
  return (x.transpose() * x).ldlt().solve(x.transpose() * y).tail<2>().norm();
}

TEST(UncertaintyBudgetTest, PixelLockingAmplitudeIsRecoveredThroughTheFit) {
  // Detections biased per coordinate c by A_c1 sin(2 pi phase_1 + psi_c) + A_c2 sin(2 pi phase_2 + psi_c + 1) with
  // phase_T = frac(q / T) (the sampling's period and a colour filter array's) plus 0.02 px noise, 8 noise seeds, the default
  // scene at quarter resolution: from 1.5 m on its normal, and from the distance (near 3 m) where the board's
  // horizontal corner spacing at the centre is 0.01 px above a whole number of pixels, so that the x phases beat
  // slowly and symmetrically across the image and the fit absorbs much of the x signature into the curvature. The
  // budget fits the coefficients on the shapes' refit projections: its mean amplitude is the injected one within
  // 2.5 standard errors of the mean, and its estimates scatter as its sigma says. The regression on the
  // unprojected shapes (the budget's until 2026-12-05) recovers there only what the fit left.
  constexpr double kA[2][2] = {{0.03, 0.015}, {0.02, 0.025}}, kPsi[2] = {0.0, 0.7}, kNoise = 0.02;
  constexpr int kSeeds = 8;
  for (bool near_whole : {false, true}) {
    SyntheticScene scene = DefaultScene();
    scene.camera = ScaledCamera(scene.camera, 0.25);
    if (near_whole) scene = NearWholeSpacingScene(scene);
    FitOptions o = CylinderOnly();
    o.noise_floor_px = 0.01;
    Eigen::Matrix2d sum = Eigen::Matrix2d::Zero(), sum2 = sum, sigma2 = sum;
    std::array<double, 2> unprojected{};
    for (int seed = 1; seed <= kSeeds; ++seed) {
      PhotoObservations photo = Clean(scene, kNoise, static_cast<uint64_t>(seed));
      Signature b;
      for (int c = 0; c < 2; ++c) b.row(c) << SinCos(kA[c][0], kPsi[c]), SinCos(kA[c][1], kPsi[c] + 1);
      AddSignature(b, &photo.detected_px);
      const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
      const ResidualPixelLocking& got = f.budget.pixel_locking;
      ASSERT_TRUE(got.amplitude_px.allFinite() && (got.sigma_px.array() > 0).all());
      sum += got.amplitude_px, sum2 += got.amplitude_px.cwiseAbs2(), sigma2 += got.sigma_px.cwiseAbs2();
      for (int c = 0; c < 2; ++c) unprojected[c] += UnprojectedAmplitude(photo, f, c) / kSeeds;
    }
    for (int c = 0; c < 2; ++c) {
      for (int t = 0; t < 2; ++t) {
        const double mean = sum(c, t) / kSeeds, sigma = std::sqrt(sigma2(c, t) / kSeeds);
        const double sd = std::sqrt(std::max(0.0, sum2(c, t) / kSeeds - mean * mean) * kSeeds / (kSeeds - 1));
        std::cout << (near_whole ? "near-whole spacing" : "1.5 m") << ", coordinate " << c << ", period " << t + 1
                  << " px: injected " << kA[c][t] << " px; through the fit " << mean << " (scatter " << sd
                  << ", sigma " << sigma << ")";
        if (t == 0) std::cout << "; unprojected period-1 regression " << unprojected[c];
        std::cout << "\n";
        EXPECT_NEAR(mean, kA[c][t], 2.5 * sigma / std::sqrt(kSeeds)) << near_whole << " " << c << " " << t;
        EXPECT_GT(sd, 0.4 * sigma) << near_whole << " " << c << " " << t;
        EXPECT_LT(sd, 2.0 * sigma) << near_whole << " " << c << " " << t;
      }
    }
    if (near_whole) {
      EXPECT_LT(unprojected[0], 0.85 * kA[0][0]) << "the fit absorbs little here: the test cannot fail";
    }
  }
}

// The pixel-locking correction (the fitted signature's effect removed from the curvature, its uncertainty the
// systematic row's pixel-locking share). A sin(2 pi phase + psi) injected noise-free at four phase offsets psi, in a
// period of 1 px and of 2 px (a colour filter array's): the uncorrected radius (the reported one less the
// correction) moves by an RMS of 0.05 mm or more (0.137 mm in period 1, 0.064 mm in period 2), the corrected one by
// less than 0.002 of that (1e-5 mm; 0.0011 mm with the shapes' phases at the fit's predictions, before
// the twentieth session, 2026-12-05: 0.008 of it). Under noise alone
// (no signature, 16 seeds) the correction is the fitted noise's projection on the shapes: its RMS over the seeds is
// the share the row reports.
TEST(UncertaintyBudgetTest, PixelLockingCorrectionRemovesTheRadiusShiftItCauses) {
  const SyntheticScene scene = DefaultScene();
  const PhotoObservations clean = Clean(scene);
  FitOptions o = CylinderOnly();
  const double r0 = *FitScreen(scene.monitor, scene.camera, {clean}, o).Chosen().radius_mm;
  constexpr double kA = 0.03;
  for (double period : {1.0, 2.0}) {
    double sum2 = 0, sum2_uncorrected = 0;
    for (int j = 0; j < 4; ++j) {
      const double psi = 0.5 * kPi * j;
      PhotoObservations photo = clean;
      Signature b = Signature::Zero();
      for (int c = 0; c < 2; ++c) b.block<1, 2>(c, period == 1 ? 0 : 2) = SinCos(kA, psi);
      AddSignature(b, &photo.detected_px);
      const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
      sum2 += (*f.radius_mm - r0) * (*f.radius_mm - r0) / 4;
      sum2_uncorrected += (UncorrectedRadiusMm(f) - r0) * (UncorrectedRadiusMm(f) - r0) / 4;
    }
    std::cout << "period " << period << " px: the injected signature moves R by " << std::sqrt(sum2_uncorrected)
              << " mm RMS over 4 phase offsets uncorrected, " << std::sqrt(sum2) << " mm corrected\n";
    EXPECT_GT(std::sqrt(sum2_uncorrected), 0.05) << period;  // the signature does move the radius
    EXPECT_LT(std::sqrt(sum2), 0.002 * std::sqrt(sum2_uncorrected)) << period;
  }
  constexpr int kSeeds = 16;
  double correction2 = 0, share = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const ModelFit f = FitScreen(scene.monitor, scene.camera, {Clean(scene, 0.02, static_cast<uint64_t>(seed))}, o)
                           .Chosen();
    correction2 += std::pow(*f.radius_mm - UncorrectedRadiusMm(f), 2) / kSeeds;
    share += f.budget.pixel_locking_share_curvature_per_mm / (f.curvature_per_mm * f.curvature_per_mm) / kSeeds;
  }
  std::cout << "noise alone: correction RMS " << std::sqrt(correction2) << " mm over " << kSeeds
            << " seeds; the row's pixel-locking share " << share << " mm\n";
  EXPECT_GT(std::sqrt(correction2), 0.6 * share);
  EXPECT_LT(std::sqrt(correction2), 1.5 * share);
}

// A tag detector that places the tags' black borders outward of where they are moves each corner along its tag's
// diagonal; as the tags' size changes across the photo this reads as curvature. 16 x 4 tags (corners "t<id>.<k>",
// a tag 0.6 of its pitch wide) seen by the default scene's camera, each border shifted outward by 0.4 px in x and
// 0.25 px in y, with 0.03 px noise, 8 seeds: the fit's signature finds the shifts (within 4 of their sigmas) and the
// corrected radius is the unshifted photos' (RMS difference below 5% of the shift's effect). The same observations
// under ids that are not tags' corners (no border shift fitted) keep the whole effect.
TEST(UncertaintyBudgetTest, TagBorderShiftIsFittedAndCorrectedFor) {
  const SyntheticScene scene = DefaultScene();
  const std::vector<Eigen::Vector2d> centres = DisplayGrid(scene.monitor, 16, 4, 0.08);
  const double half = 0.3 * (centres[1].x() - centres[0].x());
  std::vector<Eigen::Vector2d> corners;
  for (const Eigen::Vector2d& c : centres) {
    for (const Eigen::Vector2d& d : {Eigen::Vector2d(-1, 1), Eigen::Vector2d(1, 1), Eigen::Vector2d(1, -1),
                                     Eigen::Vector2d(-1, -1)}) {
      corners.push_back(c + half * d);
    }
  }
  std::mt19937_64 none(1);
  const PhotoObservations truth = Observe(scene, corners, 0, none, SceneSurface(scene));
  ASSERT_EQ(truth.ids.size(), corners.size());  // every tag whole in the photo
  const auto tagged = [](PhotoObservations p, bool tags) {
    for (size_t i = 0; i < p.ids.size(); ++i) p.ids[i] = tags ? fmt::format("t{}.{}", i / 4, i % 4) : fmt::format("c{}", i);
    return p;
  };
  const Eigen::Vector2d shift(0.4, 0.25);
  FitOptions o = CylinderOnly();
  constexpr int kSeeds = 8;
  double moved2 = 0, kept2 = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    std::mt19937_64 rng(static_cast<uint64_t>(seed));
    std::normal_distribution<double> noise(0, 0.03);
    PhotoObservations plain = truth, shifted = truth;
    for (size_t t = 0; t < corners.size(); t += 4) {
      Eigen::Vector2d centre = Eigen::Vector2d::Zero();
      for (size_t k = 0; k < 4; ++k) centre += truth.detected_px[t + k] / 4;
      for (size_t k = 0; k < 4; ++k) {
        const Eigen::Vector2d e(noise(rng), noise(rng));
        const Eigen::Vector2d u = (truth.detected_px[t + k] - centre).normalized();
        plain.detected_px[t + k] += e;
        shifted.detected_px[t + k] += e + std::sqrt(2.0) * shift.cwiseProduct(u);
      }
    }
    const ModelFit reference = FitScreen(scene.monitor, scene.camera, {tagged(plain, true)}, o).Chosen();
    const ModelFit fitted = FitScreen(scene.monitor, scene.camera, {tagged(shifted, true)}, o).Chosen();
    const ModelFit blind = FitScreen(scene.monitor, scene.camera, {tagged(shifted, false)}, o).Chosen();
    const ResidualPixelLocking& pl = fitted.budget.pixel_locking;
    ASSERT_EQ(pl.tag_border_corners, static_cast<int>(corners.size()));
    for (int c = 0; c < 2; ++c) {
      EXPECT_NEAR(pl.tag_border_shift_px[c], shift[c], 4 * pl.tag_border_shift_sigma_px[c]) << seed << " " << c;
      EXPECT_LT(pl.tag_border_shift_sigma_px[c], 0.01) << seed << " " << c;
    }
    EXPECT_EQ(blind.budget.pixel_locking.tag_border_corners, 0);
    moved2 += std::pow(*fitted.radius_mm - *reference.radius_mm, 2) / kSeeds;
    kept2 += std::pow(*blind.radius_mm - *reference.radius_mm, 2) / kSeeds;
  }
  std::cout << "tag border shift (0.4, 0.25) px: radius moved by " << std::sqrt(kept2) << " mm RMS without it fitted, "
            << std::sqrt(moved2) << " mm with it fitted and corrected\n";
  EXPECT_GT(std::sqrt(kept2), 1.0);
  EXPECT_LT(std::sqrt(moved2), 0.05 * std::sqrt(kept2));
}

TEST(UncertaintyBudgetTest, CovarianceSidecarIsReadAndChecked) {
  const SyntheticScene scene = DefaultScene();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "curvecheck-budget-test";
  std::filesystem::create_directories(dir);
  const std::filesystem::path cam = dir / "cam.cameramodel";
  EXPECT_EQ(IntrinsicsCovariancePathFor(cam), dir / "cam.intrinsics_covariance.json");
  const size_t n = scene.camera.intrinsics.size();
  nlohmann::json cov = nlohmann::json::array();
  for (size_t r = 0; r < n; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (size_t c = 0; c < n; ++c) row.push_back(r == c ? 0.25 : 0.0);
    cov.push_back(row);
  }
  nlohmann::json j = {{"format", "curvecheck.intrinsics_covariance/1"},
                      {"lensmodel", scene.camera.lensmodel},
                      {"covariance", cov},
                      {"dof", 5000}};
  std::ofstream(IntrinsicsCovariancePathFor(cam)) << j.dump();
  const IntrinsicsCovariance got = ReadIntrinsicsCovariance(IntrinsicsCovariancePathFor(cam), scene.camera);
  EXPECT_EQ(got.covariance.rows(), static_cast<long>(n));
  EXPECT_EQ(got.covariance(3, 3), 0.25);
  EXPECT_EQ(got.dof, 5000);
  EXPECT_EQ(got.misfit_rms_px, 0);
  // The calibration's measured misfit: stated into the fit options, unless a misfit is stated already.
  j["misfit"] = {{"rms_px", 0.12}, {"length_px", 900}};
  std::ofstream(IntrinsicsCovariancePathFor(cam)) << j.dump();
  const IntrinsicsCovariance with = ReadIntrinsicsCovariance(IntrinsicsCovariancePathFor(cam), scene.camera);
  FitOptions o;
  with.ApplyTo(&o);
  EXPECT_EQ(o.intrinsics_covariance(3, 3), 0.25);
  EXPECT_EQ(o.stated_lens_misfit_px, 0.12);
  EXPECT_EQ(o.stated_lens_misfit_length_px, 900);
  FitOptions stated;
  stated.stated_lens_misfit_px = 0.3;
  stated.stated_lens_misfit_length_px = 500;
  with.ApplyTo(&stated);
  EXPECT_EQ(stated.stated_lens_misfit_px, 0.3);
  EXPECT_EQ(stated.stated_lens_misfit_length_px, 500);
  j["misfit"] = {{"rms_px", 0.12}, {"length_px", -1}};
  std::ofstream(IntrinsicsCovariancePathFor(cam)) << j.dump();
  EXPECT_NE(testing::MessageOf([&] { ReadIntrinsicsCovariance(IntrinsicsCovariancePathFor(cam), scene.camera); })
                .find("misfit is 0.12 px RMS"),
            std::string::npos);
  j.erase("misfit");
  j["lensmodel"] = "LENSMODEL_PINHOLE";
  std::ofstream(IntrinsicsCovariancePathFor(cam)) << j.dump();
  EXPECT_NE(testing::MessageOf([&] { ReadIntrinsicsCovariance(IntrinsicsCovariancePathFor(cam), scene.camera); })
                .find("does not match"),
            std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace curvecheck

namespace curvecheck {
namespace {

// The budget's rows for the camera position, where the position trades against the orientation: at 3 m on axis
// the lateral position and the yaw move the image nearly alike. Smooth fields of the detector row's family,
// injected, move the camera by an RMS that the row must match per axis. Before the linearization's pseudo-inverse
// was taken of the column-equilibrated normal matrix, its relative cut dropped this direction (the curvature's
// column is ~1e6 times a position's): the row gave 6e-5 mm for x against 0.40 mm injected (30 fields), and the
// validity bench's camera x missed the truth by 5-10 sigma at 3 m.
TEST(UncertaintyBudgetTest, CameraPositionRowsMatchInjectedFieldsFarOnAxis) {
  SyntheticScene scene = DefaultScene();
  scene.camera = ScaledCamera(scene.camera, 0.25);
  const Eigen::Vector3d centre = ScreenCentreInScreen(scene.monitor);
  scene.screen_from_cam = ScreenFromCamLookAt(centre + Eigen::Vector3d(1, 2, 3000), centre, Eigen::Vector3d::UnitY());
  const PhotoObservations photo = Clean(scene);
  constexpr double kBiasPx = 0.02;
  FitOptions o = CylinderOnly();
  o.smooth_bias_px = kBiasPx;
  const ModelFit f = FitScreen(scene.monitor, scene.camera, {photo}, o).Chosen();
  const BudgetComponent& sys = Row(f, "detector systematic");
  std::mt19937_64 rng(99);  // not the row's seed
  Eigen::Vector3d sum2 = Eigen::Vector3d::Zero();
  constexpr int kFields = 20;
  for (int d = 0; d < kFields; ++d) {
    PhotoObservations biased = photo;
    const auto field = Field(scene.camera, photo.detected_px, o.systematic_field_degree, kBiasPx, rng);
    for (size_t i = 0; i < field.size(); ++i) biased.detected_px[i] += field[i];
    const ModelFit g = FitScreen(scene.monitor, scene.camera, {biased}, o).Chosen();
    sum2 += (g.cameras[0].position_in_screen_mm - f.cameras[0].position_in_screen_mm).cwiseAbs2();
  }
  const Eigen::Vector3d rms = (sum2 / kFields).cwiseSqrt();
  std::cout << "camera position (axis frame), systematic row " << sys.position_in_axis_mm.transpose()
            << " mm; injected fields' RMS shift " << rms.transpose() << " mm\n";
  // 20 draws: each RMS is known to ~16% (1 sigma).
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(sys.position_in_axis_mm[a], 0.6 * rms[a]) << "axis " << a;
    EXPECT_LT(sys.position_in_axis_mm[a], 1.6 * rms[a]) << "axis " << a;
  }
}

// The Gaussian field's correlation exp(-d^2 / 2 L^2) between every two points, plus jitter on the diagonal.
Eigen::MatrixXd GaussianKernel(const std::vector<Eigen::Vector2d>& points, double length, double jitter) {
  const long n = static_cast<long>(points.size());
  Eigen::MatrixXd k(n, n);
  for (long a = 0; a < n; ++a) {
    for (long b = 0; b < n; ++b) {
      const double d = (points[static_cast<size_t>(a)] - points[static_cast<size_t>(b)]).norm() / length;
      k(a, b) = std::exp(-0.5 * d * d) + (a == b ? jitter : 0);
    }
  }
  return k;
}

// A stated lens misfit's RMS is one field's mean square over the imager; FieldMeanSquareDof gives the degrees
// of freedom of that mean square as an estimate of the field's variance. Against seeded draws of the Gaussian
// field on a grid over the imager (Cholesky of its covariance): 2 E[ms]^2 / var(ms) over 4000 draws (relative
// standard error of the variance about 4%), and the limits: a field much shorter than the imager has many, a
// field much longer 1.
TEST(UncertaintyBudgetTest, StatedMisfitDegreesOfFreedomAreThoseOfOneFieldsMeanSquare) {
  constexpr int kWidth = 2400, kHeight = 1600, kGx = 30, kGy = 20, kDraws = 4000;
  for (const double length : {480.0, 240.0}) {
    std::vector<Eigen::Vector2d> grid;
    for (int j = 0; j < kGy; ++j) {
      for (int i = 0; i < kGx; ++i) grid.emplace_back((i + 0.5) * kWidth / kGx, (j + 0.5) * kHeight / kGy);
    }
    const long n = static_cast<long>(grid.size());
    const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(GaussianKernel(grid, length, 1e-9)).matrixL();
    std::mt19937_64 rng(61);
    std::normal_distribution<double> unit(0, 1);
    double sum = 0, sum2 = 0;
    Eigen::VectorXd z(n);
    for (int d = 0; d < kDraws; ++d) {
      for (long i = 0; i < n; ++i) z[i] = unit(rng);
      const double ms = (l * z).squaredNorm() / static_cast<double>(n);
      sum += ms, sum2 += ms * ms;
    }
    const double mean = sum / kDraws, var = sum2 / kDraws - mean * mean;
    const double simulated = 2 * mean * mean / var, dof = FieldMeanSquareDof(length, kWidth, kHeight);
    std::cout << "L " << length << " px on " << kWidth << " x " << kHeight << ": dof " << dof
              << ", simulated " << simulated << " (mean square " << mean << ")\n";
    EXPECT_NEAR(mean, 1.0, 0.05);
    EXPECT_NEAR(simulated / dof, 1.0, 0.1) << "L " << length;
  }
  // By hand: 1 / (mean rho^2 over each axis's pairs), sqrt(pi) L / E - (L / E)^2 per axis.
  EXPECT_NEAR(FieldMeanSquareDof(480, 2400, 1600), 7.2, 0.1);
  EXPECT_GT(FieldMeanSquareDof(10, 2400, 1600), 5000);
  EXPECT_NEAR(FieldMeanSquareDof(1e7, 2400, 1600), 1.0, 1e-3);
  EXPECT_TRUE(std::isinf(FieldMeanSquareDof(0, 2400, 1600)));
}

// NormalisedField: a field scaled to RMS 1 over the imager, through linear responses. Against (1) the exact
// standard deviation of each response to the unscaled field, sqrt(w^T K w); (2) an independent brute force: the
// field drawn jointly on a grid over the imager and at the points (Cholesky), each draw divided by its grid RMS;
// the responses' RMS and their 68% and 95% magnitudes agree within the draws' sampling error (4000 draws: about 3%
// at 95%); (3) Cauchy-Schwarz: the mean of the field over the grid of cell centres is at most its RMS there, so a
// response that is that mean never exceeds 1, and for a field ten times longer than the imager it is nearly +-1
// (three draws in four above 0.95).
TEST(UncertaintyBudgetTest, NormalisedFieldDrawsMatchABruteForceField) {
  constexpr int kWidth = 2400, kHeight = 1600, kDraws = 4000;
  constexpr double kLength = 480;
  std::mt19937_64 rng(71);
  std::uniform_real_distribution<double> ux(200, 1400), uy(500, 1100);
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < 60; ++i) points.emplace_back(ux(rng), uy(rng));
  const long n = static_cast<long>(points.size());
  // Responses: the x field's mean over the points, its slope in x, the y field's curvature in y, a mixture.
  std::array<Eigen::MatrixXd, 2> w = {Eigen::MatrixXd::Zero(4, n), Eigen::MatrixXd::Zero(4, n)};
  for (long i = 0; i < n; ++i) {
    const Eigen::Vector2d q = (points[static_cast<size_t>(i)] - Eigen::Vector2d(800, 800)) / 600;
    w[0](0, i) = 1.0 / n;
    w[0](1, i) = q.x() / n;
    w[1](2, i) = (q.y() * q.y() - 0.1) / n;
    w[0](3, i) = 0.5 / n, w[1](3, i) = q.x() * q.y() / n;
  }
  const NormalisedField field = NormalisedField::Draw(kLength, kWidth, kHeight, kDraws, 5);
  ASSERT_TRUE(field.ok);
  EXPECT_GT(field.lambda.size(), 20);
  EXPECT_LT(field.lambda.size(), 200);
  EXPECT_NEAR(field.lambda.sum(), 1.0, 1e-4);  // the kept modes hold nearly all of the mean square
  Eigen::VectorXd sd;
  const Eigen::MatrixXd draws = field.Respond(points, w, &sd);
  const Eigen::MatrixXd k = GaussianKernel(points, kLength, 0);
  // Brute force: a 36 x 24 grid of cell centres (spacing L / 7) and the points.
  constexpr int kGx = 36, kGy = 24;
  std::vector<Eigen::Vector2d> all;
  for (int j = 0; j < kGy; ++j) {
    for (int i = 0; i < kGx; ++i) all.emplace_back((i + 0.5) * kWidth / kGx - 0.5, (j + 0.5) * kHeight / kGy - 0.5);
  }
  const long grid = static_cast<long>(all.size());
  all.insert(all.end(), points.begin(), points.end());
  const long m = static_cast<long>(all.size());
  const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(GaussianKernel(all, kLength, 1e-8)).matrixL();
  std::normal_distribution<double> unit(0, 1);
  Eigen::MatrixXd brute = Eigen::MatrixXd::Zero(4, kDraws);
  for (int f = 0; f < 2; ++f) {
    Eigen::MatrixXd g(m, kDraws);
    for (long i = 0; i < m; ++i) {
      for (int j = 0; j < kDraws; ++j) g(i, j) = unit(rng);
    }
    const Eigen::MatrixXd values = l * g;
    for (int j = 0; j < kDraws; ++j) {
      const double rms = std::sqrt(values.col(j).head(grid).squaredNorm() / static_cast<double>(grid));
      brute.col(j) += w[static_cast<size_t>(f)] * values.col(j).tail(n) / rms;
    }
  }
  const auto magnitude = [](Eigen::RowVectorXd row, double p) {
    std::vector<double> v(row.data(), row.data() + row.size());
    for (double& x : v) x = std::abs(x);
    std::sort(v.begin(), v.end());
    return v[static_cast<size_t>(p * static_cast<double>(v.size()))];
  };
  for (long r = 0; r < 4; ++r) {
    const double exact = std::sqrt((w[0].row(r) * k * w[0].row(r).transpose())(0, 0) +
                                   (w[1].row(r) * k * w[1].row(r).transpose())(0, 0));
    EXPECT_NEAR(sd[r], exact, 0.01 * exact) << "row " << r;
    const double rms = std::sqrt(draws.row(r).squaredNorm() / kDraws),
                 brute_rms = std::sqrt(brute.row(r).squaredNorm() / kDraws);
    const double q68 = magnitude(draws.row(r), 0.68), q95 = magnitude(draws.row(r), 0.95);
    const double b68 = magnitude(brute.row(r), 0.68), b95 = magnitude(brute.row(r), 0.95);
    std::cout << "row " << r << ": sd " << sd[r] << " (exact " << exact << "); scaled RMS / sd "
              << rms / exact << " (brute force " << brute_rms / exact << "), 95% magnitude / sd " << q95 / exact
              << " (" << b95 / exact << "), 68% " << q68 / exact << " (" << b68 / exact << ")\n";
    EXPECT_NEAR(rms / brute_rms, 1.0, 0.05) << "row " << r;
    EXPECT_NEAR(q68 / b68, 1.0, 0.05) << "row " << r;
    EXPECT_NEAR(q95 / b95, 1.0, 0.06) << "row " << r;
  }
  // The mean over the grid of cell centres (64 per axis at L >= width / 8): |mean| <= RMS.
  for (const double length : {480.0, 24000.0}) {
    std::vector<Eigen::Vector2d> cells;
    for (int j = 0; j < 64; ++j) {
      for (int i = 0; i < 64; ++i) cells.emplace_back((i + 0.5) * kWidth / 64 - 0.5, (j + 0.5) * kHeight / 64 - 0.5);
    }
    std::array<Eigen::MatrixXd, 2> mean = {Eigen::MatrixXd::Constant(1, 4096, 1.0 / 4096),
                                           Eigen::MatrixXd::Zero(1, 4096)};
    const NormalisedField c = NormalisedField::Draw(length, kWidth, kHeight, 1000, 9);
    ASSERT_TRUE(c.ok);
    const Eigen::MatrixXd mean_draws = c.Respond(cells, mean, nullptr);
    EXPECT_LE(mean_draws.cwiseAbs().maxCoeff(), 1 + 1e-9) << "L " << length;
    if (length > kWidth) {  // nearly constant over the imager: the mean is nearly the RMS
      EXPECT_GT(magnitude(mean_draws.row(0), 0.25), 0.95);
    }
  }
  // Too short a field for the imager's modes: not drawn.
  EXPECT_FALSE(NormalisedField::Draw(2, kWidth, kHeight, 10, 1).ok);
  EXPECT_THROW(field.Respond({points[0]}, w, nullptr), Error);  // weights for other points
}

}  // namespace
}  // namespace curvecheck
