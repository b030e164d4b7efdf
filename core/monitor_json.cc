#include "core/monitor_json.h"

#include "core/math_util.h"

namespace curvecheck {

nlohmann::json MonitorToJson(const Monitor& m) {
  nlohmann::json j;
  j["name"] = m.name;
  j["resolution"] = {m.width_px, m.height_px};
  j["width_mm"] = m.width_mm;
  j["height_mm"] = m.height_mm;
  if (m.is_flat()) {
    j["radius_mm"] = "flat";
  } else {
    j["radius_mm"] = m.radius_mm();
  }
  j["pixel_pitch_mm"] = m.pixel_pitch_mm();
  j["half_sector_deg"] = m.half_sector_rad() * kDegPerRad;
  j["chord_width_mm"] = m.chord_width_mm();
  j["sagitta_mm"] = m.sagitta_mm();
  return j;
}

}  // namespace curvecheck
