#include "synth/true_surface.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/screen_geometry.h"
#include "synth/scene.h"

namespace curvecheck::synth_internal {
namespace {

// atan(x) for |x| <= 1, within 1e-10 rad: reduced to |x| <= tan(pi/8) and summed as its odd series to x^21
// (the next term is below 0.4143^23 / 23 = 7e-11).
inline double FastAtan(double x) {
  constexpr double kTanPi8 = 0.41421356237309503;
  double offset = 0;
  if (x > kTanPi8) {
    offset = std::numbers::pi / 4;
    x = (x - 1) / (x + 1);
  } else if (x < -kTanPi8) {
    offset = -std::numbers::pi / 4;
    x = (x + 1) / (1 - x);
  }
  // Estrin's scheme (short dependency chains) for sum_n (-1)^n x2^n / (2n + 1), n = 0..10.
  const double x2 = x * x, x4 = x2 * x2, x8 = x4 * x4, x16 = x8 * x8;
  const double p01 = 1.0 - x2 / 3, p23 = 1.0 / 5 - x2 / 7, p45 = 1.0 / 9 - x2 / 11, p67 = 1.0 / 13 - x2 / 15;
  const double p89 = 1.0 / 17 - x2 / 19;
  const double p = (p01 + x4 * p23) + x8 * (p45 + x4 * p67) + x16 * (p89 + x4 * (1.0 / 21));
  return offset + x * p;
}

}  // namespace

TrueGeometry::TrueGeometry(const Monitor& nominal, const TrueMonitor& t) : truth(&t) {
  k = t.curvature_per_mm;
  half_w = 0.5 * nominal.width_mm * t.pitch_scale;
  half_h = 0.5 * nominal.height_mm * t.pitch_scale;
  const double l = t.lean_deg * kRadPerDeg;
  cos_l = std::cos(l);
  sin_l = std::sin(l);
  shear = t.Shear();
  upright_from_true = shear.inverse();
  rotation = t.Rotation();
  centre_in_screen = ScreenCentreInScreen(nominal) + t.translation_mm;
}

SurfaceIntersector::SurfaceIntersector(const SyntheticScene& s, double max_abs_v)
    : geometry_(s.monitor, s.truth), max_abs_v_(max_abs_v) {
  const Eigen::Matrix3d true_from_screen = geometry_.rotation.transpose();
  upright_from_cam_ = geometry_.upright_from_true * true_from_screen * s.screen_from_cam.RotationMatrix();
  o_ = geometry_.upright_from_true * true_from_screen * (s.screen_from_cam.translation - geometry_.centre_in_screen);
  k_ = geometry_.k;
  c_term_ = k_ * (o_.x() * o_.x() + o_.z() * o_.z()) - 2 * o_.z();
  u_from_s_ = 1 / geometry_.half_w;
  u_from_phi_ = k_ == 0 ? 0.0 : 1 / (k_ * geometry_.half_w);
  v_from_y_ = -1 / geometry_.half_h;
  for (const TrueMonitor::Bump& b : s.truth.bumps) {
    // A ray meets the deviated surface at most |h| tan(incidence) from where it meets the base surface; 4 |h|
    // covers incidences up to 76 deg.
    const double grow_mm = 4 * std::abs(b.height_mm);
    const double gu = grow_mm / geometry_.half_w, gv = grow_mm / geometry_.half_h;
    bump_support_.push_back({b.u - 4 * b.sigma_u - gu, b.u + 4 * b.sigma_u + gu, b.v - 4 * b.sigma_v - gv,
                             b.v + 4 * b.sigma_v + gv});
  }
}

bool SurfaceIntersector::Intersect(const Eigen::Vector3d& d, int64_t* refined, double* u_out, double* v_out,
                                   HitGeometry* hit) const {
  double t;
  if (k_ == 0) {
    if (!(d.z() < 0)) return false;
    t = -o_.z() / d.z();  // the plane z = 0
  } else {
    // k |p_xz|^2 - 2 p_z = 0 with p = o + t d: a t^2 + b t + c = 0; the viewer sees the larger root (the
    // cancellation-free form as in IntersectSurface).
    const double a = k_ * (d.x() * d.x() + d.z() * d.z());
    const double b = 2 * (k_ * (o_.x() * d.x() + o_.z() * d.z()) - d.z());
    const double disc = b * b - 4 * a * c_term_;
    if (!(disc >= 0) || a == 0) return false;
    const double sq = std::sqrt(disc);
    if (b >= 0) {
      const double q = -0.5 * (b + sq);
      if (q == 0) return false;
      t = c_term_ / q;
    } else {
      t = -0.5 * (b - sq) / a;
    }
  }
  if (!(t > 0)) return false;
  const double py = o_.y() + t * d.y();
  double v = py * v_from_y_;
  if (std::abs(v) > max_abs_v_ && bump_support_.empty()) return false;
  const double px = o_.x() + t * d.x();
  double u, sin_phi = 0, cos_phi = 1;
  if (k_ == 0) {
    u = px * u_from_s_;
  } else {
    const double pz = o_.z() + t * d.z();
    sin_phi = k_ * px;
    cos_phi = 1 - k_ * pz;
    const double den = 2 - k_ * pz;  // 1 + cos(phi)
    const double tan_half = k_ * px / den;
    const double phi = (den > 0 && std::abs(tan_half) <= 1) ? 2 * FastAtan(tan_half) : std::atan2(k_ * px, 1 - k_ * pz);
    u = phi * u_from_phi_;
  }
  for (const Box& box : bump_support_) {
    if (u >= box.u0 && u <= box.u1 && v >= box.v0 && v <= box.v1) {
      ++*refined;
      Refine(d, sin_phi, cos_phi, &u, &v);
      break;
    }
  }
  if (hit) {
    // The angle in the true centre frame (the upright frame's shear does not keep angles): the leaned normal
    // (TrueGeometry::Normal) against the ray's direction there.
    const Eigen::Vector3d d_true = geometry_.shear * d;
    const double cl = geometry_.cos_l, sl = geometry_.sin_l;
    const Eigen::Vector3d n(-sin_phi * cl, -cos_phi * sl, cos_phi * cl);
    hit->t = t;
    hit->cos_incidence = std::abs(n.dot(d_true)) / std::sqrt(n.squaredNorm() * d_true.squaredNorm());
  }
  *u_out = u;
  *v_out = v;
  return true;
}

// Solves P(u, v) + dev(u, v) n(u, v) = o + t d in the true centre frame by fixed-point steps: intersect the ray
// with the tangent plane at the current deviated point, take off the deviation along the normal and project back
// onto the base surface (TrueGeometry's BasePoint and Normal, written out with one sincos per step; (u, v) of a
// point from its upright image). Each step shrinks the error by about |grad dev| tan(incidence) (0.01 for the
// 2 mm bulge scene, below 0.1 for any bump less steep than 1:10 seen at less than 45 deg), so stopping after a
// step below 1e-5 in u, v leaves below 1e-6 (0.6 um on a 1.2 m panel, 0.003 display px); at most 8 steps.
// sin_phi, cos_phi: of the base hit's angle (exact there: k x and 1 - k z on the cylinder); each step gets them
// from its own point the same way, so no step calls sin or cos.
void SurfaceIntersector::Refine(const Eigen::Vector3d& d_upright, double sin_phi, double cos_phi, double* u,
                                double* v) const {
  const Eigen::Vector3d origin = geometry_.shear * o_, d = geometry_.shear * d_upright;
  const double cl = geometry_.cos_l, sl = geometry_.sin_l, tan_l = sl / cl;
  double uu = *u, vv = *v, sn = sin_phi, cs = cos_phi;
  for (int iter = 0; iter < 8; ++iter) {
    const double arc = uu * geometry_.half_w, w = -vv * geometry_.half_h;
    const double x = k_ == 0 ? arc : sn / k_, z = k_ == 0 ? 0.0 : (1 - cs) / k_;
    const Eigen::Vector3d base(x, w * cl, z + w * sl);
    const Eigen::Vector3d n = Eigen::Vector3d(-sn * cl, -cs * sl, cs * cl) / std::sqrt(sn * sn * cl * cl + cs * cs);
    const double dev = geometry_.truth->DeviationMm({uu, vv});
    const double nd = n.dot(d);
    if (nd == 0) break;
    const double t = (n.dot(base - origin) + dev) / nd;
    const Eigen::Vector3d p = origin + t * d - dev * n;
    const double px = p.x(), py = p.y() / cl, pz = p.z() - p.y() * tan_l;  // upright
    double next_u = px * u_from_s_;
    if (k_ != 0) {
      // atan2(a, b) = 2 atan(a / (hypot(a, b) + b)) for b > 0 (|angle| < 90 deg), else the library's.
      const double a = k_ * px, b = 1 - k_ * pz, r = std::sqrt(a * a + b * b);
      next_u = (b > 0 ? 2 * FastAtan(a / (r + b)) : std::atan2(a, b)) * u_from_phi_;
      sn = a / r;
      cs = b / r;
    }
    const double next_v = py * v_from_y_;
    const bool done = std::max(std::abs(next_u - uu), std::abs(next_v - vv)) < 1e-5;
    uu = next_u;
    vv = next_v;
    if (done) break;
  }
  *u = uu;
  *v = vv;
}

}  // namespace curvecheck::synth_internal
