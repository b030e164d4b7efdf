// `curvecheck calibrate (--board NxM --square-mm S | --board-from pattern.json) photos... -o cam.cameramodel`:
// detects the board in every photo (in parallel), solves every candidate lens model with mrcal, chooses the
// simplest adequate one, prints the candidate table and writes the chosen model (a mrcal .cameramodel with its
// optimization inputs) and cam.calibration.json (the report: per-photo and per-corner residuals, outliers,
// every candidate's figures, the uncertainty grid). A photo whose decoded content repeats an earlier one's is
// used once (calibrate/photos.h): a note on stderr and in cam.calibration.json names both files.
// `curvecheck calibrate --from-screen --monitor M --pattern pattern.json photos... -o cam.cameramodel`: calibrates
// from photos of the monitor itself (calibrate/from_screen.h): the lens jointly with the poses and the screen's
// curvature; writes the model, cam.calibration.json (with `screen`) and the intrinsics covariance.
#include "app/calibrate_command.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "calibrate/calibrate.h"
#include "calibrate/from_screen.h"
#include "capture/exif.h"
#include "datasets/monitor_presets.h"
#include "pattern/pattern_json.h"
#include "app/output_paths.h"
#include "core/error.h"
#include "core/path_check.h"
#include "core/stopwatch.h"
#include "core/file_io.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct CalibrateArgs {
  std::string board, board_from, output, lensmodel = "auto", detector = "auto";
  double square_mm = 0, focal_px = 0, distance_mm = 1000;
  int splined_nx = 16, threads = 0, search_max_px = 1600;
  bool no_cross_validate = false;
  std::vector<std::string> photos;
  // --from-screen
  bool from_screen = false;
  std::string monitor, pattern;
  int min_photos = 6;
  double max_projection_sigma = FromScreenOptions{}.max_projection_sigma_px;
};

// The focal length seed: --focal-px, else the first photo's EXIF 35 mm equivalent focal length.
std::pair<double, std::string> FocalSeed(const CalibrateArgs& a, int width, int height) {
  if (a.focal_px > 0) return {a.focal_px, "--focal-px"};
  for (const std::string& p : a.photos) {
    const std::optional<double> f = FocalSeedFromExif(ReadExif(ReadFileToString(p)), width, height);
    if (f) return {*f, fmt::format("EXIF 35 mm equivalent focal length of {}", p)};
  }
  return {0, ""};  // none: CalibrateFromScreen tries seeds (from_screen.h FromScreenOptions::focal_px)
}

int RunCalibrateFromScreen(const CalibrateArgs& a) {
  const fs::path out = a.output;
  if (out.extension() != ".cameramodel") {
    throw Error("-o", fmt::format("'{}' does not end in .cameramodel", a.output), "write e.g. -o cam.cameramodel");
  }
  if (a.pattern.empty()) {
    throw Error("--pattern", "--from-screen needs the pattern.json shown", "give --pattern p.json");
  }
  if (!a.board.empty() || !a.board_from.empty()) {
    throw Error("--from-screen", "the target is the monitor's pattern, not a board", "drop --board/--board-from");
  }
  const fs::path report_path = fs::path(out).replace_extension(".calibration.json");
  fs::path cov_path = out;
  cov_path.replace_extension(".intrinsics_covariance.json");
  std::vector<fs::path> photos;
  std::error_code ec;
  for (const std::string& p : a.photos) {
    if (ClassifyPath(p) == PathKind::kLinkLoop) RequireFile(p);
    if (!fs::is_regular_file(p, ec)) throw Error(p, "is not a file", "give the photos' paths (shell globs work)");
    photos.emplace_back(p);
  }
  const std::vector<NamedOutput> outputs = {
      {"-o", out}, {"the report beside -o", report_path}, {"the covariance beside -o", cov_path}};
  std::vector<fs::path> inputs = photos;
  inputs.push_back(a.pattern);
  CheckOutputs(outputs, inputs);
  for (const NamedOutput& o : outputs) CheckWritable(o.path);
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
  o.max_projection_sigma_px = a.max_projection_sigma;
  const Stopwatch fit_watch;
  FromScreenResult r = CalibrateFromScreen(obs, monitor, width, height, o);
  if (o.focal_px > 0) r.focal_seed_source = FocalSeed(a, width, height).second;
  const double fit_s = fit_watch.Seconds();
  std::cout << FromScreenSummary(r);
  std::cout << fmt::format("detection {:.2f} s, fit {:.2f} s wall\n", detect_s, fit_s);
  nlohmann::json report = FromScreenJson(r);
  report["model"] = out.filename().string();
  report["detect_s"] = detect_s;
  report["fit_s"] = fit_s;
  OutputSet set;
  set.WriteWith(out, [&](const fs::path& staged) { WriteCameraModel(staged, r.model); });
  set.Write(report_path, report.dump(1) + "\n");
  set.Write(cov_path, FromScreenCovarianceJson(r, out.filename().string()).dump(1) + "\n");
  set.Publish();
  std::cout << fmt::format("wrote {}, {} and {}\n", out.string(), report_path.string(), cov_path.string());
  return 0;
}

int RunCalibrate(const CalibrateArgs& a) {
  if (a.from_screen) return RunCalibrateFromScreen(a);
  if (!a.monitor.empty() || !a.pattern.empty()) {
    throw Error(a.monitor.empty() ? "--pattern" : "--monitor", "is an option of --from-screen",
                "add --from-screen, or calibrate from a board with --board/--board-from");
  }
  const fs::path out = a.output;
  if (out.extension() != ".cameramodel") {
    throw Error("-o", fmt::format("'{}' does not end in .cameramodel", a.output), "write e.g. -o cam.cameramodel");
  }
  const fs::path report_path = fs::path(out).replace_extension(".calibration.json");
  if (a.board.empty() == a.board_from.empty()) {
    throw Error("--board", "give exactly one of --board NxM (with --square-mm) and --board-from pattern.json", "");
  }
  if (!a.board_from.empty() && a.square_mm != 0) {
    throw Error("--square-mm", "the square size comes from --board-from's pattern.json", "drop --square-mm");
  }
  std::vector<fs::path> photos;
  std::error_code ec;
  for (const std::string& p : a.photos) {
    if (ClassifyPath(p) == PathKind::kLinkLoop) RequireFile(p);  // "is a symbolic link loop; ..."
    if (!fs::is_regular_file(p, ec)) throw Error(p, "is not a file", "give the photos' paths (shell globs work)");
    if (fs::exists(out, ec) && fs::equivalent(p, out, ec)) throw Error(p, "is also the output", "choose another -o");
    photos.emplace_back(p);
  }
  // Every output against every input and writable before the work, which takes minutes on 30 large photos.
  fs::path cov_path = out;
  cov_path.replace_extension(".intrinsics_covariance.json");
  const std::vector<NamedOutput> outputs = {
      {"-o", out}, {"the report beside -o", report_path}, {"the covariance beside -o", cov_path}};
  std::vector<fs::path> inputs = photos;
  if (!a.board_from.empty()) inputs.push_back(a.board_from);
  CheckOutputs(outputs, inputs);
  for (const NamedOutput& o : outputs) CheckWritable(o.path);
  const BoardSpec board = a.board_from.empty() ? BoardFromText(a.board, a.square_mm) : BoardFromPatternJson(a.board_from);
  ChessboardOptions d;
  d.detector = ParseChessboardDetector(a.detector);
  d.threads = a.threads;
  d.search_max_px = a.search_max_px;
  CalibrateOptions c;
  if (a.lensmodel != "auto") c.lensmodels = {a.lensmodel};
  c.splined_nx = a.splined_nx;
  c.focal_px = a.focal_px;
  c.distance_mm = a.distance_mm;
  c.cross_validate = !a.no_cross_validate;
  c.Check();

  const Stopwatch watch;
  const CalibrationPhotos gathered = DetectCalibrationPhotos(photos, board, d);
  const double detect_s = watch.Seconds();
  int found = 0;
  for (size_t i = 0; i < gathered.detections.size(); ++i) {
    const ChessboardDetection& det = gathered.detections[i];
    found += det.found && gathered.duplicate_of[i] < 0 ? 1 : 0;
    if (!det.found) std::cout << fmt::format("{}: {}; not used\n", det.photo.string(), det.problem);
  }
  // Each photo content counts once (issue 15 item 4): the note names both files, here and in the report.
  for (const std::string& note : gathered.DuplicateNotes()) std::cerr << "calibrate: note: " << note << "\n";
  const int duplicates = gathered.Duplicates();
  std::cout << fmt::format("detection: board {}x{} ({} mm squares) in {} of {} photos{}, {:.2f} s wall\n",
                           board.corners_x, board.corners_y, board.square_mm, found, photos.size() - duplicates,
                           duplicates > 0 ? fmt::format(" ({} duplicate photo(s) left out)", duplicates) : "",
                           detect_s);
  const CalibrationResult r = Calibrate(gathered, board, c);
  std::cout << CandidateTable(r);
  const CandidateResult& ch = r.Chosen();
  std::cout << fmt::format(
      "optimization: {:.2f} s wall (all candidates{}); RMS {:.3f} px, {} outliers of {} corners\n"
      "projection uncertainty at {}: median {:.3f} px over the central half of the imager, median {:.3f} px and "
      "max {:.3f} px where the board was seen\n",
      r.optimize_s, c.cross_validate ? " and cross-validation" : "", ch.rms_px, ch.noutliers,
      ch.noutliers + ch.ninliers, c.distance_mm > 0 ? fmt::format("{} mm", c.distance_mm) : "infinity",
      ch.SigmaCentralMedian(r.width, r.height), ch.SigmaObservedMedian(), ch.SigmaObservedMax());
  nlohmann::json report = CalibrationJson(r);
  report["detect_s"] = detect_s;
  report["uncertainty"]["distance_mm"] = c.distance_mm > 0 ? nlohmann::json(c.distance_mm) : nlohmann::json("infinity");
  report["model"] = out.filename().string();
  // The model, its report and its covariance as one set (core/file_io.h OutputSet); a covariance left from an
  // earlier model goes with it.
  OutputSet set;
  set.Write(out, ch.model_text);
  set.Write(report_path, report.dump(1) + "\n");
  if (ch.intrinsics_covariance.size() > 0) {
    set.Write(cov_path, IntrinsicsCovarianceJson(ch, out.filename().string()).dump(1) + "\n");
  } else {
    set.RemoveOnPublish(cov_path);
  }
  set.Publish();
  std::cout << fmt::format("wrote {} and {}\n", out.string(), report_path.string());
  // The lens's own uncertainty, which `curvecheck analyze` propagates into the radius (its uncertainty budget).
  if (ch.intrinsics_covariance.size() > 0) {
    std::cout << fmt::format("wrote {} (the intrinsics covariance, for analyze's uncertainty budget)\n",
                             cov_path.string());
  }
  return 0;
}

}  // namespace

void AddCalibrateCommand(CLI::App& app, std::function<int()>& run) {
  auto a = std::make_shared<CalibrateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Calibrate the camera with mrcal from chessboard photos: detect, solve the candidate lens models, "
                   "keep the simplest adequate one; writes CAM.cameramodel and CAM.calibration.json");
  cmd->add_option("photos", a->photos, "Chessboard photos (one camera, one resolution)")->required();
  cmd->add_option("-o,--output", a->output, "Output camera model (.cameramodel)")->required();
  cmd->add_option("--board", a->board, "Inner corners across x down, e.g. 9x6");
  cmd->add_option("--square-mm", a->square_mm, "Square edge in mm (with --board)");
  cmd->add_option("--board-from", a->board_from,
                  "pattern.json of a checkerboard rendered by `curvecheck render` for a FLAT monitor: the monitor "
                  "is the target, squares sized by its pixel pitch");
  cmd->add_option("--lensmodel", a->lensmodel,
                  "auto (OPENCV4, OPENCV8 and a splined model; the simplest adequate one wins) or one mrcal "
                  "LENSMODEL_... name")
      ->capture_default_str();
  cmd->add_option("--detector", a->detector, "auto | opencv | mrgingham (square boards only)")->capture_default_str();
  cmd->add_option("--search-max-px", a->search_max_px,
                  "Longest side of the reduced copy the board search runs on (0 = full size); corners are refined "
                  "at full resolution")
      ->capture_default_str();
  cmd->add_option("--threads", a->threads, "Photos detected in parallel (0 = all cores)")->capture_default_str();
  cmd->add_option("--focal-px", a->focal_px, "Focal length seed, px (0 = estimate with OpenCV)")->capture_default_str();
  cmd->add_option("--distance-mm", a->distance_mm,
                  "Distance at which uncertainty and cross-validation differences are evaluated (0 = infinity)")
      ->capture_default_str();
  cmd->add_option("--splined-nx", a->splined_nx, "Knots across of the splined candidate")->capture_default_str();
  cmd->add_flag("--no-cross-validate", a->no_cross_validate, "Skip the two-halves cross-validation (faster)");
  cmd->add_flag("--from-screen", a->from_screen,
                "Calibrate from photos of the monitor showing --pattern (no board): the lens jointly with the camera "
                "poses and the screen's curvature; seeded from --focal-px or EXIF");
  cmd->add_option("--monitor", a->monitor, "With --from-screen: the monitor preset or spec (its physical size)");
  cmd->add_option("--pattern", a->pattern, "With --from-screen: the pattern.json shown in the photos");
  cmd->add_option("--min-photos", a->min_photos, "With --from-screen: fewer photos are refused")->capture_default_str();
  cmd->add_option("--max-projection-sigma", a->max_projection_sigma,
                  "With --from-screen: photos whose lens has a larger median projection sigma (px) where they put the "
                  "screen are refused with the positions to add (0: no limit)")
      ->capture_default_str();
  cmd->callback([&run, a] { run = [a] { return RunCalibrate(*a); }; });
}

}  // namespace curvecheck::app
