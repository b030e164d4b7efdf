// The analytic Jacobian of ReprojectionCost (Jets for pose and shape, mrcal's dq/dX, closed form for the
// deviation coefficients) against Ceres' numeric differentiation, for every screen model, through a distorted
// OPENCV8 lens. What this proves: the chain rule and block layout are right. What it does not: that the model
// formulas describe a screen (screen_model_test.cc) or that fits recover one (screen_fit_test.cc).
#include "analysis/screen_fit_cost.h"

#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "core/camera_model.h"
#include "datasets/monitor_presets.h"

namespace curvecheck {
namespace {

CameraModel DefaultCamera() {
  return ReadCameraModel(std::filesystem::path(std::getenv("CURVECHECK_SOURCE_DIR")) / "datasets/cameras" /
                         "default-24mp-opencv8.cameramodel");
}

// Every block's analytic Jacobian against Ceres's numeric one (Ridders). Ceres steps relative to max(|x|, 1): the
// curvature (~1e-3 /mm) needs a small first step. Element-wise relative precision 1e-2 (Ridders' estimate of
// entries near zero carries ~1e-10 px of absolute noise, 0.4% of the smallest entries), and block-wise: the largest
// difference below block_tolerance of the block's largest entry.
void ExpectJacobiansMatchNumeric(const ceres::CostFunction& cost, const std::vector<const ceres::Manifold*>& manifolds,
                                 const std::vector<const double*>& params, double block_tolerance,
                                 const std::string& label) {
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = 1e-7;
  nd.ridders_relative_initial_step_size = 1e-4;
  const ceres::GradientChecker checker(&cost, &manifolds, nd);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(params.data(), 1e-2, &results)) << label << ": " << results.error_log;
  ASSERT_EQ(results.local_jacobians.size(), params.size());
  for (size_t b = 0; b < params.size(); ++b) {
    const double scale = results.local_jacobians[b].cwiseAbs().maxCoeff();
    const double diff = (results.local_jacobians[b] - results.local_numeric_jacobians[b]).cwiseAbs().maxCoeff();
    EXPECT_GT(scale, 0) << label << " block " << b;
    EXPECT_LT(diff, block_tolerance * scale) << label << " block " << b;
  }
}

TEST(ReprojectionCostTest, AnalyticJacobianMatchesNumericForEveryModel) {
  const CameraModel camera = DefaultCamera();
  const Monitor m = LoadMonitor(kDefaultMonitorPreset);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  const DeviationBasis basis(m, m.curvature_per_mm, 9, 5);
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> pose_manifold{
      ceres::EigenQuaternionManifold(), ceres::EuclideanManifold<3>()};
  int probes = 0;
  for (ScreenModelKind kind : AllScreenModels()) {
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::Vector2d uv(0.9 * unit(rng), 0.9 * unit(rng));
      const double s = 0.5 * uv.x() * m.width_mm, y = -0.5 * uv.y() * m.height_mm;
      Eigen::VectorXd w;
      if (kind == ScreenModelKind::kCylinderDeviation) w = basis.Weights(uv);
      const ReprojectionCost cost(&camera, kind, s, y, 0.5 * m.width_mm, Eigen::Vector2d(3000, 2000), w);
      // A camera 1.5 m in front, slightly rotated; shape parameters near a 1000R panel.
      const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI + 0.05 * unit(rng), Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(0.05 * unit(rng), Eigen::Vector3d::UnitY()));
      double pose[7] = {q.x(), q.y(), q.z(), q.w(), 30 * unit(rng), 20 * unit(rng), 1500 + 50 * unit(rng)};
      double core[3] = {1e-3 * (1 + 0.2 * unit(rng)), 0.02 * unit(rng), 2e-4 * unit(rng)};
      std::vector<double> dev(static_cast<size_t>(w.size()));
      for (double& d : dev) d = unit(rng);
      std::vector<const double*> params = {pose};
      std::vector<const ceres::Manifold*> manifolds = {&pose_manifold};
      if (CoreParameterCount(kind) > 0) {
        params.push_back(core);
        manifolds.push_back(nullptr);
      }
      if (!dev.empty()) {
        params.push_back(dev.data());
        manifolds.push_back(nullptr);
      }
      double r0[2];
      ASSERT_TRUE(cost.Evaluate(params.data(), r0, nullptr)) << ScreenModelName(kind);
      ExpectJacobiansMatchNumeric(cost, manifolds, params, 1e-7, ScreenModelName(kind));
      ++probes;
    }
  }
  EXPECT_EQ(probes, 30);
}

// With free intrinsics (the calibration from the screen), the intrinsics are the last block and q uses its values
// (not the camera's): every block's Jacobian, the intrinsics' being libmrcal's dq/dintrinsics written straight into
// Ceres's block, is checked against numeric differentiation of the cost-only evaluation (plain doubles), for every
// screen model through OPENCV8 with every intrinsic perturbed; the residual equals that of a cost with fixed
// intrinsics on a camera holding the block's values; and a projector shared among costs gives the same numbers.
TEST(ReprojectionCostTest, FreeIntrinsicsJacobianMatchesNumericForEveryModel) {
  const CameraModel camera = DefaultCamera();
  const Monitor m = LoadMonitor(kDefaultMonitorPreset);
  const DeviationBasis basis(m, m.curvature_per_mm, 9, 5);
  const PointProjector projector(camera);
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> pose_manifold{
      ceres::EigenQuaternionManifold(), ceres::EuclideanManifold<3>()};
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  int probes = 0;
  for (ScreenModelKind kind : AllScreenModels()) {
    for (int trial = 0; trial < 3; ++trial) {
      const Eigen::Vector2d uv(0.9 * unit(rng), 0.9 * unit(rng));
      const double s = 0.5 * uv.x() * m.width_mm, y = -0.5 * uv.y() * m.height_mm;
      Eigen::VectorXd w;
      if (kind == ScreenModelKind::kCylinderDeviation) w = basis.Weights(uv);
      const Eigen::Vector2d detected(3000, 2000);
      const ReprojectionCost cost(&camera, kind, s, y, 0.5 * m.width_mm, detected, w, true);
      const ReprojectionCost shared(projector, kind, s, y, 0.5 * m.width_mm, detected, w, true);
      const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI + 0.05 * unit(rng), Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(0.05 * unit(rng), Eigen::Vector3d::UnitY()));
      double pose[7] = {q.x(), q.y(), q.z(), q.w(), 30 * unit(rng), 20 * unit(rng), 1500 + 50 * unit(rng)};
      double core[3] = {1e-3 * (1 + 0.2 * unit(rng)), 0.02 * unit(rng), 2e-4 * unit(rng)};
      std::vector<double> dev(static_cast<size_t>(w.size()));
      for (double& d : dev) d = unit(rng);
      CameraModel moved = camera;  // every intrinsic off the camera's: fx, fy, cx, cy by 2%, distortions by 10%
      for (size_t i = 0; i < moved.intrinsics.size(); ++i) {
        moved.intrinsics[i] = i < 4 ? moved.intrinsics[i] * (1 + 0.02 * unit(rng))
                                    : moved.intrinsics[i] * (1 + 0.1 * unit(rng)) + 1e-4 * unit(rng);
      }
      std::vector<const double*> params = {pose};
      std::vector<const ceres::Manifold*> manifolds = {&pose_manifold};
      if (CoreParameterCount(kind) > 0) params.push_back(core), manifolds.push_back(nullptr);
      if (!dev.empty()) params.push_back(dev.data()), manifolds.push_back(nullptr);
      const ReprojectionCost fixed(&moved, kind, s, y, 0.5 * m.width_mm, detected, w);
      double r_fixed[2];
      ASSERT_TRUE(fixed.Evaluate(params.data(), r_fixed, nullptr)) << ScreenModelName(kind);
      params.push_back(moved.intrinsics.data());
      manifolds.push_back(nullptr);
      ASSERT_EQ(cost.parameter_block_sizes().size(), params.size());
      ASSERT_EQ(cost.parameter_block_sizes().back(), static_cast<int>(camera.intrinsics.size()));
      double r[2], r_shared[2];
      ASSERT_TRUE(cost.Evaluate(params.data(), r, nullptr)) << ScreenModelName(kind);
      ASSERT_TRUE(shared.Evaluate(params.data(), r_shared, nullptr)) << ScreenModelName(kind);
      EXPECT_EQ(r[0], r_fixed[0]) << ScreenModelName(kind);
      EXPECT_EQ(r[1], r_fixed[1]) << ScreenModelName(kind);
      EXPECT_EQ(r[0], r_shared[0]) << ScreenModelName(kind);
      EXPECT_EQ(r[1], r_shared[1]) << ScreenModelName(kind);
      Eigen::Vector2d q_px, dq_dn;
      ASSERT_TRUE(cost.PredictWithNormal(params.data(), &q_px, &dq_dn)) << ScreenModelName(kind);
      EXPECT_NEAR(q_px.x() - detected.x(), r[0], 1e-9) << ScreenModelName(kind);
      EXPECT_NEAR(q_px.y() - detected.y(), r[1], 1e-9) << ScreenModelName(kind);
      ExpectJacobiansMatchNumeric(cost, manifolds, params, 1e-6, ScreenModelName(kind));
      ++probes;
    }
  }
  EXPECT_EQ(probes, 18);
}

TEST(ReprojectionCostTest, ResidualIsPredictionMinusDetection) {
  // A pinhole camera on the axis of a flat screen: the centre of the screen projects to the principal point.
  const CameraModel camera = PinholeModel(1000, 800, 1000);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));  // camera looks along -z
  const double pose[7] = {q.x(), q.y(), q.z(), q.w(), 0, 0, 1000};
  const ReprojectionCost cost(&camera, ScreenModelKind::kFlat, 100, 50, 300, Eigen::Vector2d(10, 20));
  const double* params[] = {pose};
  double r[2];
  ASSERT_TRUE(cost.Evaluate(params, r, nullptr));
  // Point (100, 50, 0) seen from (0, 0, 1000) looking along -z with y down: x_cam = 100, y_cam = -50, z = 1000.
  EXPECT_NEAR(r[0], 499.5 + 100 - 10, 1e-9);
  EXPECT_NEAR(r[1], 399.5 - 50 - 20, 1e-9);
  // Behind the camera: refused.
  const double behind[7] = {q.x(), q.y(), q.z(), q.w(), 0, 0, -1000};
  const double* params_behind[] = {behind};
  EXPECT_FALSE(cost.Evaluate(params_behind, r, nullptr));
}

}  // namespace
}  // namespace curvecheck
