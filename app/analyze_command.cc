// `curvecheck analyze --camera cam.cameramodel --pattern pattern.json photo.png [photo2.png ...] -o OUTDIR`:
// detection, verification of the correction, the screen fit with model selection, deviations; writes
// OUTDIR/result.json (architecture.md, "File contracts"), one overlay image per photo and OUTDIR/report.html (the
// self-contained page, analysis/report.h; --no-report skips it). The work is analysis/analyze_run.h; this file
// parses the options.
#include "app/analyze_command.h"

#include <iostream>
#include <memory>

#include "analysis/analyze_run.h"
#include "app/cli.h"

namespace curvecheck::app {

void AddAnalyzeCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<AnalyzeRequest>();
  CLI::App* cmd = app.add_subcommand(
      "analyze",
      "Detect the pattern in photos, verify the correction (planar perspective check), fit the screen (radius with "
      "uncertainty, model selection, deviations); writes OUTDIR/result.json, overlay images and report.html");
  cmd->add_option("--camera,-c", args->camera, "The camera's mrcal .cameramodel (calibrated at the photos' size)")
      ->required();
  cmd->add_option("--pattern,-p", args->patterns,
                  "pattern.json of the rendering shown in the photos: once for all photos, or once per photo "
                  "in order")
      ->required()
      ->expected(1)
      ->take_all()
      ->allow_extra_args(false);
  cmd->add_option("photos", args->photos, "Photos (PNG/JPEG, 8 or 16 bit)")->required();
  cmd->add_option("-o,--output", args->output, "Output folder (created if missing)")->required();
  cmd->add_option("--detector", args->detector,
                  "auto | mrgingham | opencv-sb | opencv-classic | apriltag")
      ->capture_default_str();
  cmd->add_option("--tolerance", args->options.verify.tolerance_display_px,
                  "Verification passes when 95% of the features are within this many display px of the planar "
                  "perspective image")
      ->capture_default_str();
  cmd->add_option("--models", args->models,
                  "Screen models to try (default: all): flat, cylinder, cylinder+lean, varying-curvature, "
                  "varying-curvature-quadratic, cylinder+deviation")
      ->delimiter(',')
      ->expected(1)
      ->take_all()
      ->allow_extra_args(false);
  cmd->add_option("--expected-noise", args->options.fit.expected_noise_px,
                  "Expected detection noise per coordinate, px (scales the robust loss)")
      ->capture_default_str();
  cmd->add_option("--lens-covariance", args->lens_covariance,
                  "The lens calibration's intrinsics covariance (curvecheck.intrinsics_covariance/1, written by "
                  "`curvecheck calibrate`); default: CAM.intrinsics_covariance.json beside --camera when it exists, "
                  "else the lens is taken as exact (the budget says so)");
  cmd->add_option("--lens-misfit", args->lens_misfit,
                  "RMS_PX,LENGTH_PX: the lens model misfit the calibration measured (a Gaussian field common to "
                  "every photo, RMS per coordinate and correlation length, px; curvecheck calibrate writes it into "
                  "the covariance sidecar, which is the default); the budget's lens-model-misfit row is this field's "
                  "effect unless the field measured from the photos' residuals moves the curvature significantly "
                  "more (one-sided 5%)")
      ->delimiter(',')
      ->expected(2);
  cmd->add_option("--pitch-tolerance", args->pitch_tolerance_percent,
                  "Tolerance of the datasheet's pixel pitch, percent (half-width of a rectangular distribution; "
                  "its u = tolerance/sqrt(3) is the budget's pixel-pitch row: u(R)/R = u(p)/p)")
      ->capture_default_str();
  cmd->add_option("--smooth-bias-px", args->options.fit.smooth_bias_px,
                  "The detector's smooth bias (RMS per coordinate of a field smooth across the image and common to "
                  "the photos, px; type B, e.g. from a bench of your detector against a known target). Default: "
                  "the part of the detector's scatter about the fit (without the pixel-locking signature) that "
                  "neighbouring corners share, a one-sided 95% bound (else the scatter less the corners' measured "
                  "random part; result.json fit.uncertainty_budget.detector_systematic.bound_reason says which)");
  cmd->add_option("--pixel-locking-prior", args->options.fit.pixel_locking_prior_px,
                  "Prior standard deviation of each of the detector's pixel-locking coefficients, px (type B; 0: "
                  "none, the regression alone). It bounds the signature where the photos cannot determine it (the "
                  "fit absorbs it) and is negligible elsewhere; the curvature and camera positions are corrected for the signature")
      ->capture_default_str();
  cmd->add_option("--prefilter-sigma", args->prefilter_sigma_px,
                  "Gaussian prefilter of the detector, sigma in camera px: -1 auto (default: against the moire "
                  "measured in the photo, and 2 x the display pitch for the refinement; where it hides a small "
                  "board, the coarse search is repeated unfiltered), 0 none, or a fixed sigma "
                  "(result.json records the one used: inputs.photos[].detection.moire.filter_sigma_px)");
  cmd->add_flag("--correct-pixel-locking", args->options.correct_pixel_locking,
                "Remove the detector's pixel-locking (estimated with the verification's error field, reported in "
                "result.json either way) from the detections before the screen fit (experimental: see README)");
  cmd->add_flag("--no-fit", args->no_fit, "Detection and verification only");
  cmd->add_flag("--no-overlays", args->no_overlays, "Do not write overlay images");
  cmd->add_flag("--no-report", args->no_report, "Do not write report.html (the HTML page; see `curvecheck report`)");
  cmd->add_option("--magnify", args->magnification, "Magnification of the residual vectors in the overlays")
      ->capture_default_str();
  cmd->callback([&run, args] {
    args->command_line = CommandLine();
    run = [args] {
      AnalyzeToFolder(*args, std::cout);
      return 0;
    };
  });
}

}  // namespace curvecheck::app
