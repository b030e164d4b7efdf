// Camera-free check of anyone's correction (issue 19 part 2): an application draws the pattern of `curvecheck
// pattern` with its own correction, captures its framebuffer at display resolution, and this compares every
// feature found in the capture with its exact display position (pattern.json features[].display_px).
//
// Detection: the detect/ library finds the board or the tags and names every feature by its pattern.json id (board
// indexing and orientation, tag ids), so a correction that is tens of px off (`none`) is still matched feature by
// feature, never by proximity to the exact position. Checkerboard inner corners ("c<k>") are then re-measured by
// RefineXCornerByEdgeAreas (below), which is exact for box-filtered (analytically anti-aliased) images, and tag
// corners ("t<id>.<k>") by RefineLCornerByEdgeAreas. The detector's own refinements are biased on such captures:
// cornerSubPix 0.08-0.10 px max on the exact 49" render, the tag border-edge fit 0.21 px per axis toward the tag's
// centre (a Gaussian prefilter on gamma-encoded code values moves edges toward black); edge areas read 0.0024 px
// (board) and 0.0088 px (tags) max there.
//
// A capture that is not the display pixel for pixel is refused with the reason before anything is measured: a size
// other than pattern.json's resolution (a scaled or cropped capture), or content scaled or shifted inside a capture
// of the right size (letterbox, a window's client area): a similarity transform (scale, rotation, offset) fitted to
// the exact -> detected positions that explains the errors (its residual below max_explained_fraction of their rms)
// and whose scale differs from 1 by more than max_scale_deviation or whose offset exceeds max_offset_px. A
// correction's own error is not a similarity: `none` on the 49" 1000R from 1.5 m has a best similarity of scale
// 1.020 that leaves 11.0 of its 25.3 px rms, and is measured, not refused (screenshot_check_test).
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "detect/detect.h"
#include "pattern/pattern_json.h"

namespace curvecheck {

// Measurement of one checkerboard X-corner (two straight or gently curved edges crossing) by edge areas. For a
// box-filtered edge in linear light, the sum over a pixel column of (I - I_below) / (I_above - I_below) is exactly
// the edge's height at the column's centre (the area under a straight line over the column's width is its value at
// the centre), whatever the edge's slope; a symmetric blur of the capture (bilinear texture sampling, MSAA) keeps
// that sum. Each of the two lines through the corner is sampled so on both arms (columns for the more horizontal
// line, rows for the other, skipping `inner_px` around the junction), fitted with a quadratic, and the two curves
// intersected; three rounds re-centre the arms on the new corner. Fitting both arms of a line together makes the
// corner insensitive to a wrong linearization (gamma): it moves the two arms' edges to opposite sides.
struct EdgeAreaOptions {
  double half_segment_px = 5;  // half-length of each column/row segment across an edge, px (> the capture's blur)
  int inner_px = 4;            // samples start this far from the junction along each arm, px
  int arm_px = 30;             // and end this far (also at most 0.45 x the distance to the next corner), px
  int rounds = 3;              // re-centring rounds
};

struct EdgeAreaCorner {
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  // display px, pixel centres at integers
  // Standard uncertainty from the scatter of the edge samples about the fitted curves (random part only), px.
  double sigma_px = 0;
  int samples = 0;  // edge samples used (both lines)
};

// `linear`: CV_64F, linear light. `guess`: the corner within ~1 px. `line_a`, `line_b`: the directions of the two
// lines through the corner in the image (any length or sign; at least 30 deg apart). `max_arm_px`: the arm length
// limit from the board (0.45 x distance to the nearest corner). nullopt when the corner is too near the image edge,
// the lines cannot be sampled (low contrast, fewer than 4 samples per arm) or the fit does not converge.
std::optional<EdgeAreaCorner> RefineXCornerByEdgeAreas(const cv::Mat& linear, const Eigen::Vector2d& guess,
                                                       const Eigen::Vector2d& line_a, const Eigen::Vector2d& line_b,
                                                       double max_arm_px, const EdgeAreaOptions& options = {});

// The same for an L-corner (a tag's black border on white): each edge sampled on one arm only, the one that
// `toward_a` / `toward_b` point along (from the corner toward the next corners of the border). Without the second arm
// the linearization must be right (pattern.json's render gamma).
std::optional<EdgeAreaCorner> RefineLCornerByEdgeAreas(const cv::Mat& linear, const Eigen::Vector2d& guess,
                                                       const Eigen::Vector2d& toward_a, const Eigen::Vector2d& toward_b,
                                                       double max_arm_px, const EdgeAreaOptions& options = {});

struct ScreenshotCheckOptions {
  double tolerance_px = 0.5;  // the verdict's tolerance on max_px, display px (> 0)
  // Refusal of a capture that is not the display pixel for pixel (see top): |similarity scale - 1| and the
  // similarity's offset at the display centre. A 1% scale moves the display's edge by 26 px on a 5120 px display.
  double max_scale_deviation = 0.01;
  double max_offset_px = 8;
  double max_explained_fraction = 0.2;
  // Linearization of code values for the edge areas, gamma: nullopt = pattern.json's render.display_gamma, else 2.2.
  std::optional<double> gamma;
  // Systematic bound of the corner measurement (standard uncertainty, px) added in quadrature to each corner's own
  // sigma: measured on exact renders of the 49" 1000R (screenshot_check_test): board X-corners max 0.0024 px, tag
  // L-corners max 0.0088 px. A corner the edge areas cannot sample keeps the detector's position with
  // detector_floor_px (its measured bias on captures: 0.21 px per axis for tag corners).
  double corner_floor_px = 0.002;
  double tag_corner_floor_px = 0.005;
  double detector_floor_px = 0.3;
  DetectOptions detect;
  EdgeAreaOptions edges;

  void Check(const std::string& where) const;  // throws Error naming `where`
};

struct ScreenshotFeature {
  std::string id;
  Eigen::Vector2d detected_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d exact_px = Eigen::Vector2d::Zero();
  double sigma_px = 0;     // standard uncertainty of detected_px (per axis), px
  std::string refinement;  // "edge-areas" | the detector's ("opencv-classic", "apriltag", ...)
  Eigen::Vector2d Error() const { return detected_px - exact_px; }
};

// Why a capture is refused (typed; `reason` is for people).
enum class ScreenshotRefusal {
  kNone,
  kWrongSize,     // the image is not the display's resolution (scaled, cropped, another monitor)
  kNotFound,      // the detector found no feature of pattern.json (detection failure text in `reason`)
  kScaled,        // content scaled inside a capture of the right size (letterbox, scaled window)
  kShifted,       // content offset (crop + pad, window decorations)
};
const char* ScreenshotRefusalName(ScreenshotRefusal refusal);

struct SimilarityFit {
  double scale = 1, rotation_deg = 0;
  Eigen::Vector2d offset_at_centre_px = Eigen::Vector2d::Zero();  // where the display centre lands, minus itself
  double raw_rms_px = 0;       // rms |detected - exact| of the detector's positions
  double residual_rms_px = 0;  // rms after the similarity
};

struct ScreenshotCheck {
  ScreenshotRefusal refusal = ScreenshotRefusal::kNone;
  std::string reason;  // "" when not refused
  std::string detector;
  std::vector<std::string> notes;
  std::vector<ScreenshotFeature> features;  // every detected feature of the pattern
  int pattern_features = 0;                  // visible features in pattern.json
  SimilarityFit similarity;
  double rms_px = 0, p95_px = 0, max_px = 0;  // of |error_px| over the features, display px
  // Decision rule (shared/design/metrology.md section 2): e = max_px, U = 2 x the standard uncertainty of the
  // feature that gives max_px (its own sigma with the floor); pass if e + U <= T, fail if e - U > T, else
  // inconclusive.
  double expanded_uncertainty_px = 0;
  double tolerance_px = 0;
  std::string verdict;  // "pass" | "fail" | "inconclusive"
  double gamma = 2.2;   // linearization used
};

// Detects, refuses or measures (see top). `image`: the capture, CV_8U one channel (ReadPhotoGray). Never throws for
// a capture it refuses (refusal); throws Error for invalid options.
ScreenshotCheck CheckScreenshot(const cv::Mat& image, const PatternFile& pattern, const ScreenshotCheckOptions& options);

// screenshot_check.json, format "curvecheck.screenshot/1" (README "check-screenshot" lists the fields).
nlohmann::json ScreenshotCheckToJson(const ScreenshotCheck& check, const PatternFile& pattern);

// The error map as a gnuplot script and its data file (name, contents): the display outline, every feature at its
// exact position coloured by |error| (display px) with its error vector magnified `magnify` times.
struct GnuplotChart {
  std::string script;
  std::string data_name, data;
};
GnuplotChart ScreenshotErrorMap(const ScreenshotCheck& check, const PatternFile& pattern, double magnify);

}  // namespace curvecheck
