#include "core/monitor.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "core/config.h"
#include "core/error.h"
#include "core/math_util.h"

namespace curvecheck {
namespace {

constexpr double kMmPerInch = 25.4;
constexpr double kMaxRadiusMm = 1e7;  // 10 km: anything flatter is 'flat' for every purpose of the rig

double CurvatureFromRadius(double radius_mm) {
  return (radius_mm <= 0 || std::isinf(radius_mm)) ? 0.0 : 1.0 / radius_mm;
}

}  // namespace

double Monitor::radius_mm() const {
  return is_flat() ? std::numeric_limits<double>::infinity() : 1.0 / curvature_per_mm;
}

double Monitor::chord_width_mm() const { return width_mm * Sinc(half_sector_rad()); }

double Monitor::sagitta_mm() const {
  // R (1 - cos theta) = 2 R sin^2(theta/2) = (W/2) (theta/2) sinc^2(theta/2): exact as kappa -> 0.
  const double t = half_sector_rad();
  return 0.5 * width_mm * 0.5 * t * Sinc(0.5 * t) * Sinc(0.5 * t);
}

void Monitor::Check(const std::string& where) const {
  if (width_px < 1 || height_px < 1) {
    throw Error(where, fmt::format("resolution {}x{} is not positive", width_px, height_px), "give Nx, Ny >= 1");
  }
  if (!(std::isfinite(width_mm) && width_mm > 0 && std::isfinite(height_mm) && height_mm > 0)) {
    throw Error(where, fmt::format("active area {} x {} mm is not a positive finite size", width_mm, height_mm),
                "give positive sizes in mm");
  }
  const double pitch_x = width_mm / width_px, pitch_y = height_mm / height_px;
  if (std::abs(pitch_x / pitch_y - 1) > 0.02) {
    throw Error(where,
                fmt::format("pixels are not square: {:.4f} mm wide but {:.4f} mm high ({} x {} mm for {} x {} px)",
                            pitch_x, pitch_y, width_mm, height_mm, width_px, height_px),
                "check the active area against the resolution");
  }
  if (!std::isfinite(curvature_per_mm) || curvature_per_mm < 0) {
    throw Error(where, fmt::format("curvature {} 1/mm is not valid", curvature_per_mm),
                "give a positive radius or 'flat'");
  }
  if (half_sector_rad() >= std::numbers::pi) {
    throw Error(where,
                fmt::format("radius {:.1f} mm is too small: a {:.1f} mm wide screen would wrap more than 360 deg",
                            radius_mm(), width_mm),
                fmt::format("give a radius above {:.1f} mm", width_mm / (2 * std::numbers::pi)));
  }
}

Monitor MonitorFromDiagonal(std::string name, int width_px, int height_px, double diagonal_in, double radius_mm) {
  Monitor m;
  m.name = std::move(name);
  m.width_px = width_px;
  m.height_px = height_px;
  const double aspect = static_cast<double>(width_px) / height_px;
  const double d = diagonal_in * kMmPerInch;
  m.height_mm = d / std::sqrt(1 + aspect * aspect);
  m.width_mm = m.height_mm * aspect;
  m.curvature_per_mm = CurvatureFromRadius(radius_mm);
  return m;
}

Monitor MonitorFromActiveArea(std::string name, int width_px, int height_px, double width_mm, double height_mm,
                              double radius_mm) {
  Monitor m;
  m.name = std::move(name);
  m.width_px = width_px;
  m.height_px = height_px;
  m.width_mm = width_mm;
  m.height_mm = height_mm;
  m.curvature_per_mm = CurvatureFromRadius(radius_mm);
  return m;
}

Monitor MonitorFromConfig(const ConfigMap& c) {
  c.RejectUnknownKeys({"format", "name", "resolution", "diagonal_in", "active_area_mm", "radius_mm"});
  if (c.Has("format") && c.String("format") != "curvecheck.monitor/1") {
    c.Fail("format", "is '" + c.String("format") + "', not 'curvecheck.monitor/1'",
           "this version reads curvecheck.monitor/1");
  }
  const std::string name = c.Has("name") ? c.String("name") : c.source();
  const std::vector<int> res = c.PositiveInts("resolution", 2);
  const bool has_diag = c.Has("diagonal_in"), has_area = c.Has("active_area_mm");
  if (has_diag == has_area) {
    c.Fail(has_diag ? "active_area_mm" : "diagonal_in",
           has_diag ? "is given together with diagonal_in" : "is missing (and so is active_area_mm)",
           "give exactly one of diagonal_in (inches) and active_area_mm ([width, height] in mm)");
  }
  if (!c.Has("radius_mm")) c.Fail("radius_mm", "is missing", "give the nominal radius in mm (1000 for 1000R) or 'flat'");
  double radius = 0;  // 0 = flat
  if (!c.IsWord("radius_mm", "flat")) {
    radius = c.PositiveNumber("radius_mm");
    if (radius > kMaxRadiusMm) {
      c.Fail("radius_mm", fmt::format("is {} mm, which is flat for every purpose", radius), "write radius_mm: flat");
    }
  }
  Monitor m;
  if (has_diag) {
    m = MonitorFromDiagonal(name, res[0], res[1], c.PositiveNumber("diagonal_in"), radius);
  } else {
    const std::vector<double> area = c.Numbers("active_area_mm", 2);
    if (!(area[0] > 0 && area[1] > 0)) {
      c.Fail("active_area_mm", fmt::format("is [{}, {}], sizes must be greater than zero", area[0], area[1]),
             "give [width, height] in mm");
    }
    m = MonitorFromActiveArea(name, res[0], res[1], area[0], area[1], radius);
  }
  m.Check(c.source());
  return m;
}

std::string DescribeRadius(const Monitor& m) {
  if (m.is_flat()) return "flat";
  return fmt::format("{:.6g} mm ({:.0f}R)", m.radius_mm(), m.radius_mm());
}

}  // namespace curvecheck
