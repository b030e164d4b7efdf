// `curvecheck calibrate --from-screen` (calibrate_run.h): the lens from photos of the monitor itself.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <ostream>
#include <tuple>

#include "calibrate/calibrate_run.h"
#include "calibrate/from_screen.h"
#include "capture/exif.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/output_paths.h"
#include "core/stopwatch.h"
#include "datasets/monitor_presets.h"
#include "pattern/pattern_json.h"

namespace curvecheck {
namespace fs = std::filesystem;

namespace {

// The focal length seed: --focal-px, else the first photo's EXIF 35 mm equivalent focal length.
std::pair<double, std::string> FocalSeed(const CalibrateRequest& a, int width, int height) {
  if (a.focal_px > 0) return {a.focal_px, "--focal-px"};
  for (const std::string& p : a.photos) {
    const std::optional<double> f = FocalSeedFromExif(ReadExif(ReadFileToString(p)), width, height);
    if (f) return {*f, fmt::format("EXIF 35 mm equivalent focal length of {}", p)};
  }
  return {0, ""};  // none: CalibrateFromScreen tries seeds (from_screen.h FromScreenOptions::focal_px)
}

}  // namespace

void RunScreenCalibration(const CalibrateRequest& a, std::ostream& out_text) {
  const CalibrationFiles files = CalibrationOutputs(a.output);
  if (a.pattern.empty()) {
    throw Error("--pattern", "--from-screen needs the pattern.json shown", "give --pattern p.json");
  }
  if (!a.board.empty() || !a.board_from.empty()) {
    throw Error("--from-screen", "the target is the monitor's pattern, not a board", "drop --board/--board-from");
  }
  const std::vector<fs::path> photos = CheckCalibrationFiles(a.photos, files, a.pattern, false);
  const fs::path& out = files.model;
  const fs::path& report_path = files.report;
  const fs::path& cov_path = files.covariance;
  const PatternFile pattern = ReadPatternJson(a.pattern);
  // The monitor's preset gives its physical size (the pitch fixes the scale); the pattern must be for it.
  const Monitor monitor = a.monitor.empty() ? pattern.monitor : LoadMonitor(a.monitor);
  if (monitor.width_px != pattern.monitor.width_px || monitor.height_px != pattern.monitor.height_px ||
      std::abs(monitor.width_mm - pattern.monitor.width_mm) > 0.01 * monitor.width_mm ||
      std::abs(monitor.curvature_per_mm - pattern.monitor.curvature_per_mm) > 1e-9) {
    throw Error(a.pattern, fmt::format("is for {}, not for --monitor {}", pattern.monitor.name, monitor.name),
                "give the pattern.json rendered for this monitor");
  }
  DetectOptions d;
  d.Check("detection options");
  const Stopwatch watch;
  int width = 0, height = 0;
  const std::vector<PhotoObservations> obs = ObserveScreenPhotos(photos, pattern, d, &width, &height);
  const double detect_s = watch.Seconds();
  FromScreenOptions o;
  if (a.lensmodel != "auto") o.lensmodels = {a.lensmodel};
  std::tie(o.focal_px, std::ignore) = FocalSeed(a, width, height);
  o.min_photos = a.min_photos;
  if (a.max_projection_sigma >= 0) {
    o.max_projection_sigma_px = a.max_projection_sigma;
  } else {
    o.refuse_imprecise = false;
  }
  const Stopwatch fit_watch;
  FromScreenResult r = CalibrateFromScreen(obs, monitor, width, height, o);
  if (o.focal_px > 0) r.focal_seed_source = FocalSeed(a, width, height).second;
  const double fit_s = fit_watch.Seconds();
  out_text << FromScreenSummary(r);
  out_text << fmt::format("detection {:.2f} s, fit {:.2f} s wall\n", detect_s, fit_s);
  nlohmann::json report = FromScreenJson(r);
  report["model"] = out.filename().string();
  report["detect_s"] = detect_s;
  report["fit_s"] = fit_s;
  OutputSet set;
  set.WriteWith(out, [&](const fs::path& staged) { WriteCameraModel(staged, r.model); });
  set.Write(report_path, report.dump(1) + "\n");
  set.Write(cov_path, FromScreenCovarianceJson(r, out.filename().string()).dump(1) + "\n");
  set.Publish();
  out_text << fmt::format("wrote {}, {} and {}\n", out.string(), report_path.string(), cov_path.string());
}

}  // namespace curvecheck
