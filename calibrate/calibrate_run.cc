// `curvecheck calibrate` from chessboard photos (calibrate_run.h); the --from-screen run is from_screen_run.cc.
#include "calibrate/calibrate_run.h"

#include <fmt/format.h>

#include <filesystem>
#include <ostream>

#include "calibrate/calibrate.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/output_paths.h"
#include "core/path_check.h"
#include "core/stopwatch.h"

namespace curvecheck {
namespace fs = std::filesystem;

CalibrationFiles CalibrationOutputs(const std::string& output) {
  CalibrationFiles f;
  f.model = output;
  if (f.model.extension() != ".cameramodel") {
    throw Error("-o", fmt::format("'{}' does not end in .cameramodel", output), "write e.g. -o cam.cameramodel");
  }
  f.report = fs::path(f.model).replace_extension(".calibration.json");
  f.covariance = fs::path(f.model).replace_extension(".intrinsics_covariance.json");
  return f;
}

std::vector<fs::path> CheckCalibrationFiles(const std::vector<std::string>& photo_args, const CalibrationFiles& files,
                                            const std::string& target, bool refuse_output_photo) {
  std::vector<fs::path> photos;
  std::error_code ec;
  for (const std::string& p : photo_args) {
    if (ClassifyPath(p) == PathKind::kLinkLoop) RequireFile(p);  // "is a symbolic link loop; ..."
    if (!fs::is_regular_file(p, ec)) throw Error(p, "is not a file", "give the photos' paths (shell globs work)");
    if (refuse_output_photo && fs::exists(files.model, ec) && fs::equivalent(p, files.model, ec)) {
      throw Error(p, "is also the output", "choose another -o");
    }
    photos.emplace_back(p);
  }
  const std::vector<NamedOutput> outputs = {{"-o", files.model},
                                            {"the report beside -o", files.report},
                                            {"the covariance beside -o", files.covariance}};
  std::vector<fs::path> inputs = photos;
  if (!target.empty()) inputs.push_back(target);
  CheckOutputs(outputs, inputs);
  for (const NamedOutput& o : outputs) CheckWritable(o.path);
  return photos;
}

void RunBoardCalibration(const CalibrateRequest& a, std::ostream& out_text, std::ostream& err) {
  const CalibrationFiles files = CalibrationOutputs(a.output);
  if (a.board.empty() == a.board_from.empty()) {
    throw Error("--board", "give exactly one of --board NxM (with --square-mm) and --board-from pattern.json", "");
  }
  if (!a.board_from.empty() && a.square_mm != 0) {
    throw Error("--square-mm", "the square size comes from --board-from's pattern.json", "drop --square-mm");
  }
  // Every output against every input and writable before the work, which takes minutes on 30 large photos.
  const std::vector<fs::path> photos = CheckCalibrationFiles(a.photos, files, a.board_from, true);
  const fs::path& out = files.model;
  const fs::path& report_path = files.report;
  const fs::path& cov_path = files.covariance;
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
    if (!det.found) out_text << fmt::format("{}: {}; not used\n", det.photo.string(), det.problem);
  }
  // Each photo content counts once (issue 15 item 4): the note names both files, here and in the report.
  for (const std::string& note : gathered.DuplicateNotes()) err << "calibrate: note: " << note << "\n";
  const int duplicates = gathered.Duplicates();
  out_text << fmt::format("detection: board {}x{} ({} mm squares) in {} of {} photos{}, {:.2f} s wall\n",
                           board.corners_x, board.corners_y, board.square_mm, found, photos.size() - duplicates,
                           duplicates > 0 ? fmt::format(" ({} duplicate photo(s) left out)", duplicates) : "",
                           detect_s);
  const CalibrationResult r = Calibrate(gathered, board, c);
  out_text << CandidateTable(r);
  const CandidateResult& ch = r.Chosen();
  out_text << fmt::format(
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
  out_text << fmt::format("wrote {} and {}\n", out.string(), report_path.string());
  // The lens's own uncertainty, which `curvecheck analyze` propagates into the radius (its uncertainty budget).
  if (ch.intrinsics_covariance.size() > 0) {
    out_text << fmt::format("wrote {} (the intrinsics covariance, for analyze's uncertainty budget)\n",
                             cov_path.string());
  }
}

}  // namespace curvecheck
