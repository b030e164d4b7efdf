// End-to-end calibration on synthetic sets with known lenses (issue 5 item 5): the synthetic camera photographs
// a flat monitor showing a checkerboard; the rig detects, solves and chooses the model; the recovered model is
// compared with the true lens by projection over the imager, and with its own reported uncertainty.
#include "calibrate/calibrate.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <iostream>

#include "calibrate/truth_comparison.h"
#include "core/error.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

struct SetResult {
  SyntheticBoardSet set;
  std::vector<ChessboardDetection> detections;
  CalibrationResult calibration;
  double detection_rms_px = 0;
};

SetResult RunSet(const CameraModel& truth, int views, uint64_t seed, const CalibrateOptions& options) {
  SyntheticBoardOptions o;
  o.camera = truth;
  o.views = views;
  o.seed = seed;
  SetResult r;
  r.set = MakeSyntheticBoardSet(o);
  double sum = 0;
  int n = 0;
  for (size_t k = 0; k < r.set.views.size(); ++k) {
    ChessboardDetection d = DetectChessboard(r.set.views[k].photo, r.set.board, ChessboardOptions());
    d.photo = "view" + std::to_string(k);
    EXPECT_TRUE(d.found) << "view " << k << ": " << d.problem;
    if (d.found) {
      // The detector's corner order may start at any corner: compare with the nearest true corner.
      for (const Eigen::Vector2d& q : d.corners_px) {
        double best = 1e30;
        for (const Eigen::Vector2d& t : r.set.views[k].corners_px) best = std::min(best, (q - t).squaredNorm());
        sum += best;
        ++n;
      }
    }
    r.detections.push_back(std::move(d));
  }
  r.detection_rms_px = std::sqrt(sum / std::max(1, n));
  r.calibration = Calibrate(r.detections, r.set.board, options);
  std::cout << CandidateTable(r.calibration);
  std::cout << "detection RMS against truth: " << r.detection_rms_px << " px over " << n << " corners\n";
  return r;
}

TruthComparison Compare(const CameraModel& truth, const SetResult& r, double distance_mm) {
  const TruthComparison c =
      CompareWithTruth(truth, r.set, r.detections, r.calibration, r.calibration.Chosen(), distance_mm);
  std::cout << "chose " << r.calibration.Chosen().lensmodel << "; recovered_from_true: rotation " << c.rotation_deg
            << " deg, translation " << c.translation_mm.transpose() << " mm; recovered - truth RMS " << c.rms_px
            << " px, reported sigma RMS " << c.rms_sigma_px << " px, " << c.within_3sigma << "/" << c.points
            << " within 3 sigma, worst ratio " << c.worst_ratio << ", " << c.no_sigma
            << " grid points without uncertainty; where sigma < " << c.confident_sigma_px << " px ("
            << c.confident_points << " points): RMS " << c.confident_rms_px << " px\n";
  return c;
}

// What "recovered to 0.1 px over the imager" can mean. The synthetic sets observe the imager up to 35-105 px from
// its corners (the whole board, its outer squares and a white margin must be in view); the 16x12 grid's four
// extreme points lie beyond the data, ~49 deg off axis. There OPENCV8 extrapolates: its rational terms are
// nearly degenerate over the observed radii (the set of seed 7 recovers k1..k6 = -0.30, -0.16, 0.013, 0.19,
// -0.36, -0.034 against the truth's 0.3, -0.05, 0.02, 0.8, 0.05, 0.01, with numerator and denominator both
// crossing zero near 53 deg), so the four extreme points are off by 0.7-1.5 px while mrcal reports 2.5-6.7 px of
// uncertainty there; the other 188 points are within 0.03 px. This is the data, not the rig: the exact true
// corners with i.i.d. 0.03 px Gaussian noise (no synthetic camera) give a whole-grid RMS of 0.097, 0.217, 0.129,
// 0.081, 0.079 px for noise seeds 1-5, with the same extreme points dominating. So the acceptance is: (a) where
// the calibration reports an uncertainty below 0.1 px, the recovered lens is within 0.1 px RMS of the truth, and
// that region is at least 95% of the grid; (b) everywhere, the difference is within 3 sigma at >= 95% of the grid
// points and its RMS is below 3x the reported RMS sigma. The whole-grid RMS is printed.
void ExpectRecovered(const TruthComparison& cmp) {
  const int grid_points = cmp.points + cmp.no_sigma;
  EXPECT_LT(cmp.confident_rms_px, 0.1);
  EXPECT_GE(cmp.confident_points, grid_points * 95 / 100) << "the calibration is confident over too little of the imager";
  EXPECT_LT(cmp.rms_px, 3 * cmp.rms_sigma_px);
  EXPECT_GE(cmp.within_3sigma, cmp.points * 95 / 100);
  EXPECT_LE(cmp.no_sigma, 4);
}

TEST(Calibrate, Opencv8TruthChoosesOpencv8AndRecoversTheLens) {
  CalibrateOptions options;
  const SetResult r = RunSet(StrongOpencv8Lens(), 30, 7, options);
  EXPECT_LT(r.detection_rms_px, 0.1);
  const CalibrationResult& c = r.calibration;
  ASSERT_EQ(c.candidates.size(), 3u);
  EXPECT_EQ(c.Chosen().lensmodel, "LENSMODEL_OPENCV8") << c.choice;
  EXPECT_FALSE(c.candidates[0].adequate()) << "OPENCV4 cannot absorb the truth's k3 and rational terms";
  ExpectRecovered(Compare(StrongOpencv8Lens(), r, options.distance_mm));
  // The intrinsics covariance written beside the model (analyze's lens row): the recovered core (fx, fy, cx, cy)
  // is within 4 of its sigmas of the truth, and the sidecar carries it.
  const CandidateResult& ch = c.Chosen();
  const CameraModel truth = StrongOpencv8Lens();
  ASSERT_EQ(ch.intrinsics_covariance.rows(), static_cast<long>(truth.intrinsics.size()));
  EXPECT_GT(ch.intrinsics_covariance_dof, 1000);
  for (int i = 0; i < 4; ++i) {
    const double sigma = std::sqrt(ch.intrinsics_covariance(i, i)), err = ch.intrinsics[static_cast<size_t>(i)] -
                                                                          truth.intrinsics[static_cast<size_t>(i)];
    std::cout << "intrinsic " << i << ": error " << err << " px, sigma " << sigma << " px\n";
    EXPECT_GT(sigma, 0);
    EXPECT_LT(std::abs(err), 4 * sigma) << i;
  }
  const nlohmann::json side = IntrinsicsCovarianceJson(ch, "cam.cameramodel");
  EXPECT_EQ(side["format"], "curvecheck.intrinsics_covariance/1");
  EXPECT_EQ(side["covariance"].size(), truth.intrinsics.size());
  // The misfit the calibration measured goes with it (analyze's lens-model-misfit row takes it as its floor).
  if (ch.misfit_note.empty() && ch.misfit_length_px > 0) {
    ASSERT_TRUE(side.contains("misfit"));
    EXPECT_NEAR(side["misfit"]["rms_px"].get<double>(), std::sqrt(std::max(0.0, ch.misfit_variance_px2)), 1e-12);
    EXPECT_EQ(side["misfit"]["length_px"].get<double>(), ch.misfit_length_px);
  } else {
    EXPECT_FALSE(side.contains("misfit")) << ch.misfit_note;
  }
}

// The wide lens: whatever model is chosen must reproduce the truth within 0.1 px and its own uncertainty.
TEST(Calibrate, WideLensIsRecoveredWithinItsUncertainty) {
  CalibrateOptions options;
  const SetResult r = RunSet(WideLens(), 30, 11, options);
  EXPECT_LT(r.detection_rms_px, 0.1);
  const CalibrationResult& c = r.calibration;
  EXPECT_TRUE(c.Chosen().adequate()) << c.choice;
  ExpectRecovered(Compare(WideLens(), r, options.distance_mm));
}

}  // namespace
}  // namespace curvecheck
