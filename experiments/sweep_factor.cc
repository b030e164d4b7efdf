#include "experiments/sweep_factor.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "core/error.h"
#include "core/screen_geometry.h"

namespace curvecheck::experiments {
namespace {

// Geometry factors move the camera around the screen centre (it keeps looking at it); the pattern is rendered
// for the camera's position unless viewpoint_offset_mm separates the two.
const std::vector<FactorInfo> kFactors = {
    {"yaw_deg", "yaw", -85, 85,
     "camera moved horizontally around the screen centre at the same distance (positive: to the right), "
     "looking "
     "at the centre",
     [](double v, SweepPoint& p) { p.yaw_deg = v, p.camera_moved = true; }},
    {"pitch_deg", "pitch", -85, 85, "camera moved vertically around the screen centre (positive: up)",
     [](double v, SweepPoint& p) { p.pitch_deg = v, p.camera_moved = true; }},
    {"distance_mm", "distance", 100, 100000, "camera distance from the screen centre",
     [](double v, SweepPoint& p) {
       p.offset_from_centre_mm = p.offset_from_centre_mm.normalized() * v;
       p.camera_moved = true;
     }},
    {"defocus_px", "defocus", 0, 50, "Gaussian PSF sigma in px of the (scaled) camera; 0 = sharp",
     [](double v, SweepPoint& p) {
       p.scene.optics.blur = v > 0 ? Blur::kGaussian : Blur::kNone;
       p.scene.optics.blur_px = v;
     }},
    {"noise_x", "noise", 0, 1000,
     "sensor noise multiplier: shot and read noise relative to the signal times x (full well / x^2, read "
     "noise / "
     "x); 0 = noiseless",
     [](double v, SweepPoint& p) {
       if (v == 0) {
         p.scene.sensor.noise = false;
       } else {
         p.scene.sensor.full_well_e /= v * v;
         p.scene.sensor.read_noise_e /= v;
       }
     }},
    {"exposure", "exposure", 0.001, 100, "scene radiance multiplier (optics.exposure)",
     [](double v, SweepPoint& p) { p.scene.optics.exposure = v; }},
    {"fill_factor", "fill", 0.05, 1, "emitting fraction of a display pixel along each axis (moire)",
     [](double v, SweepPoint& p) { p.scene.display.fill_factor = v; }},
    {"square_px", "square", 8, 2000,
     "checkerboard square edge, display px at the screen centre; the board spans about 90% of the display",
     [](double v, SweepPoint& p) {
       const Monitor& m = p.scene.monitor;
       p.spec.square_mm = v * m.pixel_pitch_mm();
       p.spec.cols = std::max(2, static_cast<int>(std::floor(0.9 * m.width_px / v)));
       p.spec.rows = std::max(2, static_cast<int>(std::floor(0.9 * m.height_px / v)));
     }},
    {"coverage", "coverage", 0.15, 1, "fraction of the display's width and height the fitted board may span",
     [](double v, SweepPoint& p) { p.spec.margin = 0.5 * (1 - v); }},
    {"radius_ratio", "radius", 0.2, 5,
     "true radius / nominal: rendered for the nominal, photographed with the true",
     [](double v, SweepPoint& p) { p.scene.truth.curvature_per_mm = p.scene.monitor.curvature_per_mm / v; }},
    {"viewpoint_offset_mm", "viewpoint_offset", -3000, 3000,
     "camera moved sideways (x) from the viewpoint the pattern was rendered for, still looking at the centre",
     [](double v, SweepPoint& p) { p.sideways_mm = v, p.camera_moved = true; }},
};

double ParseNumber(const std::string& text, const std::string& what) {
  size_t used = 0;
  double v = std::numeric_limits<double>::quiet_NaN();
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v)) {
    throw Error("--factor", fmt::format("{} '{}' is not a finite number", what, text),
                "write NAME=start:stop:count");
  }
  return v;
}

}  // namespace

const std::vector<FactorInfo>& SweepFactors() { return kFactors; }

const FactorInfo& FindFactor(const std::string& name) {
  for (const FactorInfo& f : kFactors) {
    if (name == f.name || name == f.alias) return f;
  }
  std::string known;
  for (const FactorInfo& f : kFactors)
    known += fmt::format("{}{} ({})", known.empty() ? "" : ", ", f.name, f.alias);
  throw Error("--factor", fmt::format("'{}' is not a sweep factor", name), "give one of: " + known);
}

SweepFactor ParseFactor(const std::string& text) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos) {
    throw Error("--factor", fmt::format("'{}' has no '='", text),
                "write NAME=start:stop:count, e.g. yaw=0:40:5");
  }
  const FactorInfo& info = FindFactor(text.substr(0, eq));
  SweepFactor f;
  f.name = info.name;
  std::vector<std::string> parts;
  std::stringstream ss(text.substr(eq + 1));
  for (std::string p; std::getline(ss, p, ':');) parts.push_back(p);
  if (parts.size() == 1) {
    f.start = f.stop = ParseNumber(parts[0], "value");
  } else if (parts.size() == 3) {
    f.start = ParseNumber(parts[0], "start");
    f.stop = ParseNumber(parts[1], "stop");
    const double count = ParseNumber(parts[2], "count");
    if (!(count >= 1 && count <= 1000 && count == std::floor(count))) {
      throw Error("--factor",
                  fmt::format("{}: count {} is not a whole number from 1 to 1000", f.name, parts[2]), "");
    }
    f.count = static_cast<int>(count);
  } else {
    throw Error("--factor", fmt::format("'{}' is not start:stop:count", text), "write e.g. yaw=0:40:5");
  }
  for (double v : {f.start, f.stop}) {
    if (v < info.lo || v > info.hi) {
      throw Error("--factor", fmt::format("{} = {:g} is outside {:g}..{:g}", f.name, v, info.lo, info.hi),
                  fmt::format("sweep {} ({}) within that range", f.name, info.meaning));
    }
  }
  return f;
}

SweepPoint MakeSweepPoint(const SyntheticScene& base, const PatternSpec& spec,
                          const std::vector<SweepFactor>& factors, const std::vector<double>& values) {
  SweepPoint p;
  p.scene = base;
  p.spec = spec;
  const Eigen::Vector3d centre = ScreenCentreInScreen(base.monitor);
  p.offset_from_centre_mm = base.screen_from_cam.translation - centre;
  for (size_t f = 0; f < factors.size(); ++f) FindFactor(factors[f].name).apply(values.at(f), p);
  const Eigen::Vector3d offset =
      Eigen::AngleAxisd(p.yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()) *
      (Eigen::AngleAxisd(-p.pitch_deg * M_PI / 180, Eigen::Vector3d::UnitX()) * p.offset_from_centre_mm);
  p.viewpoint_in_screen = centre + offset;
  if (p.camera_moved) {
    p.scene.screen_from_cam.translation = p.viewpoint_in_screen + Eigen::Vector3d(p.sideways_mm, 0, 0);
    p.scene.screen_from_cam =
        ScreenFromCamLookAt(p.scene.screen_from_cam.translation, centre, Eigen::Vector3d::UnitY());
  }
  return p;
}

}  // namespace curvecheck::experiments
