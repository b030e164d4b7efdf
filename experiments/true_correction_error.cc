#include "experiments/true_correction_error.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <optional>

#include "core/camera_model.h"
#include "core/error.h"
#include "core/screen_geometry.h"
#include "core/stats.h"
#include "synth/lens_misfit.h"

namespace curvecheck::experiments {
namespace {

using Vec8 = Eigen::Matrix<double, 8, 1>;

// Where the camera sees display position p: the normalized image point of the true surface point, or nothing
// when the point is behind the camera.
std::optional<Eigen::Vector2d> Normalized(const TrueImages& truth, const Eigen::Vector2d& display_px) {
  const Eigen::Vector3d x = truth.CameraPoint(display_px);
  if (!(x.z() > 1e-6)) return std::nullopt;
  return Eigen::Vector2d(x.x() / x.z(), x.y() / x.z());
}

struct Seen {
  Eigen::Vector2d ab;      // pattern mm / 1000 (conditioning)
  Eigen::Vector2d n;       // normalized image point
  Eigen::Matrix2d j_inv;   // d(display px) / dn
};

Eigen::Vector2d Apply(const Vec8& h, const Eigen::Vector2d& ab, double* w_out = nullptr) {
  const double w = h(6) * ab.x() + h(7) * ab.y() + 1;
  if (w_out) *w_out = w;
  return {(h(0) * ab.x() + h(1) * ab.y() + h(2)) / w, (h(3) * ab.x() + h(4) * ab.y() + h(5)) / w};
}

// Normalized DLT (Hartley): the homography ab -> n with h33 = 1.
Vec8 Dlt(const std::vector<Seen>& seen) {
  const auto similarity = [&](bool image) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const Seen& s : seen) mean += image ? s.n : s.ab;
    mean /= static_cast<double>(seen.size());
    double spread = 0;
    for (const Seen& s : seen) spread += ((image ? s.n : s.ab) - mean).norm();
    const double k = std::sqrt(2.0) * static_cast<double>(seen.size()) / std::max(spread, 1e-12);
    Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
    t(0, 0) = t(1, 1) = k;
    t.block<2, 1>(0, 2) = -k * mean;
    return t;
  };
  const Eigen::Matrix3d ta = similarity(false), tn = similarity(true);
  Eigen::MatrixXd a(2 * seen.size(), 9);
  for (size_t i = 0; i < seen.size(); ++i) {
    const Eigen::Vector3d p = ta * seen[i].ab.homogeneous();
    const Eigen::Vector3d q = tn * seen[i].n.homogeneous();
    a.row(2 * i) << p.x(), p.y(), 1, 0, 0, 0, -q.x() * p.x(), -q.x() * p.y(), -q.x();
    a.row(2 * i + 1) << 0, 0, 0, p.x(), p.y(), 1, -q.y() * p.x(), -q.y() * p.y(), -q.y();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd v = svd.matrixV().col(8);
  Eigen::Matrix3d hn;
  hn << v(0), v(1), v(2), v(3), v(4), v(5), v(6), v(7), v(8);
  Eigen::Matrix3d h = tn.inverse() * hn * ta;
  h /= h(2, 2);
  Vec8 out;
  out << h(0, 0), h(0, 1), h(0, 2), h(1, 0), h(1, 1), h(1, 2), h(2, 0), h(2, 1);
  return out;
}

double Cost(const Vec8& h, const std::vector<Seen>& seen) {
  double c = 0;
  for (const Seen& s : seen) c += (s.j_inv * (Apply(h, s.ab) - s.n)).squaredNorm();
  return c;
}

// Gauss-Newton (Levenberg-damped when a step does not lower the cost) on the display-px residuals.
Vec8 Refine(Vec8 h, const std::vector<Seen>& seen) {
  double cost = Cost(h, seen), lambda = 0;
  for (int iter = 0; iter < 50; ++iter) {
    Eigen::Matrix<double, 8, 8> jtj = Eigen::Matrix<double, 8, 8>::Zero();
    Vec8 jtr = Vec8::Zero();
    for (const Seen& s : seen) {
      double w = 1;
      const Eigen::Vector2d m = Apply(h, s.ab, &w);
      Eigen::Matrix<double, 2, 8> dm;
      const double a = s.ab.x(), b = s.ab.y();
      dm << a / w, b / w, 1 / w, 0, 0, 0, -m.x() * a / w, -m.x() * b / w,  //
          0, 0, 0, a / w, b / w, 1 / w, -m.y() * a / w, -m.y() * b / w;
      const Eigen::Matrix<double, 2, 8> jr = s.j_inv * dm;
      const Eigen::Vector2d r = s.j_inv * (m - s.n);
      jtj += jr.transpose() * jr;
      jtr += jr.transpose() * r;
    }
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::Matrix<double, 8, 8> damped = jtj;
      damped.diagonal() *= 1 + lambda;
      const Vec8 step = damped.ldlt().solve(-jtr);
      const double next = Cost(h + step, seen);
      if (next <= cost) {
        h += step;
        improved = true;
        const bool converged = cost - next <= 1e-15 * std::max(cost, 1e-30) || step.norm() < 1e-14;
        cost = next;
        lambda = lambda / 10;
        if (converged) return h;
      } else {
        lambda = lambda == 0 ? 1e-6 : lambda * 10;
      }
    }
    if (!improved) break;
  }
  return h;
}

}  // namespace

TrueCorrectionError MeasureTrueCorrectionError(const SyntheticScene& scene, const Pattern& pattern) {
  const TrueImages truth(scene);
  std::vector<Seen> seen;
  for (const Feature& f : pattern.features) {
    if (!f.display_px || !f.visible) continue;
    const Eigen::Vector2d p = *f.display_px;
    const std::optional<Eigen::Vector2d> n = Normalized(truth, p);
    if (!n) continue;
    const Eigen::Vector2d q = ProjectPoint(scene.camera, n->homogeneous());
    if (!(q.x() >= 0 && q.y() >= 0 && q.x() <= scene.camera.width - 1 && q.y() <= scene.camera.height - 1)) continue;
    Eigen::Matrix2d j;
    bool ok = true;
    for (int axis = 0; axis < 2; ++axis) {
      const Eigen::Vector2d e = Eigen::Vector2d::Unit(axis) * 0.5;
      const std::optional<Eigen::Vector2d> plus = Normalized(truth, p + e);
      const std::optional<Eigen::Vector2d> minus = Normalized(truth, p - e);
      if (!plus || !minus) {
        ok = false;
        break;
      }
      j.col(axis) = (*plus - *minus) / 1.0;
    }
    if (!ok || !(std::abs(j.determinant()) > 1e-20)) continue;
    seen.push_back({f.pattern_mm / 1000.0, *n, j.inverse()});
  }
  if (seen.size() < 5) {
    throw Error("true correction error", fmt::format("only {} features are in the camera's view", seen.size()),
                "place the camera so that it sees the pattern");
  }
  const Vec8 h = Refine(Dlt(seen), seen);
  TrueCorrectionError out;
  out.features = static_cast<int>(seen.size());
  std::vector<double> lengths;
  for (const Seen& s : seen) {
    // The displacement of the shown feature that would put it where the planar image needs it.
    const Eigen::Vector2d d = s.j_inv * (Apply(h, s.ab) - s.n);
    out.error_display_px.push_back(d);
    lengths.push_back(d.norm());
    out.max_display_px = std::max(out.max_display_px, d.norm());
  }
  out.p95_display_px = Percentile(lengths, 95);
  out.rms_display_px = Rms(lengths);
  return out;
}

}  // namespace curvecheck::experiments
