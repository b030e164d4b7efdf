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

#include "core/camera_model.h"
#include "core/correction.h"
#include "pattern/pattern_json.h"

namespace curvecheck {

struct VerifyOptions {
  // Pass when 95% of the features are within this many display px of the planar perspective image (the 95th
  // percentile of the residuals' lengths). 0.5 display px is half a pixel on the monitor: larger errors show as
  // misplaced edges. A percentile rather than the RMS, because a correction that is wrong in one region (a
  // misstated viewpoint shifts the edges, not the centre) must fail even where most features are right; not the
  // maximum, because one noisy corner must not fail a good rendering.
  double tolerance_display_px = 0.5;
  // Fewest features for a verdict: the homography has 8 degrees of freedom, so at least 4 points fit it
  // exactly; the residuals mean something only with many more.
  int min_features = 8;

  void Check(const std::string& where) const;
};

struct FeatureCheck {
  std::string id;
  Eigen::Vector2d pattern_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d display_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d detected_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d expected_px = Eigen::Vector2d::Zero();  // the fitted planar perspective image
  Eigen::Vector2d residual_px = Eigen::Vector2d::Zero();  // detected - expected
  Eigen::Vector2d residual_display_px = Eigen::Vector2d::Zero();
  double residual_arcmin = 0;
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
  double rms_px = 0, max_px = 0;
  double rms_display_px = 0, max_display_px = 0, p95_display_px = 0;
  double rms_arcmin = 0, max_arcmin = 0;
  double tolerance_display_px = 0;
  bool pass = false;
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

// The verdict over several photos: residual statistics over all their features together; passes only if every
// photo with a verdict passes and at least one has a verdict.
Verification CombineVerifications(const std::vector<Verification>& photos, const VerifyOptions& options);

}  // namespace curvecheck
