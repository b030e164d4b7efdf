// The analysis of a set of photos (issue 6 item 6): detect -> verify -> fit -> select -> deviations, and the
// result.json document (architecture.md, "File contracts"). `curvecheck analyze` and `curvecheck demo` are thin
// shells around Analyze, ResultJson and the overlays (analysis/overlay.h).
//
// Bad photos do not stop the analysis: a photo that cannot be read, has the wrong size for the camera model,
// or does not show its pattern is rejected with its reason, and the good ones are analysed. Only when no photo
// is usable does Analyze report failure.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "detect/detect.h"
#include "analysis/screen_fit.h"
#include "analysis/verify.h"
#include "core/camera_model.h"
#include "pattern/pattern_json.h"

namespace curvecheck {

// The overlays' size: the photo scaled to at most this many px on its longer side (overlay.h OverlayPng).
constexpr int kOverlayMaxPx = 3000;

struct AnalyzeOptions {
  DetectOptions detect;
  VerifyOptions verify;
  FitOptions fit;
  // Fit the screen (false: detection and verification only).
  bool fit_screen = true;
  // The lens calibration's intrinsics covariance (curvecheck.intrinsics_covariance/1, written by curvecheck
  // calibrate). Empty: CAM.intrinsics_covariance.json beside the camera model when it exists; otherwise the lens
  // is taken as exact (the budget's lens row is 0 and says so). A file given here must exist.
  std::filesystem::path lens_covariance;
  // Remove the pixel-locking the verification estimated (Verification::pixel_locking, analysis/error_field.h)
  // from the detections before the screen fit. Off by default: on the default scene at quarter resolution from
  // 1.5 m it cut the radius scatter over 16 jittered poses from 5.0 mm to 0.45 mm, but from 3 m the fit's
  // residual noise fell to a few thousandths of a pixel and the model choice then took varying-curvature or
  // cylinder+deviation on detector biases the first harmonic leaves (3 of 8 trials, sigma 38-156 mm, one
  // ill-conditioned), where without it the cylinder was chosen 16 times of 16 with the scatter at 1.0 sigma.
  // The estimate is reported either way; the budget's detector-systematic row covers what is not removed.
  bool correct_pixel_locking = false;
  // Keep each used photo's image for its overlay (PhotoAnalysis::overlay_gray), scaled to at most this many px on
  // its longer side, so that OverlayPng draws on it instead of decoding the photo a second time (issue 18: the
  // second decode was a third of `analyze`'s time at 24 MP). 0: keep none (OverlayPng reads the photo again).
  int overlay_max_px = 0;

  void Check(const std::string& where) const;
};

struct PhotoInput {
  std::filesystem::path photo;
  std::filesystem::path pattern;  // its pattern.json
};

// Why a photo was not used (typed; PhotoAnalysis::rejected says it for people). The detection's and the
// verification's own kinds say more (PhotoAnalysis::detection.failure_kind, verification.failure_kind).
enum class PhotoRejection {
  kNone,
  kUnreadable,    // the file cannot be read as a photo
  kWrongSize,     // its size is not the camera model's
  kDetection,     // the pattern was not detected (see detection.failure_kind)
  kVerification,  // no verdict from its features (see verification.failure_kind)
  kDuplicate,     // the same image content as an earlier photo: used once
};

// Why there is no screen fit (typed; AnalysisResult::fit_failure says it for people).
enum class FitFailure {
  kNone,
  kNotRequested,    // AnalyzeOptions::fit_screen is false
  kNoUsablePhoto,   // every photo was rejected
  kTooFewFeatures,  // a used photo has fewer features than FitOptions::min_features_per_photo
  kSolver,          // the fit itself failed (pose initialisation, an ill-posed problem); see fit_failure
};

struct PhotoAnalysis {
  PhotoInput input;
  std::string name;  // file name of the photo, unique within the analysis (for result.json and overlays)
  bool used = false;
  std::string rejected;  // why the photo was not used ("" when used)
  PhotoRejection rejection = PhotoRejection::kNone;
  Detection detection;
  // How the photo file became gray (ReadPhotoGray; luma or the channel mean, and the colour aliasing measured):
  // set by Analyze from files; colour = false from AnalyzeImages, whose images come gray.
  GrayConversion gray_conversion;
  Verification verification;
  int fit_index = -1;  // index of this photo in the fit (ScreenFitResult cameras / residuals), -1 if not fitted
  // kDuplicate: the index (in AnalysisResult::photos) of the earlier photo with this content, whose analysis
  // stands for it; -1 otherwise.
  int duplicate_of = -1;
  std::vector<std::string> fit_ids;  // the ids given to the fit, in its order
  double read_ms = 0, verify_ms = 0;
  // The photo as OverlayPng draws on it (AnalyzeOptions::overlay_max_px): 8-bit gray, scaled by overlay_scale
  // (<= 1) with INTER_AREA; empty when not kept.
  cv::Mat overlay_gray;
  double overlay_scale = 1;
  int overlay_max_px = 0;
};

struct AnalysisResult {
  std::filesystem::path camera_path;
  CameraModel camera;
  Monitor monitor;  // the nominal monitor, common to every pattern.json
  std::vector<PatternFile> patterns;  // by input order (each photo's own)
  std::vector<PhotoAnalysis> photos;
  Verification verification;  // over all used photos
  std::optional<ScreenFitResult> fit;
  std::string fit_failure;  // why there is no fit (fit disabled, or an error) when `fit` is empty
  FitFailure fit_failure_kind = FitFailure::kNone;
  double total_ms = 0, fit_ms = 0;

  int UsedPhotos() const;
  // The photo whose analysis the overlay of photos[index] draws: index itself when it is used; for a duplicate
  // (PhotoRejection::kDuplicate) the earlier photo with its content, when that one is used; -1: no overlay.
  int OverlaySource(size_t index) const;
};

// Analyses the photos. Throws Error for bad input that concerns the whole analysis (unreadable camera model or
// pattern.json, patterns of different monitors, invalid options); a bad photo is rejected, not thrown. The
// caller checks UsedPhotos() > 0.
AnalysisResult Analyze(const std::filesystem::path& camera_path, const std::vector<PhotoInput>& inputs,
                       const AnalyzeOptions& options);

// As Analyze, with the camera model and the photos already in memory (benchmarks): images[i] is the photo of
// inputs[i] (CV_8U or CV_16U, one channel); inputs[i].photo only names it.
AnalysisResult AnalyzeImages(const CameraModel& camera, const std::filesystem::path& camera_path,
                             const std::vector<PhotoInput>& inputs, const std::vector<cv::Mat>& images,
                             const AnalyzeOptions& options);

// The screen fit's observations of a photo the verification accepted: its verified features, each detection less
// the pixel-locking bias the verification estimated when options.correct_pixel_locking. Analyze fits these; a
// bench that refits a photo's observations (bench validity --detector-effect) builds them here too.
PhotoObservations FitObservationsOf(const PhotoAnalysis& photo, const AnalyzeOptions& options);

// result.json: format curvecheck.result/1 (architecture.md) with the inputs and their provenance, the
// verification, the fit with every candidate, the deviations, and every feature.
nlohmann::json ResultJson(const AnalysisResult& result, const std::string& command_line);

// The name of each photo in the analysis (PhotoAnalysis::name, result.json's inputs.photos[].name), in input
// order: its file name, made unique by stem (a/photo.png and b/photo.png become photo.png and photo-2.png) because
// the overlay file is named after the stem (report.h OverlayFileName).
std::vector<std::string> PhotoNames(const std::vector<PhotoInput>& inputs);

// A short human summary (verification verdict, radius +- sigma, chosen model, rejected photos), one item per line.
std::string SummaryText(const AnalysisResult& result);

}  // namespace curvecheck
