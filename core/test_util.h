// Shared gtest helpers for Eigen values (tests only).
#pragma once

#include <gmock/gmock.h>

#include <Eigen/Core>
#include <functional>
#include <sstream>
#include <string>

#include "core/error.h"
#include "core/pose.h"

namespace curvecheck::testing {

// The message of the curvecheck::Error that f throws, or "(no error)".
inline std::string MessageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// Matches an Eigen vector or matrix whose largest absolute element difference from `expected` is <= tol.
// A NaN or an infinity in either argument never matches, not even the same value in both: a non-finite number
// is not near anything (a NaN difference compares false with every tolerance, and Eigen's maxCoeff over NaNs
// is unspecified, so without this check a NaN result passed). Test non-finite values explicitly.
MATCHER_P2(EigenNear, expected, tol, "") {
  if (arg.rows() != expected.rows() || arg.cols() != expected.cols()) {
    *result_listener << "size " << arg.rows() << " x " << arg.cols() << ", expected " << expected.rows() << " x "
                     << expected.cols();
    return false;
  }
  if (!arg.allFinite() || !expected.allFinite()) {
    std::ostringstream s;
    s << "not finite: value " << arg.transpose() << ", expected " << expected.transpose();
    *result_listener << s.str();
    return false;
  }
  if (arg.size() == 0) return true;  // two empty matrices of one shape (maxCoeff needs an element)
  const double err = (arg - expected).cwiseAbs().maxCoeff();
  if (!(err <= tol)) {
    std::ostringstream s;
    s << "max abs difference " << err << " > " << tol << "; expected " << expected.transpose();
    *result_listener << s.str();
    return false;
  }
  return true;
}

// Matches a Pose whose rotation is within rot_tol_rad (angle of the relative rotation) and whose translation is
// within trans_tol_mm (largest component) of `expected`.
MATCHER_P3(PoseNear, expected, rot_tol_rad, trans_tol_mm, "") {
  const double rot = RotationDistanceRad(arg, expected);
  const double trans = (arg.translation - expected.translation).cwiseAbs().maxCoeff();
  if (rot > rot_tol_rad || trans > trans_tol_mm) {
    std::ostringstream s;
    s << "rotation off by " << rot << " rad (tol " << rot_tol_rad << "), translation by " << trans << " mm (tol "
      << trans_tol_mm << "); translation " << arg.translation.transpose() << " expected "
      << expected.translation.transpose();
    *result_listener << s.str();
    return false;
  }
  return true;
}

}  // namespace curvecheck::testing

#include <random>

#include "core/monitor.h"
#include "core/screen_geometry.h"

namespace curvecheck::testing {

// Random valid viewpoints (every display point faces them), in the screen frame.
// Inside the cylinder: anywhere in front of the screen up to the far side of the circle.
// Outside: in front of the circle (farther than 2R from the screen centre), off to the sides and above.
// For a flat monitor "inside" means within 1.5 m, "outside" farther.
inline Eigen::Vector3d RandomViewpoint(const Monitor& m, bool inside, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double r = m.is_flat() ? 1500 : m.radius_mm();
  for (;;) {
    const double x = (unit(rng) - 0.5) * (inside ? 1.6 * r : 3 * r);
    const double y = (unit(rng) - 0.5) * 3 * m.height_mm;
    const double z_rel = inside ? unit(rng) * 2 * r : (2 + 2 * unit(rng)) * r;  // in front of the centre
    const Eigen::Vector3d p = ScreenCentreInScreen(m) + Eigen::Vector3d(x, y, z_rel);
    const Eigen::Vector3d rel(x, y, z_rel);
    const bool in_cyl = m.is_flat() ? z_rel < 1500 : (x * x + (z_rel - r) * (z_rel - r) < r * r);
    if (in_cyl == inside && FrontClearanceMm(m, p) > 20 && rel.norm() > 100) return p;
  }
}

}  // namespace curvecheck::testing
