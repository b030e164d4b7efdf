#include "core/viewing.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/config.h"
#include "core/error.h"
#include "core/flip.h"
#include "core/math_util.h"
#include "core/monitor_json.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {

double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));  // accurate for small and large angles alike
}

}  // namespace

ViewingGeometry DescribeViewing(const Monitor& m, const Eigen::Vector3d& o) {
  CheckViewpoint(m, o, "viewpoint");
  ViewingGeometry g;
  g.distance_to_centre_mm = (o - ScreenCentreInScreen(m)).norm();
  g.front_clearance_mm = FrontClearanceMm(m, o);

  // Horizontal: sum the signed azimuth steps along the centre line, so that sweeps beyond 180 deg
  // (viewpoints close inside a strongly curved screen) are measured without wrapping. Each step is far
  // below pi, so the sum equals the unwrapped difference of the end azimuths exactly.
  constexpr int kSteps = 2048;
  double sweep = 0;
  Eigen::Vector2d prev;
  for (int i = 0; i <= kSteps; ++i) {
    const Eigen::Vector3d d = SurfacePointFromUv(m, {-1.0 + 2.0 * i / kSteps, 0.0}) - o;
    const Eigen::Vector2d xz(d.x(), d.z());
    if (i > 0) sweep += std::atan2(prev.x() * xz.y() - prev.y() * xz.x(), prev.dot(xz));
    prev = xz;
  }
  g.horizontal_fov_deg = std::abs(sweep) * kDegPerRad;

  const Eigen::Vector3d top = SurfacePointFromUv(m, {0.0, -1.0}) - o;
  const Eigen::Vector3d bottom = SurfacePointFromUv(m, {0.0, 1.0}) - o;
  g.vertical_fov_deg = AngleBetween(top, bottom) * kDegPerRad;

  // One pixel centred on the screen centre: from u = -1/Nx to +1/Nx, v = -1/Ny to +1/Ny.
  const double du = 1.0 / m.width_px, dv = 1.0 / m.height_px;
  const double ax = AngleBetween(SurfacePointFromUv(m, {-du, 0.0}) - o, SurfacePointFromUv(m, {du, 0.0}) - o);
  const double ay = AngleBetween(SurfacePointFromUv(m, {0.0, -dv}) - o, SurfacePointFromUv(m, {0.0, dv}) - o);
  g.pixels_per_degree_horizontal = 1.0 / (ax * kDegPerRad);
  g.pixels_per_degree_vertical = 1.0 / (ay * kDegPerRad);
  return g;
}

double NearestSurfaceDistanceMm(const Monitor& m, const Eigen::Vector3d& o) {
  const double v = std::clamp(-2 * o.y() / m.height_mm, -1.0, 1.0);  // y = -v H/2 on the surface
  const double dy = -0.5 * v * m.height_mm - o.y();
  auto horizontal2 = [&](double u) {
    const Eigen::Vector3d p = SurfacePointFromUv(m, {u, 0.0});
    return (p.x() - o.x()) * (p.x() - o.x()) + (p.z() - o.z()) * (p.z() - o.z());
  };
  constexpr int kSteps = 4096;
  int best = 0;
  double best_d2 = horizontal2(-1.0);
  for (int i = 1; i <= kSteps; ++i) {
    const double d2 = horizontal2(-1.0 + 2.0 * i / kSteps);
    if (d2 < best_d2) best_d2 = d2, best = i;
  }
  double lo = -1.0 + 2.0 * std::max(best - 1, 0) / kSteps, hi = -1.0 + 2.0 * std::min(best + 1, kSteps) / kSteps;
  const double g = 0.5 * (std::sqrt(5.0) - 1);
  for (int it = 0; it < 60; ++it) {
    const double a = hi - g * (hi - lo), b = lo + g * (hi - lo);
    if (horizontal2(a) < horizontal2(b)) {
      hi = b;
    } else {
      lo = a;
    }
  }
  const double h2 = std::min(best_d2, horizontal2(0.5 * (lo + hi)));
  return std::sqrt(h2 + dy * dy);
}

double ViewerPixelsPerDegree(const Monitor& m, const Eigen::Vector3d& o) {
  CheckViewpoint(m, o, "viewpoint");
  return FlipPixelsPerDegree(NearestSurfaceDistanceMm(m, o), m.pixel_pitch_mm());
}

std::optional<Eigen::Vector3d> ViewpointFromOptions(const Monitor& monitor, const std::string& viewpoint,
                                                    const std::optional<double>& distance_mm,
                                                    const std::optional<std::string>& offset_mm) {
  std::optional<Eigen::Vector3d> v;
  std::string option = "--viewpoint";
  if (distance_mm) {
    option = "--distance-mm";
    if (!std::isfinite(*distance_mm) || *distance_mm <= 0) {
      throw Error("--distance-mm", fmt::format("{} is not a positive distance", *distance_mm),
                  "give the distance from the screen centre in mm, e.g. --distance-mm 600");
    }
    Eigen::Vector2d offset = Eigen::Vector2d::Zero();
    if (offset_mm) {
      const std::vector<double> o = ParseNumberList(*offset_mm, 2, "--offset-mm");
      offset = Eigen::Vector2d(o[0], o[1]);
    }
    v = ViewpointFromScreenCentre(monitor, *distance_mm, offset);
  } else if (!viewpoint.empty()) {
    const std::vector<double> p = ParseNumberList(viewpoint, 3, "--viewpoint");
    v = Eigen::Vector3d(p[0], p[1], p[2]);
  }
  if (v) CheckViewpoint(monitor, *v, option);
  return v;
}

std::string DescribeViewpoint(const Monitor& monitor, const Eigen::Vector3d& v) {
  return fmt::format("viewpoint ({:g}, {:g}, {:g}) mm (screen frame), {:.1f} mm from the screen centre", v.x(), v.y(),
                     v.z(), (v - ScreenCentreInScreen(monitor)).norm());
}

nlohmann::json MonitorInfoJson(const Monitor& m, const std::optional<Eigen::Vector3d>& viewpoint) {
  nlohmann::json j;
  j["format"] = "curvecheck.info/1";
  j["monitor"] = MonitorToJson(m);
  if (viewpoint) {
    const ViewingGeometry view = DescribeViewing(m, *viewpoint);
    j["viewpoint_mm"] = {viewpoint->x(), viewpoint->y(), viewpoint->z()};
    j["viewing"] = {{"distance_to_centre_mm", view.distance_to_centre_mm},
                    {"front_clearance_mm", view.front_clearance_mm},
                    {"horizontal_fov_deg", view.horizontal_fov_deg},
                    {"vertical_fov_deg", view.vertical_fov_deg},
                    {"pixels_per_degree_horizontal", view.pixels_per_degree_horizontal},
                    {"pixels_per_degree_vertical", view.pixels_per_degree_vertical}};
  }
  return j;
}

std::string MonitorInfoText(const Monitor& m, const std::optional<Eigen::Vector3d>& viewpoint) {
  const double theta_deg = m.half_sector_rad() * kDegPerRad;
  std::string s = fmt::format("monitor         {}\n", m.name) +
                  fmt::format("resolution      {} x {} px\n", m.width_px, m.height_px) +
                  fmt::format("active area     {:.2f} mm wide (along the surface) x {:.2f} mm high\n", m.width_mm,
                              m.height_mm) +
                  fmt::format("radius          {}\n", DescribeRadius(m)) +
                  fmt::format("pixel pitch     {:.4f} mm ({:.1f} px/inch)\n", m.pixel_pitch_mm(),
                              25.4 / m.pixel_pitch_mm());
  if (!m.is_flat()) {
    s += fmt::format("sector          {:.2f} deg (half sector theta = {:.3f} deg)\n", 2 * theta_deg, theta_deg) +
         fmt::format("chord width     {:.2f} mm between the edges; the edges stand {:.2f} mm in front of the centre\n",
                     m.chord_width_mm(), m.sagitta_mm());
  }
  if (!viewpoint) {
    return s + "viewpoint       not given (--distance-mm D from the screen centre, or --viewpoint x,y,z in mm, "
               "screen frame) -> no field of view\n";
  }
  const ViewingGeometry view = DescribeViewing(m, *viewpoint);
  const Eigen::Vector3d rel = *viewpoint - ScreenCentreInScreen(m);
  return s +
         fmt::format("viewpoint       ({:g}, {:g}, {:g}) mm; {:.1f} mm from the screen centre (offset {:g}, {:g}, "
                     "{:g} mm)\n",
                     viewpoint->x(), viewpoint->y(), viewpoint->z(), view.distance_to_centre_mm, rel.x(), rel.y(),
                     rel.z()) +
         fmt::format("field of view   {:.2f} deg horizontal, {:.2f} deg vertical (centre column)\n",
                     view.horizontal_fov_deg, view.vertical_fov_deg) +
         fmt::format("at the centre   {:.2f} px/deg horizontal, {:.2f} px/deg vertical\n",
                     view.pixels_per_degree_horizontal, view.pixels_per_degree_vertical);
}

}  // namespace curvecheck
