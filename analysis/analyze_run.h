// `curvecheck analyze` once its options are parsed (app/analyze_command.cc): the options checked, every output
// checked against the inputs before the work, the analysis (pipeline.h), and OUTDIR/result.json, one overlay per
// photo read (overlay.h; a duplicate's too) and OUTDIR/report.html (report.h) published as one set.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "analysis/pipeline.h"

namespace curvecheck {

// The command's options; `options` holds those that bind to AnalyzeOptions directly.
struct AnalyzeRequest {
  std::string camera;
  std::vector<std::string> patterns;
  std::vector<std::string> photos;
  std::string output;
  AnalyzeOptions options;
  std::vector<std::string> models;
  std::string detector = "auto";
  bool no_fit = false;
  bool no_overlays = false;
  bool no_report = false;
  double magnification = 50;
  std::string command_line;
  std::string lens_covariance;
  double pitch_tolerance_percent = 0.1;
  std::optional<double> prefilter_sigma_px;
  // --lens-misfit RMS_PX,LENGTH_PX: the lens model misfit as stated (FitOptions::stated_lens_misfit_px); empty: the
  // calibration's, from the intrinsics covariance sidecar when it has one.
  std::vector<double> lens_misfit;
};


// Runs the analysis into request.output, printing the summary and what was written on `log`. Throws Error for bad
// input, for no usable photo (the first photo's reason), and when report.html could not be written (result.json
// was).
void AnalyzeToFolder(AnalyzeRequest request, std::ostream& log);

}  // namespace curvecheck
