#include "core/screen_geometry.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"
#include "core/math_util.h"

namespace curvecheck {
namespace {

// The "centre frame" is the screen frame translated so that the screen centre is the origin:
// p_centre = p_screen - ScreenCentreInScreen. There the cylinder is kappa (x^2 + z^2) = 2 z, the plane z = 0
// when kappa = 0, and the axis is at z = R.
Eigen::Vector3d ToCentre(const Monitor& m, const Eigen::Vector3d& p) { return p - ScreenCentreInScreen(m); }
Eigen::Vector3d FromCentre(const Monitor& m, const Eigen::Vector3d& p) { return p + ScreenCentreInScreen(m); }

// Arc length s from the centre column to the point's angular position on the cylinder; x for kappa = 0.
double ArcLengthInCentre(const Monitor& m, const Eigen::Vector3d& p) {
  const double k = m.curvature_per_mm;
  if (k == 0) return p.x();
  return std::atan2(k * p.x(), 1 - k * p.z()) / k;
}

}  // namespace

Eigen::Vector3d ScreenCentreInScreen(const Monitor& m) {
  return m.is_flat() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(0, 0, -m.radius_mm());
}

Eigen::Vector3d ViewpointFromScreenCentre(const Monitor& m, double distance_mm, const Eigen::Vector2d& offset_mm) {
  return ScreenCentreInScreen(m) + Eigen::Vector3d(offset_mm.x(), offset_mm.y(), distance_mm);
}

Eigen::Vector2d UvFromDisplayPx(const Monitor& m, const Eigen::Vector2d& px) {
  return {2 * (px.x() + 0.5) / m.width_px - 1, 2 * (px.y() + 0.5) / m.height_px - 1};
}

Eigen::Vector2d DisplayPxFromUv(const Monitor& m, const Eigen::Vector2d& uv) {
  return {(uv.x() + 1) * 0.5 * m.width_px - 0.5, (uv.y() + 1) * 0.5 * m.height_px - 0.5};
}

Eigen::Vector3d SurfacePointFromUv(const Monitor& m, const Eigen::Vector2d& uv) {
  // With s = u W/2 and phi = kappa s: x = sin(phi)/kappa = s sinc(phi),
  // z = (1 - cos phi)/kappa = s (phi/2) sinc^2(phi/2)   (relative to the centre; thesis Eq 4.1).
  const double s = 0.5 * uv.x() * m.width_mm;
  const double phi = m.curvature_per_mm * s;
  const double half = Sinc(0.5 * phi);
  const Eigen::Vector3d p_centre(s * Sinc(phi), -0.5 * uv.y() * m.height_mm, s * 0.5 * phi * half * half);
  return FromCentre(m, p_centre);
}

Eigen::Vector3d SurfaceNormalFromUv(const Monitor& m, const Eigen::Vector2d& uv) {
  const double phi = m.curvature_per_mm * 0.5 * uv.x() * m.width_mm;
  return {-std::sin(phi), 0, std::cos(phi)};
}

Eigen::Vector2d UvFromSurfacePoint(const Monitor& m, const Eigen::Vector3d& point_in_screen) {
  const Eigen::Vector3d p = ToCentre(m, point_in_screen);
  return {2 * ArcLengthInCentre(m, p) / m.width_mm, -2 * p.y() / m.height_mm};
}

std::optional<SurfaceHit> IntersectSurface(const Monitor& m, const Eigen::Vector3d& origin_in_screen,
                                           const Eigen::Vector3d& direction_in_screen) {
  // In the centre frame the surface is kappa (x^2 + z^2) - 2 z = 0. With p = o + t d (xz components only):
  //   a t^2 + b t + c = 0,  a = kappa |d|^2,  b = 2 (kappa o.d - d_z),  c = kappa |o|^2 - 2 o_z.
  // The viewer sees the exit point of the ray from the cylinder: the larger root. For kappa = 0 this is the
  // plane z = 0 (a = 0). Roots are taken in the cancellation-free form q = -(b + sign(b) sqrt(D))/2,
  // t = {q/a, c/q}.
  const Eigen::Vector3d o = ToCentre(m, origin_in_screen);
  const Eigen::Vector3d& d = direction_in_screen;
  const double k = m.curvature_per_mm;
  const double a = k * (d.x() * d.x() + d.z() * d.z());
  const double b = 2 * (k * (o.x() * d.x() + o.z() * d.z()) - d.z());
  const double c = k * (o.x() * o.x() + o.z() * o.z()) - 2 * o.z();
  double t;
  if (a == 0) {
    if (b == 0) return std::nullopt;  // parallel to the plane, or a vertical ray
    t = -c / b;
  } else {
    const double disc = b * b - 4 * a * c;
    if (disc < 0) return std::nullopt;  // misses the cylinder
    const double sq = std::sqrt(disc);
    if (b >= 0) {
      const double q = -0.5 * (b + sq);  // q <= 0: roots q/a <= 0 and c/q; the larger is c/q
      if (q == 0) return std::nullopt;
      t = c / q;
    } else {
      const double q = -0.5 * (b - sq);  // q > 0: q/a is the larger root
      t = q / a;
    }
  }
  if (!(t > 0) || !std::isfinite(t)) return std::nullopt;
  SurfaceHit hit;
  hit.distance = t;
  const Eigen::Vector3d p_centre = o + t * d;
  hit.point_in_screen = FromCentre(m, p_centre);
  hit.uv = Eigen::Vector2d(2 * ArcLengthInCentre(m, p_centre) / m.width_mm, -2 * p_centre.y() / m.height_mm);
  // A tolerance of 1e-12 keeps points computed exactly on an edge (u = +-1) on the display.
  hit.on_display = std::abs(hit.uv.x()) <= 1 + 1e-12 && std::abs(hit.uv.y()) <= 1 + 1e-12;
  return hit;
}

double FrontClearanceMm(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen) {
  // In the centre frame, with P(phi) = (sin(phi)/kappa, y, (1 - cos phi)/kappa) and n = (-sin phi, 0, cos phi):
  //   f(phi) = (O - P) . n = O_z cos(phi) - O_x sin(phi) + (1 - cos phi)/kappa,   independent of y.
  // Its minimum over [-theta, theta] is at an end or at a stationary point, tan(phi) = -O_x / (O_z - R).
  const Eigen::Vector3d o = ToCentre(m, viewpoint_in_screen);
  const double k = m.curvature_per_mm;
  const double theta = m.half_sector_rad();
  auto f = [&](double phi) {
    const double h = Sinc(0.5 * phi);
    const double one_minus_cos_over_k = (k == 0) ? 0.0 : 0.5 * phi * phi * h * h / k;
    return o.z() * std::cos(phi) - o.x() * std::sin(phi) + one_minus_cos_over_k;
  };
  double best = std::min(f(-theta), f(theta));
  if (k > 0) {
    // f'(phi) = -(O_z - R) sin(phi) - O_x cos(phi) = 0  ->  phi* = atan2(-O_x, O_z - R) (mod pi).
    const double r = 1 / k;
    const double phi0 = std::atan2(-o.x(), o.z() - r);
    for (double cand : {phi0, phi0 - M_PI, phi0 + M_PI}) {
      if (cand > -theta && cand < theta) best = std::min(best, f(cand));
    }
  }
  return best;
}

void CheckViewpoint(const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen, const std::string& where) {
  if (!viewpoint_in_screen.allFinite()) {
    throw Error(where, "viewpoint is not a finite point", "give x,y,z in mm in the screen frame");
  }
  // Farther than 1 km a 1.2 m wide screen spans under 0.07 deg: no camera resolves its pattern, and the
  // geometry's numbers (fields of view, clearances) lose their precision and then overflow (1e160 mm printed an
  // infinite distance and a 45 deg field of view).
  const double distance_mm = (viewpoint_in_screen - ScreenCentreInScreen(m)).stableNorm();  // no overflow at 1e160
  if (!(distance_mm <= kMaxViewpointDistanceMm)) {
    const Eigen::Vector3d& v = viewpoint_in_screen;
    throw Error(where,
                fmt::format("viewpoint ({:g}, {:g}, {:g}) mm is {:.3g} mm from the screen centre, beyond 1 km "
                            "(1e6 mm), where this {:.0f} mm wide screen spans {:.2g} deg",
                            v.x(), v.y(), v.z(), distance_mm, m.width_mm,
                            2 * std::atan(0.5 * m.width_mm / distance_mm) * kDegPerRad),
                "give a viewpoint within 1 km of the screen (a camera typically stands 300-3000 mm away)");
  }
  // Below a micrometre the viewpoint is on the surface up to rounding.
  constexpr double kMinClearanceMm = 1e-3;
  const double clearance = FrontClearanceMm(m, viewpoint_in_screen);
  if (!(clearance > kMinClearanceMm)) {
    const Eigen::Vector3d& v = viewpoint_in_screen;
    throw Error(where,
                fmt::format("viewpoint ({:g}, {:g}, {:g}) mm is on or behind the screen surface (part of the "
                            "display faces away from it by {:.3g} mm)",
                            v.x(), v.y(), v.z(), -clearance),
                m.is_flat() ? "put it in front of the screen: z > 0 (screen frame: the screen is the plane z = 0)"
                            : fmt::format("put it in front of the screen: the screen centre is at z = {:g}, the "
                                          "cylinder axis at z = 0",
                                          -m.radius_mm()));
  }
}

}  // namespace curvecheck
