// Screen models against the geometry core's analytic surface (core/screen_geometry.h) and against each other
// where the families nest (flat in cylinder; cylinder in cylinder+lean and in varying curvature), and the
// deviation basis' gauge (orthogonal to the rigid and radius modes).
#include "analysis/screen_model.h"

#include <gtest/gtest.h>

#include <random>

#include "core/screen_geometry.h"
#include "core/test_util.h"
#include "datasets/monitor_presets.h"

namespace curvecheck {
namespace {

using testing::EigenNear;

TEST(ScreenModelTest, CylinderIsTheGeometryCoresSurfaceInTheCentreFrame) {
  const Monitor m = LoadMonitor(kDefaultMonitorPreset);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector2d uv(unit(rng), unit(rng));
    const double s = 0.5 * uv.x() * m.width_mm, y = -0.5 * uv.y() * m.height_mm;
    Eigen::Vector3d n;
    const double k = m.curvature_per_mm;
    const Eigen::Vector3d p = CoreScreenPoint<double>(ScreenModelKind::kCylinder, &k, s, y, 0.5 * m.width_mm, &n);
    EXPECT_THAT(p, EigenNear(SurfacePointFromUv(m, uv) - ScreenCentreInScreen(m), 1e-9));
    EXPECT_THAT(n, EigenNear(SurfaceNormalFromUv(m, uv), 1e-12));
  }
}

TEST(ScreenModelTest, FlatIsTheLimitOfEveryFamily) {
  const double s = 412.5, y = -98.25, h = 600;
  const double k_tiny[3] = {1e-13, 0, 0};
  const Eigen::Vector3d flat = CoreScreenPoint<double>(ScreenModelKind::kFlat, nullptr, s, y, h, nullptr);
  EXPECT_THAT(flat, EigenNear(Eigen::Vector3d(s, y, 0), 0));
  for (ScreenModelKind kind : AllScreenModels()) {
    if (kind == ScreenModelKind::kFlat) continue;
    const Eigen::Vector3d p = CoreScreenPoint<double>(kind, k_tiny, s, y, h, nullptr);
    // The difference is k s^2 / 2 ~ 1e-8 mm at k = 1e-13.
    EXPECT_THAT(p, EigenNear(flat, 1e-7)) << ScreenModelName(kind);
  }
}

TEST(ScreenModelTest, RicherFamiliesReduceToTheCylinder) {
  const double h = 599, k = 1 / 1080.0;
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (int i = 0; i < 20; ++i) {
    const double s = h * unit(rng), y = 170 * unit(rng);
    const double kc[3] = {k, 0, 0};
    Eigen::Vector3d n_cyl;
    const Eigen::Vector3d cyl = CoreScreenPoint<double>(ScreenModelKind::kCylinder, kc, s, y, h, &n_cyl);
    for (ScreenModelKind kind : {ScreenModelKind::kCylinderLean, ScreenModelKind::kVaryingCurvature,
                                 ScreenModelKind::kVaryingCurvatureQuadratic}) {
      Eigen::Vector3d n;
      // Gauss-Legendre with 8 nodes integrates cos/sin of phi < 0.6 rad to far below a nanometre.
      EXPECT_THAT(CoreScreenPoint<double>(kind, kc, s, y, h, &n), EigenNear(cyl, 1e-9)) << ScreenModelName(kind);
      EXPECT_THAT(n, EigenNear(n_cyl, 1e-12)) << ScreenModelName(kind);
    }
  }
}

TEST(ScreenModelTest, LeanTiltsTheAxisAndKeepsRowsHorizontalArcs) {
  const double h = 599, k = 1e-3, lambda = 0.02;
  const double core[2] = {k, lambda};
  const double y = 150;
  // Every point of a row has the same height y cos(lambda), and lies lambda y further toward the viewer than
  // the cylinder's row: the row is the cylinder's arc of radius 1/k, shifted.
  for (double s : {-500.0, -100.0, 0.0, 250.0, 590.0}) {
    Eigen::Vector3d n;
    const Eigen::Vector3d p = CoreScreenPoint<double>(ScreenModelKind::kCylinderLean, core, s, y, h, &n);
    EXPECT_NEAR(p.y(), y * std::cos(lambda), 1e-12);
    EXPECT_NEAR(p.z() - (1 - std::cos(k * s)) / k, y * std::sin(lambda), 1e-9);
    EXPECT_NEAR(p.x(), std::sin(k * s) / k, 1e-9);
    EXPECT_NEAR(n.norm(), 1, 1e-12);
    EXPECT_NEAR(n.dot(Eigen::Vector3d(std::cos(k * s), 0, std::sin(k * s))), 0, 1e-12);  // row tangent
    EXPECT_NEAR(n.dot(Eigen::Vector3d(0, std::cos(lambda), std::sin(lambda))), 0, 1e-12);  // column tangent
  }
}

TEST(ScreenModelTest, VaryingCurvatureFollowsItsHeading) {
  // k(s) = k0 + k1 s/h: the heading at s is k0 s + k1 s^2/(2h), and the arc has unit speed; check the end point
  // against a fine trapezoid integration.
  const double h = 600, k0 = 1e-3, k1 = 3e-4, s = 550;
  const double core[2] = {k0, k1};
  Eigen::Vector3d n;
  const Eigen::Vector3d p = CoreScreenPoint<double>(ScreenModelKind::kVaryingCurvature, core, s, 0, h, &n);
  double x = 0, z = 0;
  const int steps = 200000;
  for (int i = 0; i < steps; ++i) {
    const double t0 = s * i / steps, t1 = s * (i + 1) / steps;
    const auto phi = [&](double t) { return k0 * t + k1 * t * t / (2 * h); };
    x += 0.5 * (std::cos(phi(t0)) + std::cos(phi(t1))) * (t1 - t0);
    z += 0.5 * (std::sin(phi(t0)) + std::sin(phi(t1))) * (t1 - t0);
  }
  EXPECT_NEAR(p.x(), x, 1e-6);
  EXPECT_NEAR(p.z(), z, 1e-6);
  const double phi_end = k0 * s + k1 * s * s / (2 * h);
  EXPECT_THAT(n, EigenNear(Eigen::Vector3d(-std::sin(phi_end), 0, std::cos(phi_end)), 1e-12));
}

TEST(DeviationBasisTest, FieldIsOrthogonalToTheRigidAndRadiusModes) {
  const Monitor m = LoadMonitor(kDefaultMonitorPreset);
  const DeviationBasis basis(m, m.curvature_per_mm, 13, 6);
  EXPECT_EQ(basis.size(), 13 * 6 - 5);
  // Inner products over a grid other than the one the basis was built on (so this is not a tautology up to
  // the quadrature): each mode against each basis field is small relative to the norms.
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(5, basis.size());
  Eigen::VectorXd mode_norm = Eigen::VectorXd::Zero(5), field_norm = Eigen::VectorXd::Zero(basis.size());
  for (int j = 0; j < 57; ++j) {
    for (int i = 0; i < 113; ++i) {
      const Eigen::Vector2d uv(-1 + 2.0 * i / 112, -1 + 2.0 * j / 56);
      const Eigen::Matrix<double, 5, 1> modes = basis.Modes(uv);
      const Eigen::VectorXd w = basis.Weights(uv);
      gram += modes * w.transpose();
      mode_norm += modes.cwiseAbs2();
      field_norm += w.cwiseAbs2();
    }
  }
  for (int a = 0; a < 5; ++a) {
    for (int b = 0; b < basis.size(); ++b) {
      EXPECT_LT(std::abs(gram(a, b)) / std::sqrt(mode_norm[a] * field_norm[b]), 0.02) << a << " " << b;
    }
  }
  // Cubic B-splines sum to one.
  EXPECT_NEAR(basis.Splines(Eigen::Vector2d(0.123, -0.77)).sum(), 1, 1e-12);
}

TEST(DeviationBasisTest, RepresentsAPlantedBumpAfterTheGauge) {
  // The 2 mm bump of datasets/scenes/bulge-2mm.yaml, minus its projection onto the modes, is reproduced by the
  // basis to a fraction of its height (least squares over a grid).
  const Monitor m = LoadMonitor(kDefaultMonitorPreset);
  const DeviationBasis basis(m, m.curvature_per_mm, 13, 6);  // FitOptions' default
  std::vector<Eigen::Vector2d> grid;
  for (int j = 0; j < 31; ++j) {
    for (int i = 0; i < 61; ++i) grid.emplace_back(-1 + 2.0 * i / 60, -1 + 2.0 * j / 30);
  }
  const auto bump = [](const Eigen::Vector2d& uv) {
    const double du = (uv.x() - 0.35) / 0.12, dv = (uv.y() + 0.3) / 0.3;
    return 2.0 * std::exp(-0.5 * (du * du + dv * dv));
  };
  Eigen::MatrixXd a(grid.size(), basis.size()), modes(grid.size(), 5);
  Eigen::VectorXd b(grid.size());
  for (size_t i = 0; i < grid.size(); ++i) {
    a.row(static_cast<long>(i)) = basis.Weights(grid[i]).transpose();
    modes.row(static_cast<long>(i)) = basis.Modes(grid[i]).transpose();
    b[static_cast<long>(i)] = bump(grid[i]);
  }
  const Eigen::VectorXd b_gauged = b - modes * modes.colPivHouseholderQr().solve(b);
  const Eigen::VectorXd fit = a * a.colPivHouseholderQr().solve(b_gauged);
  EXPECT_LT((fit - b_gauged).cwiseAbs().maxCoeff(), 0.25);  // mm, of a 2 mm bump (measured: 0.20)
  EXPECT_GT(b_gauged.maxCoeff(), 1.6);
}

}  // namespace
}  // namespace curvecheck
