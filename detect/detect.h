// Detection (issue 6 item 1): finds the features of a pattern.json in a photo and names them with the
// pattern's feature ids ("c<k>" checkerboard inner corners, "t<id>.<k>" tag corners; pattern/pattern.h).
//
// Detectors:
//   mrgingham       the mrgingham library (no CLAHE/blur preprocessing: the library as it is). Square boards of
//                   N x N inner corners only.
//   opencv-sb       OpenCV findChessboardCornersSB at full resolution (its own sub-pixel corners; histogram
//                   equalization only as a retry, it costs accuracy).
//   opencv-classic  OpenCV findChessboardCorners on a copy scaled down by an integer factor to at most
//                   `classic_max_px` on its longer side (area averaging; global threshold, then with histogram
//                   equalization; not the adaptive thresholds, which take a minute on photos of other boards),
//                   then cornerSubPix at full resolution with a window of 0.3 x the distance to the nearest corner
//                   (on a smoothed patch, see prefilter_sigma_px).
//   apriltag        AprilTag 3 tag36h11 on a copy shrunk by `apriltag_decimate` with area averaging and smoothed
//                   (0.8 px; AprilTag's own decimation samples single pixels, which aliases the display's pixel
//                   grid); corners moved by -0.5 px to pixel centres at integers, then refined at
//                   full resolution from the tag's outer border: each of the four edges is located along its
//                   normal at ~1 px steps and fitted with a quadratic curve (lens distortion and screen curvature
//                   bend the edges), adjacent curves intersected. Kind "both": the checkerboard corners are
//                   predicted from the nearest tags (local homography in pattern coordinates) and refined by
//                   cornerSubPix within the clean X-junction around each corner.
//   auto            by pattern kind, without running every detector: checkerboard -> opencv-classic (falls back
//                   to opencv-sb only if classic fails, and says so in the notes); apriltag and both -> apriltag.
//
// Orientation of checkerboards (the grid a board detector returns has no ids). Candidates are the symmetries
// of the board that keep its size: identity and 180 deg, plus 90 and 270 deg for square boards, and the same
// seen through a mirror. Rule: (1) the square colours decide where the board's parity makes them decisive (the
// top-left square is black; a 180 deg turn changes the colours iff cols + rows is odd, a 90 deg turn iff the
// board has an even number of squares per side, a left-right mirror iff cols is even, an up-down one iff rows
// is even); (2) among the candidates the colours leave, the photo is assumed roughly upright: the board's up
// direction, averaged over the board, within `upright_max_deg` (default 40) of the image's up, and unmirrored
// where an unmirrored and a mirrored candidate are both upright (a board that is its own mirror image, e.g.
// 15 x 5: a mirrored photo of it cannot be told from a true one). A mirrored candidate is chosen where the
// colours leave no unmirrored one (16 x 6 seen in a mirror), or where the only upright candidate is mirrored:
// the default 16 x 5 board photographed upright through a mirror has the colours of the board turned by
// 180 deg, and is named mirrored (so a true photo of it taken upside down is refused as mirrored too, with
// that alternative in the text). If no candidate or more than one remains, the result is failure "ambiguous
// orientation" rather than a guess.
//
// Handedness (issue 15). A camera sees only the front of a screen, so the map pattern plane -> image has one
// orientation: with the pattern's a to the right and b up, and the image's x to the right and y down, an
// upright photo maps (a, b) to about (s a, -s b), and every photo of the front, at any roll, tilt, perspective or
// lens distortion, has det(d image / d pattern) < 0. After the ids are assigned, an affine map is fitted to
// the features (pattern_mm -> px, least squares; PatternHandedness); if its determinant is positive the
// features map to the pattern with a reflection and the detection fails with kMirrored (a webcam or phone
// "mirror" setting, or a photo flipped in software). Tags: a mirrored tag36h11 tag does not decode (every code
// mirrored is at least 4 bits from every code in any rotation, and at most 2 are corrected), so when no tag of
// the pattern decodes, the detector runs again on the photo flipped left to right; tags of the pattern there
// mean the photo is mirrored (the same test on their corners mapped back).
//
// Screening. Every feature is predicted from its neighbours (the nearest `screen_neighbours` features in
// pattern coordinates, excluding the same tag's corners) by a homography fitted to them; a feature whose
// detection is farther from the prediction than max(`outlier_sigmas` x the robust sigma of all residuals,
// `outlier_min_px`) is flagged "outlier: ...". The worst is flagged first and removed from the neighbourhoods
// before the others are re-checked, so one bad feature does not drag its neighbours along. Features within
// `border_px` of the image edge are flagged "near the image border". Flagged features stay in the result (the
// caller decides; `flag` says why).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "core/image_decode.h"
#include "detect/moire.h"
#include "pattern/pattern_json.h"

namespace curvecheck {

// The detectors above; names (auto, mrgingham, opencv-sb, opencv-classic, apriltag) are parsed and printed only
// at the edges (ParseDetector, DetectorName).
enum class Detector { kAuto, kMrgingham, kOpenCvSb, kOpenCvClassic, kAprilTag };
const char* DetectorName(Detector detector);
// Throws Error(where, "detector '<name>' is not known", the list) for any other name.
Detector ParseDetector(const std::string& name, const std::string& where);

struct DetectOptions {
  Detector detector = Detector::kAuto;
  // AprilTag: the detector runs on a copy shrunk by this factor (1 = full resolution). 2 is ~3x faster than 1 at
  // 24 MP; the corners are refined at full resolution afterwards either way. 1..8.
  int apriltag_decimate = 2;
  // AprilTag: largest number of corrected bits accepted (tag36h11 codes are >= 11 bits apart). 0..3.
  int apriltag_max_hamming = 1;
  // AprilTag: threads for the detector (0 = all cores).
  int apriltag_threads = 0;
  // Refine AprilTag corners from the border edges (false: the detector's corners, -0.5 px, as they are).
  bool refine_tags = true;
  // Refine them in light: the photo's tone curve measured on the tags' borders (detect_tags.h MeasureTagTone) and
  // undone before the refinement (false: the code values read as light, the 50% crossings as the edges).
  bool tag_tone_from_borders = true;
  // opencv-classic: longer side of the scaled copy that the coarse detector sees, px (0 = full resolution).
  int classic_max_px = 1600;
  // opencv-sb: add CALIB_CB_ACCURACY (upsampling; ~5x slower, a little more accurate).
  bool sb_accuracy = false;
  // Gaussian smoothing (sigma, px) of the neighbourhood of each feature before its full-resolution refinement, and
  // of the whole photo before opencv-sb and mrgingham. -1 = auto: (1) from the moire measured in the photo
  // (moire.h): when moire is present, the sigma that brings each of its components down to
  // moire.residual_contrast, or the sigma that brings the broadband texture (moire.h) to moire.residual_texture
  // when it reaches moire.texture_limit, the larger (at most 10 px), applied to the whole photo before the coarse
  // detector (any) and to the refinement; (2) for the refinement, at least 2 x the display's pixel pitch in the
  // photo (estimated from the coarse detections and pattern.json's display positions) when that pitch exceeds 0.5
  // camera px: the camera then
  // resolves the display's pixels, and the pattern's edges are staircases of them. A photo with neither is
  // detected unfiltered. A symmetric blur moves neither straight edges nor X-corners (moire.h). Measured
  // (docs/bench/moire.txt, 1.67 camera px per display px, sharp lens): fill 0.7 0.51 px RMS unfiltered, 0.024 px
  // with the prefilter; fill 1 0.137 px unfiltered, 0.019 px. Detection.moire reports what was seen and used.
  // Under -1, where the prefiltered copy hides a small board from the coarse search (every detector tried: under
  // the auto detector classic, then SB), the coarse search is repeated on the photo itself and noted; the
  // refinement keeps its sigma. A stated sigma (>= 0) is used as given.
  double prefilter_sigma_px = -1;
  // Orientation rule (2): largest angle between the board's up and the image's up, deg, in (0, 45].
  double upright_max_deg = 40;
  // Screening: neighbours per local homography (>= 5), threshold in robust sigmas and its floor in px.
  int screen_neighbours = 8;
  double outlier_sigmas = 5;
  double outlier_min_px = 0.5;
  // Features closer than this to the image edge (px) are flagged: their refinement window is cut.
  double border_px = 4;
  // Measure the refined board corners' response to the photo's own noise (Detection::refinement_noise): four
  // more refinements of up to 120 corners.
  bool measure_refinement_noise = true;
  // The moire measurement and the auto prefilter's thresholds (moire.h).
  MoireOptions moire;

  void Check(const std::string& where) const;  // throws Error naming `where`
};

struct DetectedFeature {
  std::string id;      // the pattern.json feature id ("c12", "t7.2")
  Eigen::Vector2d px;  // camera image coordinates, pixel centres at integers (mrcal/OpenCV convention)
  // 0..1, detector-specific. mrgingham: 0.5^(pyramid level of its refinement), 1 = refined at full
  // resolution. opencv-sb / opencv-classic: 1 (no per-corner measure; see the screening flags). apriltag tag
  // corners: min(1, decision margin / 100) x 1 / (1 + (edge fit RMS / 0.2 px)^2); board corners of "both":
  // 1 when cornerSubPix converged within a quarter of its window of the prediction, else lower in proportion.
  double quality = 1;
  // "" = good; else why it is suspect ("outlier: 2.3 px from neighbours' homography", "near the image border").
  std::string flag;
};

// The random part of the refined corners' error: how far the refinement moves them when noise like the photo's own
// is added to the photo (detect_board.h MeasureSquareNoise, RefinementNoiseResponsePx). Sensor noise moves each
// corner independently; it cannot make a smooth error across the board, so the analysis's detector-systematic row
// bounds the smooth error by the scatter less this part (analysis/screen_fit.h FitOptions::smooth_bias_px).
// Measured for board corners refined by cornerSubPix (opencv-classic; opencv-sb and mrgingham under the auto
// prefilter) on photos whose refinement takes them from the photo itself (not where the board's display gaps or
// broadband texture set the refinement: point-sampled photos, whose "noise" is the display's own structure).
struct RefinementNoise {
  bool measured = false;
  std::string basis;  // what gave the noise: "black and white squares", or on white the moire spectrum's floor
  // The photo's noise on the board's squares, in gray levels of the photo's depth: standard deviation on black and
  // on white square interiors (about each interior's mean), their levels, the correlation of horizontally and
  // vertically adjacent pixels, and how many interiors of each colour.
  double black_sd = 0, white_sd = 0, black_level = 0, white_level = 0, correlation_lag1 = 0;
  int black_patches = 0, white_patches = 0;
  // The RMS per coordinate of the corners' displacement under the drawn noise, px (over corners and draws), and
  // how many corners (up to 120, evenly through the board) and draws measured it. response_u_px: its standard
  // uncertainty, from the spread of the corner-draws' mean squares (the standard error of their mean, which holds
  // the corners' differences; over 2 response_px, the delta method).
  double response_px = 0;
  double response_u_px = 0;
  int corners = 0, draws = 0;
};

// Why a detection found nothing (a typed outcome: callers branch on this, `Detection::failure` is for people).
enum class DetectionFailure {
  kNone,
  kPatternNotFound,       // no board or tags of the pattern (also a board that is not pattern.json's)
  kAmbiguousOrientation,  // a board is seen, but which corner is which cannot be decided
  kDifferentPattern,      // tags whose ids are not in pattern.json, or tags where pattern.json has a plain board
  kMirrored,              // the features map to the pattern with a reflection: a mirrored photo (handedness above)
};
// "pattern_not_found", "ambiguous_orientation", "different_pattern", "mirrored" ("" for kNone): for tables and
// JSON.
const char* DetectionFailureName(DetectionFailure failure);

struct Detection {
  std::string detector;                   // which detector produced the features
  std::vector<DetectedFeature> features;  // unique ids, all present in the pattern
  // "" on success; else "<category>: <details>" with the category one of "pattern not found" (also when a
  // board is seen but not the one of pattern.json), "ambiguous orientation", "different pattern" (tags whose
  // ids are not in pattern.json: "different pattern: ids not in pattern.json: ..."; tags where pattern.json has
  // a plain board), "mirrored" ("mirrored: the detected features map to the pattern with a reflection: the photo
  // is mirrored (...); turn mirroring off or flip the photo back ..."). Features are empty on failure.
  std::string failure;
  DetectionFailure failure_kind = DetectionFailure::kNone;  // set together with `failure`
  std::vector<std::string> notes;  // e.g. "orientation from the square colours", "12 of 144 corners not found"
  double time_ms = 0;              // wall time of DetectFeatures
  // The display-pixel moire measured in the photo (moire.h), the display's pitch in the photo and the prefilter
  // applied (filter_sigma_px: 0 = none); measured on every call, also when the detection fails.
  MoireMeasure moire;
  // The refinement's response to the photo's own noise (above); measured = false where it is not measured.
  RefinementNoise refinement_noise;
  // Tags: how far the border edges' 50% crossings sat inside the tags in the code values as they are, px (the
  // median over up to 24 tags), and the power that takes the code values to light, making it zero, with which the
  // tags were refined (detect_tags.h MeasureTagTone); NaN = not measured (fewer than 3 tags measured it, not tags).
  double tag_border_shift_px = std::nan("");
  double tag_tone_gamma = std::nan("");
};

// Photo file -> gray image, 8-bit (CV_8U) or 16-bit (CV_16U, precision kept). Colour photos are converted by
// ColourPhotoToGray (core/image_decode.h: luma, or the channel mean where the display's sub-pixels alias in
// colour), which says how in `conversion` if given. Throws Error(file, problem, fix) on missing, unreadable,
// truncated (PNG and JPEG end markers are checked) or empty images and on other pixel types.
cv::Mat ReadPhotoGray(const std::filesystem::path& path, GrayConversion* conversion = nullptr);
// The same from the bytes of a photo file (`source` names it in errors), with core's header checks and wording
// (DecodeImage) but without ReadPhotoGray's own truncation messages.
cv::Mat DecodePhotoGray(std::string_view bytes, const std::string& source, GrayConversion* conversion = nullptr);
// The note DetectionResult::notes carries for a colour photo converted by the channel mean ("" otherwise).
std::string GrayConversionNote(const GrayConversion& conversion);

// Detects the pattern of pattern.json in a photo (CV_8U or CV_16U, one channel). Never throws for a photo
// without the pattern or with a different one: it returns `failure` instead. Throws Error for invalid
// options, an unsupported image type, or a detector that cannot detect this pattern kind (apriltag on a plain
// checkerboard, a board detector on an apriltag grid, mrgingham on a board that is not N x N corners).
Detection DetectFeatures(const cv::Mat& photo_gray, const PatternFile& pattern, const DetectOptions& options);

// The handedness test of DetectFeatures (above): the determinant of the linear part A of the affine map fitted
// by least squares to the features' pattern_mm -> px, as det(A) / s1(A)^2 (s1 its larger singular value), in
// [-1, 1]. Negative for a photo of the front of the pattern (about -cos(tilt) at any roll), positive for
// a mirrored one; NaN for fewer than 3 features or collinear ones. DetectFeatures refuses a detection above
// +kMirroredHandedness. Throws Error for an id that is not in the pattern.
constexpr double kMirroredHandedness = 0.05;
double PatternHandedness(const std::vector<DetectedFeature>& features, const PatternFile& pattern);

// The outlier screening of DetectFeatures (above) on any features of `pattern` (e.g. merged from several
// detections): appends "outlier: ..." to the flags of inconsistent features; returns notes (features that
// could not be screened). Throws Error for an id that is not in the pattern.
std::vector<std::string> ScreenFeatures(std::vector<DetectedFeature>& features, const PatternFile& pattern,
                                        const DetectOptions& options);

}  // namespace curvecheck
