#include "calibrate/truth_comparison.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>

#include "core/error.h"
#include "core/math_util.h"

namespace curvecheck {

TruthComparison CompareWithTruth(const CameraModel& truth, const SyntheticBoardSet& set,
                                 const std::vector<ChessboardDetection>& detections, const CalibrationResult& r,
                                 const CandidateResult& candidate, double distance_mm) {
  if (!candidate.error.empty() || candidate.cam_from_board_rt.size() != r.used.size()) {
    throw Error("CompareWithTruth", fmt::format("candidate {} has no solution to compare", candidate.lensmodel),
                "compare a candidate that solved");
  }
  // Pairs (true corner in the true camera frame, the same corner in the recovered frame).
  const std::vector<Eigen::Vector3d> board = set.board.CornersInBoard();
  std::vector<Eigen::Vector3d> a, b;
  for (size_t u = 0; u < r.used.size(); ++u) {
    const size_t k = static_cast<size_t>(r.used[u]);
    const SyntheticBoardView& v = set.views.at(k);
    const Eigen::Matrix<double, 6, 1>& rt = candidate.cam_from_board_rt[u];
    const double angle = rt.head<3>().norm();
    const Eigen::Matrix3d rot = angle > 0 ? Eigen::AngleAxisd(angle, rt.head<3>() / angle).toRotationMatrix()
                                          : Eigen::Matrix3d::Identity();
    for (size_t i = 0; i < detections.at(k).corners_px.size(); ++i) {
      size_t best = 0;
      for (size_t j = 1; j < v.corners_px.size(); ++j) {
        if ((v.corners_px[j] - detections[k].corners_px[i]).squaredNorm() <
            (v.corners_px[best] - detections[k].corners_px[i]).squaredNorm()) {
          best = j;
        }
      }
      a.push_back(v.screen_from_cam.Inverse() * set.corners_in_screen[best]);
      b.push_back(rot * board[i] + rt.tail<3>());
    }
  }
  Eigen::Vector3d ma = Eigen::Vector3d::Zero(), mb = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= static_cast<double>(a.size());
  mb /= static_cast<double>(b.size());
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) h += (a[i] - ma) * (b[i] - mb).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d rotation = svd.matrixV() * fix * svd.matrixU().transpose();
  TruthComparison out;
  out.translation_mm = mb - rotation * ma;
  out.rotation_deg = Eigen::AngleAxisd(rotation).angle() / kRadPerDeg;

  const CameraModel recovered = ParseCameraModel(candidate.model_text, candidate.lensmodel);
  const std::vector<Eigen::Vector2d>& grid = candidate.uncertainty.pixel_px;
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& ray : UnprojectPixels(truth, grid)) {
    points.push_back(distance_mm > 0 ? Eigen::Vector3d(rotation * (ray.normalized() * distance_mm) + out.translation_mm)
                                     : Eigen::Vector3d(rotation * ray));
  }
  const std::vector<Eigen::Vector2d> q = ProjectPoints(recovered, points);
  double sum = 0, sum_sigma = 0, sum_confident = 0, sum_observed = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    const double d = (q[i] - grid[i]).norm();
    const double s = candidate.uncertainty.sigma_px[i];
    sum += d * d;
    if (candidate.uncertainty.observed[i]) {
      sum_observed += d * d;
      ++out.observed_points;
    }
    if (!std::isfinite(s)) {
      ++out.no_sigma;
      continue;
    }
    sum_sigma += s * s;
    out.worst_ratio = std::max(out.worst_ratio, d / s);
    out.within_3sigma += d <= 3 * s ? 1 : 0;
    ++out.points;
    if (s < out.confident_sigma_px) {
      sum_confident += d * d;
      ++out.confident_points;
    }
  }
  out.rms_px = std::sqrt(sum / static_cast<double>(std::max<size_t>(1, q.size())));
  out.rms_sigma_px = std::sqrt(sum_sigma / std::max(1, out.points));
  out.confident_rms_px = std::sqrt(sum_confident / std::max(1, out.confident_points));
  out.observed_rms_px = std::sqrt(sum_observed / std::max(1, out.observed_points));
  return out;
}

}  // namespace curvecheck
