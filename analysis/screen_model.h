// Screen models for the fit (issue 6 item 3): the point of the physical screen at display coordinates (u, v),
// as a function of a few shape parameters, in the fitted screen's CENTRE frame: origin at the screen centre,
// x right, y up, +z toward the viewer (architecture.md's screen frame shifted by +R in z). Units: mm, radians.
//
// A feature at (u, v) (UvFromDisplayPx) has arc length s = u W/2 along its row and height y = -v H/2, with W, H
// the monitor's active width and height from the spec: the pixel pitch is fixed (scale is otherwise not
// observable from photos). The models, with k the curvature (1/mm, > 0 when the edges come toward the viewer):
//   flat                         P = (s, y, 0)
//   cylinder                     P = C_k(s) + (0, y, 0),  C_k(s) = (sin(k s)/k, 0, (1 - cos(k s))/k)
//   cylinder+lean                P = C_k(s) + y (0, cos(lambda), sin(lambda)): the cylinder's axis tilted by
//                                lambda against the panel's columns (top toward the viewer for lambda > 0), rows
//                                stay horizontal arcs of radius 1/k. A rigid tilt of the whole panel is a camera
//                                pose; this one is observable through the rows' sagitta seen at a slant.
//   varying-curvature            k(s) = k0 + k1 (s/h), h = W/2; the row is the curve of heading
//                                phi(s) = int_0^s k = k0 s + k1 s^2/(2h), P = (int_0^s cos phi, y, int_0^s sin phi)
//                                (8-point Gauss-Legendre quadrature: exact to 1e-12 mm for |phi| < 1).
//   varying-curvature-quadratic  the same with + k2 (s/h)^2, phi += k2 s^3/(3 h^2).
//   cylinder+deviation           cylinder + d(u, v) n(s), n = (-sin(k s), 0, cos(k s)) the unit normal toward
//                                the viewer, d a smooth field (DeviationBasis) with the rigid and curvature
//                                modes removed so that it does not duplicate the pose or the radius.
// Every formula is written with sinc forms, so that k = 0 (flat) is inside each family, and is templated so
// that Ceres Jets differentiate it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <string>
#include <vector>

#include "core/monitor.h"

namespace curvecheck {

enum class ScreenModelKind {
  kFlat,
  kCylinder,
  kCylinderLean,
  kVaryingCurvature,
  kVaryingCurvatureQuadratic,
  kCylinderDeviation,
};

// "flat", "cylinder", "cylinder+lean", "varying-curvature", "varying-curvature-quadratic", "cylinder+deviation".
const char* ScreenModelName(ScreenModelKind kind);
// Inverse of ScreenModelName; throws Error naming `where` for an unknown name (listing the known ones).
ScreenModelKind ParseScreenModel(const std::string& name, const std::string& where);
// ParseScreenModel of each name, in order.
std::vector<ScreenModelKind> ParseScreenModels(const std::vector<std::string>& names, const std::string& where);
// The models in order of complexity (the order FitScreen reports them in).
std::vector<ScreenModelKind> AllScreenModels();
// Number of shape parameters other than the deviation field: flat 0, cylinder 1 (k), cylinder+lean 2 (k, lambda),
// varying-curvature 2 (k0, k1), varying-curvature-quadratic 3 (k0, k1, k2), cylinder+deviation 1 (k).
int CoreParameterCount(ScreenModelKind kind);

namespace screen_model_internal {

// sin(x)/x for doubles and Jets, exact at 0 (series below 1e-4, where the truncation error of value and
// derivative is below 1e-20).
template <typename T>
T SincT(const T& x) {
  using std::abs, std::sin;
  if (abs(x) < 1e-4) {
    const T x2 = x * x;
    return T(1) - x2 / 6.0 * (T(1) - x2 / 20.0);
  }
  return sin(x) / x;
}

// Heading integral of a row of curvature k(t) = k0 + k1 t/h + k2 t^2/h^2 from 0 to s: (x, z) in the centre frame.
template <typename T>
void VaryingRow(const T& k0, const T& k1, const T& k2, double s, double h, T* x, T* z) {
  // 8-point Gauss-Legendre nodes and weights on [-1, 1].
  static constexpr double kNode[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                                      -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                      0.7966664774136267,  0.9602898564975363};
  static constexpr double kWeight[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                        0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                        0.2223810344533745, 0.1012285362903763};
  using std::cos, std::sin;
  *x = T(0);
  *z = T(0);
  for (int i = 0; i < 8; ++i) {
    const double t = 0.5 * s * (kNode[i] + 1);
    const T phi = k0 * t + k1 * (t * t / (2 * h)) + k2 * (t * t * t / (3 * h * h));
    *x += kWeight[i] * cos(phi);
    *z += kWeight[i] * sin(phi);
  }
  *x *= 0.5 * s;
  *z *= 0.5 * s;
}

}  // namespace screen_model_internal

// Point (centre frame, mm) of the model surface WITHOUT the deviation field, at arc length s_mm and height y_mm,
// and its unit normal toward the viewer. `core` holds CoreParameterCount(kind) values (k in 1/mm, lambda in
// rad); `half_width_mm` is W/2 (used by the varying-curvature models).
template <typename T>
Eigen::Matrix<T, 3, 1> CoreScreenPoint(ScreenModelKind kind, const T* core, double s_mm, double y_mm,
                                       double half_width_mm, Eigen::Matrix<T, 3, 1>* normal) {
  using screen_model_internal::SincT;
  using std::cos, std::sin, std::sqrt;
  using V = Eigen::Matrix<T, 3, 1>;
  switch (kind) {
    case ScreenModelKind::kFlat:
      if (normal) *normal = V(T(0), T(0), T(1));
      return V(T(s_mm), T(y_mm), T(0));
    case ScreenModelKind::kCylinder:
    case ScreenModelKind::kCylinderDeviation:
    case ScreenModelKind::kCylinderLean: {
      // x = s sinc(phi), z = (1 - cos phi)/k = s (phi/2) sinc^2(phi/2), phi = k s.
      const T phi = core[0] * s_mm;
      const T half = SincT(T(0.5) * phi);
      V p(s_mm * SincT(phi), T(y_mm), s_mm * T(0.5) * phi * half * half);
      if (kind != ScreenModelKind::kCylinderLean) {
        if (normal) *normal = V(-sin(phi), T(0), cos(phi));
        return p;
      }
      const T lambda = core[1];
      p.y() = y_mm * cos(lambda);
      p.z() += y_mm * sin(lambda);
      if (normal) {
        // d/ds = (cos phi, 0, sin phi), d/dy = (0, cos lambda, sin lambda); n = d/ds x d/dy, normalized.
        const V n(-sin(phi) * cos(lambda), -cos(phi) * sin(lambda), cos(phi) * cos(lambda));
        *normal = n / sqrt(n.squaredNorm());
      }
      return p;
    }
    case ScreenModelKind::kVaryingCurvature:
    case ScreenModelKind::kVaryingCurvatureQuadratic: {
      const T k2 = kind == ScreenModelKind::kVaryingCurvatureQuadratic ? core[2] : T(0);
      T x, z;
      screen_model_internal::VaryingRow(core[0], core[1], k2, s_mm, half_width_mm, &x, &z);
      if (normal) {
        const double h = half_width_mm;
        const T phi = core[0] * s_mm + core[1] * (s_mm * s_mm / (2 * h)) + k2 * (s_mm * s_mm * s_mm / (3 * h * h));
        *normal = V(-sin(phi), T(0), cos(phi));
      }
      return V(x, T(y_mm), z);
    }
  }
  return V::Zero();
}

// The deviation field's basis: d(u, v) = Weights(u, v) . z. Tensor-product uniform cubic B-splines over
// [-1, 1]^2 (nu x nv coefficients c, knots spaced 2/(nu-3) and 2/(nv-3) so the splines span the whole screen),
// restricted to the subspace c = N z orthogonal, in the L2 inner product over the screen, to the normal
// components of the modes that a pose or a radius change produce on a cylinder of curvature k:
//   cos(phi), sin(phi) (x and z shifts; rotation about y equals a shift plus a slide along the surface),
//   v cos(phi) (rotation about x, also the normal part of a lean), v sin(phi) (rotation about z),
//   (1 - cos phi)/k^2 ~ s^2/2 (radius change),     phi = k s.
// N has orthonormal columns, so |z| = |c| (the prior on z is one on the coefficients).
class DeviationBasis {
 public:
  DeviationBasis() = default;
  // Throws Error unless nu, nv >= 4 and the monitor is valid. `curvature_per_mm` selects the cylinder whose
  // rigid modes are removed (the fitted or nominal one).
  DeviationBasis(const Monitor& monitor, double curvature_per_mm, int nu, int nv);

  int size() const { return static_cast<int>(null_.cols()); }  // free coefficients: nu nv - 5
  int nu() const { return nu_; }
  int nv() const { return nv_; }
  // Row vector w with d(u, v) = w . z (mm per unit of z).
  Eigen::VectorXd Weights(const Eigen::Vector2d& uv) const;
  // The raw B-spline values at (u, v) (nu nv of them, u fastest).
  Eigen::VectorXd Splines(const Eigen::Vector2d& uv) const;
  // The five gauge modes at (u, v), in the order above (for tests and for projecting a truth field).
  Eigen::Matrix<double, 5, 1> Modes(const Eigen::Vector2d& uv) const;

 private:
  int nu_ = 0, nv_ = 0;
  double theta_ = 0;  // k W/2: phi = theta u
  double k_ = 0, half_width_mm_ = 0;
  Eigen::MatrixXd null_;  // nu nv x (nu nv - 5)
};

// Uniform cubic B-spline kernel B(t), support |t| < 2, sum over integer shifts = 1.
double CubicBSpline(double t);

}  // namespace curvecheck
