// Verification of a correction (architecture.md, "Analysis: Verify"; issue 6 item 2): is what the camera sees a
// planar perspective image of the pattern?
//
// A rendering corrected for viewpoint V shows, seen from V, the pattern plane in exact perspective (the
// construction of thesis 000_0a6434fbdad225dc.txt section 4.1: every display pixel shows the plane point on the
// ray from V through it). With the lens removed (mrcal unprojection to normalized coordinates), a photo taken
// from V must therefore be the image of the plane under a homography H: (x/z, y/z) ~ H (a, b, 1) for pattern
// coordinates (a, b) in mm. Whatever the best homography cannot explain is the correction's error (plus
// detection noise): a wrong method, a wrong screen model, a misstated viewpoint, or a monitor that is not the
// one the rendering assumed.
//
// The homography is fitted by least squares on the camera-pixel residuals (through the lens, with mrcal's
// projection gradients), starting from a DLT in normalized coordinates. All features the detector did not flag
// are used, with no robust loss: a systematic residual is the quantity being measured, not an outlier.
//
// Residuals are reported
//   - in camera px: detected - predicted;
//   - in display px: the display displacement that would explain the camera residual, r_display = J^-1 r_px
//     with J = d(camera px)/d(display px) = d q/d(a, b) * d(a, b)/d(display px): the homography's (through
//     the lens) and the rendering's correction mapping's local Jacobians (exact when the camera is at the
//     stated viewpoint, a first-order approximation otherwise);
//   - in arc-minutes: the angle between the detected ray and the predicted ray at the camera.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "analysis/error_field.h"
#include "core/camera_model.h"
#include "core/correction.h"
#include "pattern/pattern_json.h"

namespace curvecheck {

struct VerifyOptions {
  // The tolerance T on the correction error: 95% of the features must be displaced by less than T display px
  // (the 95th percentile of the correction-error field's length over the features). 0.5 display px is half a
  // pixel on the monitor: larger errors show as misplaced edges. A percentile rather than the RMS, because a
  // correction that is wrong in one region must fail even where most features are right; not the maximum,
  // because one bad corner must not decide.
  double tolerance_display_px = 0.5;
  // Fewest features for a verdict: the homography has 8 degrees of freedom, so at least 4 points fit it
  // exactly; the residuals mean something only with many more.
  int min_features = 8;
  // The correction-error field (analysis/error_field.h): tensor Legendre polynomials in the display position,
  // up to this degree across the width (the height's degree scaled by the features' aspect), the degree chosen
  // by AIC, fitted to the residuals beyond the homography. 16 resolves an error that changes sign about 16
  // times across the screen; rougher errors are indistinguishable from detection noise at the feature spacing
  // and raise the noise estimate (and so U) instead.
  int max_field_degree = 16;
  // Largest residual scatter (camera px per coordinate, about the field) that is still detection noise. Corner
  // detectors give 0.02-0.3 px on real photos; beyond this the residuals hold an error the field cannot resolve
  // (rough at the feature spacing) or the photo is too poor, and a pass cannot be stated.
  double max_noise_px = 0.5;
  // Features whose residual about the field exceeds this many robust sigmas (at least detector_systematic_px)
  // are left out of the field fit (and listed); they keep their residuals.
  double outlier_sigmas = 5;
  // Standard uncertainty of the detector's systematic error, camera px per coordinate: corner detectors lock to
  // the pixel grid and are biased on small, blurred squares by a few hundredths to a tenth of a pixel, and such a
  // bias varies smoothly over the screen, so the field cannot tell it from a correction error (the verdict bench
  // saw e = 0.12-0.47 display px on exact renderings at 2-3 m and quarter resolution, the same on every seed).
  // It enters U as 2 x this x the display px per camera px, in quadrature with the field's band. 0 turns it off.
  double detector_systematic_px = 0.05;
  // Monte Carlo draws of the field's estimation error for the simultaneous 95% band (fixed seed: the same
  // photo gives the same verdict).
  int uncertainty_draws = 400;
  // Fit the detector's pixel-locking (analysis/error_field.h) with the field: its coefficients are reported and
  // each feature's predicted bias (FeatureCheck::pixel_locking_px) is what the analysis removes before the
  // screen fit. Off: the field and the noise hold it.
  bool pixel_locking = true;

  void Check(const std::string& where) const;
};

// The three outcomes of the decision rule (ISO 14253-1 with the expanded uncertainty U as guard band;
// ../shared/design/metrology.md section 2): pass when e + U <= T, fail when e - U > T, otherwise inconclusive.
enum class Verdict { kPass, kFail, kInconclusive };
const char* VerdictName(Verdict v);   // "pass", "fail", "inconclusive" (result.json)
const char* VerdictLabel(Verdict v);  // "PASS", "FAIL", "INCONCLUSIVE" (summaries)

struct FeatureCheck {
  std::string id;
  Eigen::Vector2d pattern_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d display_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d detected_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d expected_px = Eigen::Vector2d::Zero();  // the fitted planar perspective image
  Eigen::Vector2d residual_px = Eigen::Vector2d::Zero();  // detected - expected
  Eigen::Vector2d residual_display_px = Eigen::Vector2d::Zero();
  // Standard uncertainty of residual_display_px from detection noise (display px, per axis: the camera-px noise
  // through the local inverse Jacobian).
  Eigen::Vector2d residual_display_sigma_px = Eigen::Vector2d::Zero();
  // The correction-error field at this feature (display px) and its standard uncertainty (per axis).
  Eigen::Vector2d error_display_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d error_display_sigma_px = Eigen::Vector2d::Zero();
  // The detector's pixel-locking bias predicted at the detected position (detected - true, camera px; zero when
  // not estimated).
  Eigen::Vector2d pixel_locking_px = Eigen::Vector2d::Zero();
  double residual_arcmin = 0;
  bool field_outlier = false;  // left out of the field fit (residual far beyond the noise)
};

// Why no verdict was reached (typed; `Verification::failure` says it for people).
enum class VerificationFailure {
  kNone,
  kTooFewFeatures,  // fewer usable features than VerifyOptions::min_features
  kLensMismatch,    // a feature unprojects behind the camera: the lens model does not fit the photo
  kDegenerate,      // the pattern plane is not in front of the camera, or the homography fit did not converge
  kNoVerdict,       // combined: no photo gave a verdict
};

struct Verification {
  std::vector<FeatureCheck> features;  // in the order given
  // Pattern mm -> normalized camera coordinates: (x/z, y/z, 1) ~ homography * (a, b, 1).
  Eigen::Matrix3d homography = Eigen::Matrix3d::Identity();
  // Raw residual statistics (correction error and detection noise together).
  double rms_px = 0, max_px = 0;
  double rms_display_px = 0, max_display_px = 0, p95_display_px = 0;
  double rms_arcmin = 0, max_arcmin = 0;
  double tolerance_display_px = 0;

  // The decision (see Verdict). e: the 95th percentile over the features of the correction-error field's length
  // (display px); U: its expanded uncertainty: a simultaneous 95% band of the field over the features (so that
  // [e - U, e + U] holds the true percentile with at least 95% probability when the detections are unbiased),
  // combined in quadrature with the detector's systematic term (VerifyOptions::detector_systematic_px);
  // ratio = T / U.
  Verdict verdict = Verdict::kInconclusive;
  bool pass = false;  // verdict == kPass
  double error_p95_display_px = 0;
  double expanded_uncertainty_display_px = 0;
  double coverage_factor = 0;  // the field's band over the RMS standard uncertainty of the field at the features
  double field_band_display_px = 0;       // the field's simultaneous 95% band (U's random part)
  double systematic_display_px = 0;       // U's systematic part: 2 x detector_systematic_px x display px per camera px
  double tolerance_ratio = 0;  // T / U
  double noise_px = 0;         // detection noise about the field, camera px per coordinate
  double display_px_per_camera_px = 0;  // median over the features (the camera's resolving power on the display)
  int field_degree = 0;                 // total degree of the chosen field
  int field_outliers = 0;
  PixelLocking pixel_locking;           // fitted with the field (VerifyOptions::pixel_locking)
  std::string verdict_reason;           // one line: why this verdict
  // When inconclusive: what would make it conclusive, with figures ("" otherwise).
  std::string advice;

  // "" when a verdict was reached; otherwise why not ("only 5 usable features; at least 8 are needed").
  std::string failure;
  VerificationFailure failure_kind = VerificationFailure::kNone;  // set together with `failure`
};

// The pattern plane of a pattern.json (its "pattern"."plane" object). Throws Error naming `where` if absent
// or invalid.
PatternPlane PatternPlaneFromJson(const nlohmann::json& pattern_json, const std::string& where);

// Verifies one photo. ids / detected_px: the detector's unflagged features (ids of `pattern`'s features; an
// unknown id throws Error). Features whose display_px is null in pattern.json are skipped.
Verification VerifyCorrection(const PatternFile& pattern, const CameraModel& camera,
                              const std::vector<std::string>& ids, const std::vector<Eigen::Vector2d>& detected_px,
                              const VerifyOptions& options = {});

// The verdict over several photos: residual statistics over all their features together; fail if any photo
// with a verdict fails, pass only if every one passes, otherwise inconclusive; e and U of the photo that decides
// (the largest e + U).
Verification CombineVerifications(const std::vector<Verification>& photos, const VerifyOptions& options);

}  // namespace curvecheck
