// `curvecheck export-mpcdi` (mpcdi_export.h): the correction of a result.json or a monitor as an MPCDI file.
#include "analysis/mpcdi_export.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <ostream>
#include <string>

#include "analysis/result_reader.h"
#include "core/config.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/output_paths.h"
#include "core/screen_geometry.h"
#include "core/viewing.h"
#include "datasets/monitor_presets.h"
#include "mpcdi/mpcdi_file.h"
#include "mpcdi/warp_grid.h"

namespace curvecheck {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

// What the warp is computed for: the nominal monitor (the frame --viewpoint is given in), the corrected one (the
// measured or given radius) and the deviation field, if any.
struct Correction {
  Monitor nominal, corrected;
  std::optional<DeviationMap> deviation;
  std::string source;  // for the summary and the XML comment
};

std::string Text(const json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

// The monitor and the correction of a result.json (analysis/result_reader.h checked the types). Refuses a fit
// that gives no radius to correct for, with the fit's own reason.
Correction FromResult(const fs::path& path, std::ostream& log) {
  const json r = ReadResultJson(path);
  const std::string where = path.string();
  const json& mj = r["inputs"]["monitor"];
  const json& fit = r["fit"];
  const std::string fix = "export the nominal correction with --monitor M [--radius-mm R], or measure again (README "
                          "\"Analyze\")";
  if (fit["model"].is_null()) {
    throw Error(where, fmt::format("the analysis has no fit: {}", Text(fit, "failure")), fix);
  }
  const std::string model = fit["model"].get<std::string>();
  const std::string status = Text(fit, "status");
  if (status == "inadequate") {
    throw Error(where,
                fmt::format("the chosen model ({}) does not fit the photos to their noise (fit.status inadequate), "
                            "so its radius is not a measurement{}",
                            model, Text(fit, "adequacy_note").empty() ? "" : ": " + Text(fit, "adequacy_note")),
                fix);
  }
  if (status == "ill_conditioned") {
    throw Error(where,
                fmt::format("the photos do not determine the radius (fit.status ill_conditioned){}",
                            Text(fit, "condition_note").empty() ? "" : ": " + Text(fit, "condition_note")),
                fix);
  }
  if (model == "flat") {
    throw Error(where, "the chosen model is flat: the fit has no radius to correct for", fix);
  }
  if (!fit.contains("radius_mm") || !fit["radius_mm"].is_number()) {
    // The fit's own reason: its condition note, else its warnings, else the radius status.
    std::string reason = Text(fit, "condition_note");
    if (reason.empty() && fit.contains("warnings") && fit["warnings"].is_array()) {
      for (const json& w : fit["warnings"]) {
        if (w.is_string()) reason += (reason.empty() ? "" : "; ") + w.get<std::string>();
      }
    }
    if (reason.empty()) reason = "radius_status " + (Text(fit, "radius_status").empty() ? "?" : Text(fit, "radius_status"));
    if (fit.contains("radius_lower_bound_mm") && fit["radius_lower_bound_mm"].is_number()) {
      reason += fmt::format(" (the radius is only bounded below, by {:.0f} mm)", fit["radius_lower_bound_mm"].get<double>());
    }
    throw Error(where, fmt::format("the fit of model {} has no radius: {}", model, reason), fix);
  }
  const double radius = fit["radius_mm"].get<double>();
  Correction c;
  const std::string name = Text(mj, "name");
  const double nominal_radius = mj["radius_mm"].is_number() ? mj["radius_mm"].get<double>() : 0;
  c.nominal = MonitorFromActiveArea(name, mj["resolution"][0].get<int>(), mj["resolution"][1].get<int>(),
                                    mj["width_mm"].get<double>(), mj["height_mm"].get<double>(), nominal_radius);
  c.corrected = MonitorFromActiveArea(name, c.nominal.width_px, c.nominal.height_px, c.nominal.width_mm,
                                      c.nominal.height_mm, radius);
  c.corrected.Check(where + ": fit.radius_mm");
  const std::string sigma =
      fit.contains("radius_sigma_mm") && fit["radius_sigma_mm"].is_number()
          ? fmt::format(" +- {:.1f} mm (1 sigma)", fit["radius_sigma_mm"].get<double>())
          : std::string();
  c.source = fmt::format("{}: model {}, radius {:.1f} mm{}", path.filename().string(), model, radius, sigma);
  if (model == "cylinder+deviation") {
    const auto d = r.find("deviations");
    if (d == r.end() || !d->contains("map")) {
      throw Error(where, "model cylinder+deviation was chosen but the file has no deviations.map",
                  "run analyze again to write it");
    }
    const json& map = (*d)["map"];
    DeviationMap dev;
    dev.nu = map["nu"].get<int>();
    dev.nv = map["nv"].get<int>();
    int unsupported = 0;
    for (const json& v : map["mm"]) {
      dev.mm.push_back(v.is_number() ? v.get<double>() : 0.0);
      unsupported += v.is_number() ? 0 : 1;
    }
    dev.Check((where + ": deviations.map").c_str());
    c.deviation = dev;
    c.source += fmt::format(", deviation field {} x {} cells", dev.nu, dev.nv);
    if (unsupported > 0) {
      log << fmt::format("note: {} of {} cells of the deviation map have no feature near them; the export takes "
                               "0 mm there\n",
                               unsupported, dev.mm.size());
    }
  } else if (model != "cylinder") {
    // The other shapes (lean, curvature varying across the width) are exported by their radius alone.
    std::string terms;
    if (fit.contains("extra") && fit["extra"].is_object()) {
      for (const auto& [k, v] : fit["extra"].items()) {
        if (v.contains("value") && v["value"].is_number()) terms += fmt::format(" {} = {:.4g};", k, v["value"].get<double>());
      }
    }
    log << fmt::format("warning: the chosen model is {}; the MPCDI warp corrects for its radius only (a "
                             "cylinder), not its other terms:{}\n",
                             model, terms.empty() ? " (none listed)" : terms);
  }
  return c;
}

std::pair<int, int> ParseGrid(const std::string& text) {
  const std::vector<double> v = ParseNumberList(text, 2, "--grid");
  for (double x : v) {
    if (x != std::floor(x) || x < 2 || x > 8192) {
      throw Error("--grid", fmt::format("'{}' is not two whole numbers of samples from 2 to 8192", text),
                  "write e.g. --grid 321,91 (samples across, down)");
    }
  }
  return {static_cast<int>(v[0]), static_cast<int>(v[1])};
}

}  // namespace

void ExportMpcdi(const MpcdiExportRequest& a, std::ostream& log) {
  const fs::path out = a.output;
  if (out.extension() != ".mpcdi") {
    throw Error("-o", fmt::format("'{}' does not end in .mpcdi", a.output), "write e.g. -o warp.mpcdi");
  }
  std::vector<fs::path> inputs;
  if (a.result) inputs.emplace_back(*a.result);
  if (a.monitor) inputs.emplace_back(*a.monitor);
  CheckOutputs({{"-o", out}}, inputs);
  CheckWritable(out);

  Correction c;
  if (a.result) {
    c = FromResult(*a.result, log);
  } else {
    c.nominal = LoadMonitor(*a.monitor);
    c.corrected = c.nominal;
    if (a.radius_mm) {
      if (!std::isfinite(*a.radius_mm) || *a.radius_mm <= 0) {
        throw Error("--radius-mm", fmt::format("{} is not a positive radius", *a.radius_mm),
                    "give the radius in mm, e.g. --radius-mm 1000");
      }
      c.corrected = MonitorFromActiveArea(c.nominal.name, c.nominal.width_px, c.nominal.height_px, c.nominal.width_mm,
                                          c.nominal.height_mm, *a.radius_mm);
      c.corrected.Check("--radius-mm");
    }
    c.source = fmt::format("monitor {}, radius {}", c.nominal.name, DescribeRadius(c.corrected));
  }
  // The viewpoint is given in the nominal monitor's screen frame (as for render); what stays put when the radius
  // changes is its position relative to the screen centre, so it moves with the centre into the corrected frame.
  const std::optional<Eigen::Vector3d> given =
      ViewpointFromOptions(c.nominal, a.viewpoint, a.distance_mm, a.offset_mm);
  if (!given) throw Error("--viewpoint", "no viewpoint given", "give --viewpoint x,y,z or --distance-mm D");
  const Eigen::Vector3d viewpoint = ScreenCentreInScreen(c.corrected) + (*given - ScreenCentreInScreen(c.nominal));
  CheckViewpoint(c.corrected, viewpoint, a.distance_mm ? "--distance-mm" : "--viewpoint");

  const auto [cols, rows] = a.grid ? ParseGrid(*a.grid) : DefaultWarpGridSize(c.corrected);
  const DeviationMap* deviation = c.deviation ? &*c.deviation : nullptr;
  const WarpGrid grid = MakeWarpGrid(c.corrected, viewpoint, deviation, cols, rows);
  // Every second pixel in x and y: the error is smooth within a grid cell, and its maximum at the display's edges
  // is sampled (the README's figure is over every pixel).
  const WarpInterpolationError err = MeasureWarpInterpolation(c.corrected, viewpoint, deviation, grid, 2);
  MpcdiWriteOptions options;
  options.comment = fmt::format(
      "curvecheck export-mpcdi: {}; {}; grid {} x {} samples edge to edge, linear; interpolation error max {:.4f} "
      "display px. Conventions: README, section MPCDI export (PFM rows bottom to top, R = u, G = v with v = 0 at the "
      "bottom of the source image, B = 0; the source image is what curvecheck render draws with method none)",
      c.source, DescribeViewpoint(c.corrected, viewpoint), cols, rows, err.max_px);
  WriteMpcdi(out, grid, options);
  const std::vector<uint8_t> alpha = AlphaFromWarp(grid);
  size_t shown = 0;
  for (uint8_t v : alpha) shown += v ? 1 : 0;
  log << fmt::format(
      "{}\n{}\ngrid {} x {} samples (display edge to edge, linear): interpolation error max {:.4f} display px, rms "
      "{:.4f} (every 2nd pixel)\nalpha map: the source image covers {:.2f}% of the display\nwrote {}\n",
      c.source, DescribeViewpoint(c.corrected, viewpoint), cols, rows, err.max_px, err.rms_px,
      100.0 * static_cast<double>(shown) / static_cast<double>(alpha.size()), out.string());
}

}  // namespace curvecheck
