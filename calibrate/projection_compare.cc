#include "calibrate/projection_compare.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/stats.h"

namespace curvecheck {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The differences at every grid point (2 per point, stacked) for intrinsics ia, ib; the fitted rotation's angle.
// The rays of the pixels q through lens m with intrinsics i (through its misfit field when it has one).
std::vector<Eigen::Vector3d> Rays(const LensWithCovariance& m, const std::vector<double>& i,
                                  const std::vector<Eigen::Vector2d>& q) {
  CameraModel c = m.model;
  c.intrinsics = i;
  if (!m.model_pixel_of) return UnprojectPixels(c, q);
  std::vector<Eigen::Vector2d> model_px;
  for (const Eigen::Vector2d& p : q) model_px.push_back(m.model_pixel_of(p));
  return UnprojectPixels(c, model_px);
}

Eigen::VectorXd Differences(const LensWithCovariance& la, const LensWithCovariance& lb, const std::vector<double>& ia,
                            const std::vector<double>& ib, const std::vector<Eigen::Vector2d>& grid,
                            const std::vector<bool>& region, double* angle_rad = nullptr) {
  CameraModel b = lb.model;
  b.intrinsics = ib;
  const std::vector<Eigen::Vector3d> va = Rays(la, ia, grid), vb = Rays(lb, ib, grid);
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < grid.size(); ++k) {
    if (region[k] && va[k].allFinite() && vb[k].allFinite()) h += vb[k].normalized() * va[k].normalized().transpose();
  }
  // Kabsch: the rotation R maximising sum vb . R va.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d rot = svd.matrixU() * d * svd.matrixV().transpose();
  if (angle_rad) *angle_rad = Eigen::AngleAxisd(rot).angle();
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& v : va) points.push_back(rot * v.normalized());
  std::vector<Eigen::Vector2d> qb = ProjectPoints(b, points);
  if (lb.true_image_of) {
    for (Eigen::Vector2d& q : qb) q = lb.true_image_of(q);
  }
  Eigen::VectorXd out(2 * static_cast<long>(grid.size()));
  for (size_t k = 0; k < grid.size(); ++k) out.segment<2>(2 * static_cast<long>(k)) = qb[k] - grid[k];
  return out;
}

// Jacobian of Differences with respect to the intrinsics of `which` (0: a, 1: b), central differences.
Eigen::MatrixXd DifferenceJacobian(const LensWithCovariance& a, const LensWithCovariance& b, int which,
                                   const std::vector<Eigen::Vector2d>& grid, const std::vector<bool>& region) {
  const LensWithCovariance& m = which == 0 ? a : b;
  const int n = static_cast<int>(m.model.intrinsics.size());
  Eigen::MatrixXd g(2 * static_cast<long>(grid.size()), n);
  for (int i = 0; i < n; ++i) {
    const double sigma = std::sqrt(std::max(0.0, m.covariance(i, i)));
    const double step = sigma > 0 ? 1e-3 * sigma : 1e-7 * std::max(1.0, std::abs(m.model.intrinsics[static_cast<size_t>(i)]));
    std::vector<double> plus = m.model.intrinsics, minus = m.model.intrinsics;
    plus[static_cast<size_t>(i)] += step;
    minus[static_cast<size_t>(i)] -= step;
    const Eigen::VectorXd dp = which == 0 ? Differences(a, b, plus, b.model.intrinsics, grid, region)
                                          : Differences(a, b, a.model.intrinsics, plus, grid, region);
    const Eigen::VectorXd dm = which == 0 ? Differences(a, b, minus, b.model.intrinsics, grid, region)
                                          : Differences(a, b, a.model.intrinsics, minus, grid, region);
    g.col(i) = (dp - dm) / (2 * step);
  }
  return g;
}

bool HasCovariance(const LensWithCovariance& m) {
  const long n = static_cast<long>(m.model.intrinsics.size());
  return m.covariance.rows() == n && m.covariance.cols() == n && n > 0;
}

bool HasUnmodelledField(const LensWithCovariance& m) {
  return std::any_of(m.unmodelled.begin(), m.unmodelled.end(), [](const UncertaintyBudget::FieldComponent& c) {
    return c.variance_px2 > 0 && c.length_px > 0;
  });
}

}  // namespace

std::vector<Eigen::Vector2d> ImagerGrid(int width, int height, int gx, int gy) {
  std::vector<Eigen::Vector2d> q;
  for (int j = 0; j < gy; ++j) {
    for (int i = 0; i < gx; ++i) q.emplace_back((i + 0.5) * width / gx - 0.5, (j + 0.5) * height / gy - 0.5);
  }
  return q;
}

std::vector<bool> CoveredCells(const std::vector<Eigen::Vector2d>& observed_px, int width, int height, int gx, int gy,
                               int min_points) {
  std::vector<int> count(static_cast<size_t>(gx * gy), 0);
  for (const Eigen::Vector2d& q : observed_px) {
    const int i = static_cast<int>(std::floor((q.x() + 0.5) * gx / width));
    const int j = static_cast<int>(std::floor((q.y() + 0.5) * gy / height));
    if (i >= 0 && i < gx && j >= 0 && j < gy) ++count[static_cast<size_t>(j * gx + i)];
  }
  std::vector<bool> out;
  for (int c : count) out.push_back(c >= min_points);
  return out;
}

double ChiSquare2Quantile(double alpha) { return -2 * std::log(alpha); }

double AgreementBound(const ProjectionComparison& c, double alpha) {
  return std::sqrt(ChiSquare2Quantile(alpha / std::max(1, c.rank)));
}

ProjectionComparison CompareProjections(const LensWithCovariance& a, const LensWithCovariance& b,
                                        const std::vector<Eigen::Vector2d>& grid, const std::vector<bool>& given) {
  if (a.model.width != b.model.width || a.model.height != b.model.height) {
    throw Error("CompareProjections",
                fmt::format("the imagers differ: {} x {} and {} x {} px", a.model.width, a.model.height,
                            b.model.width, b.model.height),
                "compare models of one camera at one resolution");
  }
  ProjectionComparison r;
  r.pixel_px = grid;
  r.in_region = given.empty() ? std::vector<bool>(grid.size(), true) : given;
  if (r.in_region.size() != grid.size() || std::count(r.in_region.begin(), r.in_region.end(), true) < 3) {
    throw Error("CompareProjections", "the comparison region has fewer than 3 grid points",
                "give a larger region (more photos toward the image's edges)");
  }
  double angle = 0;
  const Eigen::VectorXd d = Differences(a, b, a.model.intrinsics, b.model.intrinsics, grid, r.in_region, &angle);
  r.rotation_deg = angle * 180 / M_PI;
  const long rows = d.size();
  Eigen::MatrixXd l(rows, 0);  // Cov(d) = L L^T
  for (int which = 0; which < 2; ++which) {
    const LensWithCovariance& m = which == 0 ? a : b;
    if (!HasCovariance(m)) continue;
    const Eigen::MatrixXd g = DifferenceJacobian(a, b, which, grid, r.in_region);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (m.covariance + m.covariance.transpose()));
    const Eigen::MatrixXd half =
        eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    Eigen::MatrixXd joined(rows, l.cols() + half.cols());
    joined << l, g * half;
    l = joined;
    const LensWithCovariance& other = which == 0 ? b : a;
    if (!HasCovariance(other) && HasUnmodelledField(m)) {
      // The unmodelled field over the grid: K = sum over the components of their covariance at the distance,
      // per coordinate, factored K = U S U^T (modes below 1e-9 of the largest dropped).
      const long n = static_cast<long>(grid.size());
      Eigen::MatrixXd k = Eigen::MatrixXd::Zero(n, n);
      for (const UncertaintyBudget::FieldComponent& c : m.unmodelled) {
        if (!(c.variance_px2 > 0) || !(c.length_px > 0)) continue;
        for (long i = 0; i < n; ++i) {
          for (long j = 0; j < n; ++j) {
            k(i, j) += MisfitComponentCovariance(
                c, (grid[static_cast<size_t>(i)] - grid[static_cast<size_t>(j)]).norm());
          }
        }
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ke(k);
      const double top = ke.eigenvalues().maxCoeff();
      std::vector<long> keep;
      for (long i = 0; i < n; ++i) {
        if (ke.eigenvalues()[i] > 1e-9 * top) keep.push_back(i);
      }
      const long nk = static_cast<long>(keep.size());
      Eigen::MatrixXd field = Eigen::MatrixXd::Zero(rows, 2 * nk);
      for (long c = 0; c < nk; ++c) {
        const Eigen::VectorXd col = ke.eigenvectors().col(keep[static_cast<size_t>(c)]) *
                                    std::sqrt(ke.eigenvalues()[keep[static_cast<size_t>(c)]]);
        for (long i = 0; i < n; ++i) field(2 * i, 2 * c) = field(2 * i + 1, 2 * c + 1) = col[i];
      }
      Eigen::MatrixXd with(rows, l.cols() + field.cols());
      with << l, field;
      l = with;
    }
  }
  std::vector<double> dist, sig, maha;
  std::vector<long> region_rows;
  for (size_t k = 0; k < grid.size(); ++k) {
    const long row = 2 * static_cast<long>(k);
    const Eigen::Vector2d dk = d.segment<2>(row);
    const Eigen::Matrix2d ck = l.cols() ? Eigen::Matrix2d(l.middleRows<2>(row) * l.middleRows<2>(row).transpose())
                                        : Eigen::Matrix2d::Zero();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> e(ck);
    const double s = std::sqrt(std::max(0.0, e.eigenvalues().maxCoeff()));
    const double mk = e.eigenvalues().minCoeff() > 1e-12 * std::max(1e-12, e.eigenvalues().maxCoeff())
                          ? std::sqrt(dk.dot(ck.ldlt().solve(dk)))
                          : kNaN;
    r.diff_px.push_back(dk);
    r.covariance_px2.push_back(ck);
    r.sigma_px.push_back(s);
    r.mahalanobis.push_back(mk);
    if (!r.in_region[k] || !dk.allFinite()) continue;
    dist.push_back(dk.norm());
    sig.push_back(s);
    if (std::isfinite(mk)) maha.push_back(mk);
    region_rows.push_back(row);
    region_rows.push_back(row + 1);
  }
  if (l.cols() > 0) {
    Eigen::MatrixXd lr(static_cast<long>(region_rows.size()), l.cols());
    for (size_t i = 0; i < region_rows.size(); ++i) lr.row(static_cast<long>(i)) = l.row(region_rows[i]);
    const Eigen::BDCSVD<Eigen::MatrixXd> svd(lr);
    const Eigen::VectorXd sv = svd.singularValues();
    for (long i = 0; i < sv.size(); ++i) r.rank += sv[i] > 1e-6 * sv[0] ? 1 : 0;
  }
  const auto max_of = [](const std::vector<double>& v) { return v.empty() ? kNaN : *std::max_element(v.begin(), v.end()); };
  r.median_px = dist.empty() ? kNaN : Median(dist);
  r.max_px = max_of(dist);
  r.median_sigma_px = sig.empty() ? kNaN : Median(sig);
  r.max_sigma_px = max_of(sig);
  r.median_mahalanobis = maha.empty() ? kNaN : Median(maha);
  r.max_mahalanobis = max_of(maha);
  return r;
}

}  // namespace curvecheck
