#include <fmt/format.h>

#include <Eigen/Core>
#include <iostream>
#include <nlohmann/json.hpp>

#include "app/commands.h"
#include "app/render_options.h"
#include "core/config.h"
#include "core/math_util.h"
#include "core/monitor_json.h"
#include "core/screen_geometry.h"
#include "core/viewing.h"
#include "datasets/monitor_presets.h"

namespace curvecheck::app {

int RunInfo(const InfoOptions& o) {
  if (o.list_presets) {
    for (const std::string& name : MonitorPresetNames()) {
      const Monitor m = LoadMonitor(name);
      std::cout << fmt::format("{:<24} {}{}\n", name, m.name, name == kDefaultMonitorPreset ? "  (default)" : "");
    }
    return 0;
  }
  const Monitor m = LoadMonitor(o.monitor);
  std::optional<Eigen::Vector3d> viewpoint;
  std::optional<ViewingGeometry> view;
  viewpoint = ViewpointFromOptions(m, o.viewpoint.value_or(""), o.distance_mm, o.offset_mm);
  if (viewpoint) view = DescribeViewing(m, *viewpoint);

  if (o.json) {
    nlohmann::json j;
    j["format"] = "curvecheck.info/1";
    j["monitor"] = MonitorToJson(m);
    if (view) {
      j["viewpoint_mm"] = {viewpoint->x(), viewpoint->y(), viewpoint->z()};
      j["viewing"] = {{"distance_to_centre_mm", view->distance_to_centre_mm},
                      {"front_clearance_mm", view->front_clearance_mm},
                      {"horizontal_fov_deg", view->horizontal_fov_deg},
                      {"vertical_fov_deg", view->vertical_fov_deg},
                      {"pixels_per_degree_horizontal", view->pixels_per_degree_horizontal},
                      {"pixels_per_degree_vertical", view->pixels_per_degree_vertical}};
    }
    std::cout << j.dump(2) << "\n";
    return 0;
  }

  const double theta_deg = m.half_sector_rad() * kDegPerRad;
  std::cout << fmt::format("monitor         {}\n", m.name)
            << fmt::format("resolution      {} x {} px\n", m.width_px, m.height_px)
            << fmt::format("active area     {:.2f} mm wide (along the surface) x {:.2f} mm high\n", m.width_mm,
                           m.height_mm)
            << fmt::format("radius          {}\n", DescribeRadius(m))
            << fmt::format("pixel pitch     {:.4f} mm ({:.1f} px/inch)\n", m.pixel_pitch_mm(),
                           25.4 / m.pixel_pitch_mm());
  if (!m.is_flat()) {
    std::cout << fmt::format("sector          {:.2f} deg (half sector theta = {:.3f} deg)\n", 2 * theta_deg,
                             theta_deg)
              << fmt::format("chord width     {:.2f} mm between the edges; the edges stand {:.2f} mm in front of "
                             "the centre\n",
                             m.chord_width_mm(), m.sagitta_mm());
  }
  if (!view) {
    std::cout << "viewpoint       not given (--distance-mm D from the screen centre, or --viewpoint x,y,z in mm, "
                 "screen frame) -> no field of view\n";
    return 0;
  }
  const Eigen::Vector3d rel = *viewpoint - ScreenCentreInScreen(m);
  std::cout << fmt::format("viewpoint       ({:g}, {:g}, {:g}) mm; {:.1f} mm from the screen centre "
                           "(offset {:g}, {:g}, {:g} mm)\n",
                           viewpoint->x(), viewpoint->y(), viewpoint->z(), view->distance_to_centre_mm, rel.x(),
                           rel.y(), rel.z())
            << fmt::format("field of view   {:.2f} deg horizontal, {:.2f} deg vertical (centre column)\n",
                           view->horizontal_fov_deg, view->vertical_fov_deg)
            << fmt::format("at the centre   {:.2f} px/deg horizontal, {:.2f} px/deg vertical\n",
                           view->pixels_per_degree_horizontal, view->pixels_per_degree_vertical);
  return 0;
}

}  // namespace curvecheck::app
