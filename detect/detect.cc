#include "detect/detect.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>

#include "detect/detect_board.h"
#include "detect/detect_tags.h"
#include "detect/pattern_info.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_decode.h"
#include "core/image_io.h"
#include "core/stopwatch.h"

namespace curvecheck {
namespace {

using detect_internal::CornerGrid;
using detect_internal::ApplyHomography;
using detect_internal::DetectedTag;
using detect_internal::FitHomography;
using detect_internal::PatternInfo;
using detect_internal::ReadPatternInfo;
using detect_internal::TagIdRanges;

constexpr Detector kDetectors[] = {Detector::kAuto, Detector::kMrgingham, Detector::kOpenCvSb,
                                   Detector::kOpenCvClassic, Detector::kAprilTag};

void AddFlag(DetectedFeature& f, const std::string& flag) { f.flag += (f.flag.empty() ? "" : "; ") + flag; }

// The kMirrored failure (detect.h); `detail` ("" or " (...)") says how it was seen.
void FailMirrored(Detection& out, const std::string& detail) {
  out.failure_kind = DetectionFailure::kMirrored;
  out.failure = "mirrored: the detected features map to the pattern with a reflection: the photo is mirrored (a "
                "webcam or phone mirror setting, or flipped in software); turn mirroring off or flip the photo "
                "back" +
                detail;
}

// PatternHandedness on pattern.json's coordinates; NaN if too few features.
double Handedness(const std::vector<DetectedFeature>& features, const PatternInfo& info) {
  std::vector<Eigen::Vector2d> plane, px;
  for (const DetectedFeature& f : features) {
    plane.push_back(info.pattern_mm.at(f.id));
    px.push_back(f.px);
  }
  return detect_internal::AffineHandedness(plane, px);
}

// Screening (detect.h): local homographies of each feature's neighbours in pattern coordinates.
void ScreenOutliers(std::vector<DetectedFeature>& features, const PatternInfo& info, const DetectOptions& o,
                    std::vector<std::string>& notes) {
  const size_t n = features.size();
  if (n < 6) {
    if (n > 0) notes.push_back(fmt::format("{} features: too few to screen for outliers", n));
    return;
  }
  std::vector<Eigen::Vector2d> plane(n);
  std::vector<std::string> group(n);  // a tag's own corners are not its neighbours
  for (size_t i = 0; i < n; ++i) {
    plane[i] = info.pattern_mm.at(features[i].id);
    const std::string& id = features[i].id;
    group[i] = id[0] == 't' ? id.substr(0, id.find('.')) : id;
  }
  std::vector<std::vector<size_t>> order(n);  // others by distance on the plane
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) {
      if (j != i && group[j] != group[i]) order[i].push_back(j);
    }
    std::sort(order[i].begin(), order[i].end(),
              [&](size_t a, size_t b) { return (plane[a] - plane[i]).squaredNorm() < (plane[b] - plane[i]).squaredNorm(); });
  }
  std::vector<bool> active(n, true);
  std::vector<double> residual(n);
  const size_t max_rounds = n / 4 + 1;
  size_t unscreened = 0;
  for (size_t round = 0; round < max_rounds; ++round) {
    unscreened = 0;
    std::vector<double> finite;
    for (size_t i = 0; i < n; ++i) {
      std::vector<Eigen::Vector2d> from, to;
      for (size_t j : order[i]) {
        if (!active[j]) continue;
        from.push_back(plane[j]);
        to.push_back(features[j].px);
        if (static_cast<int>(from.size()) == o.screen_neighbours) break;
      }
      const std::optional<Eigen::Matrix3d> h = from.size() >= 5 ? FitHomography(from, to) : std::nullopt;
      residual[i] = h ? (ApplyHomography(*h, plane[i]) - features[i].px).norm() : std::nan("");
      if (!h) ++unscreened;
      if (active[i] && std::isfinite(residual[i])) finite.push_back(residual[i]);
    }
    if (finite.empty()) break;
    std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
    const double sigma = 1.4826 * finite[finite.size() / 2];
    const double limit = std::max(o.outlier_sigmas * sigma, o.outlier_min_px);
    size_t worst = n;
    for (size_t i = 0; i < n; ++i) {
      if (active[i] && std::isfinite(residual[i]) && residual[i] > limit &&
          (worst == n || residual[i] > residual[worst])) {
        worst = i;
      }
    }
    if (worst == n) break;
    active[worst] = false;
    AddFlag(features[worst], fmt::format("outlier: {:.2f} px from its neighbours' homography (limit {:.2f} px)",
                                         residual[worst], limit));
  }
  if (unscreened > 0) {
    notes.push_back(fmt::format("{} features not screened (fewer than 5 neighbours for a homography)", unscreened));
  }
}

void FlagBorder(std::vector<DetectedFeature>& features, const cv::Mat& photo, double border_px) {
  for (DetectedFeature& f : features) {
    const double d = std::min({f.px.x() + 0.5, f.px.y() + 0.5, photo.cols - 0.5 - f.px.x(), photo.rows - 0.5 - f.px.y()});
    if (d < border_px) AddFlag(f, fmt::format("near the image border ({:.1f} px)", d));
  }
}

// 8-bit copy for the detectors (16-bit scaled so that its brightest pixel is 255).
cv::Mat To8Bit(const cv::Mat& photo) {
  if (photo.depth() == CV_8U) return photo;
  double max_value = 0;
  cv::minMaxLoc(photo, nullptr, &max_value);
  cv::Mat out;
  photo.convertTo(out, CV_8U, max_value > 0 ? 255.0 / max_value : 1.0);
  return out;
}

// The display's pixel pitch in the photo (camera px per display px): median over pairs of features of their
// image distance over their display distance (pattern.json display_px); 0 if there are too few.
double DisplayPitchPx(const std::vector<std::pair<std::string, Eigen::Vector2d>>& found, const PatternFile& pattern) {
  std::map<std::string, Eigen::Vector2d> display;
  for (const Feature& f : pattern.features) {
    if (f.display_px) display[f.id] = *f.display_px;
  }
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> pts;  // image, display
  const size_t step = std::max<size_t>(1, found.size() / 40);
  for (size_t i = 0; i < found.size(); i += step) {
    const auto it = display.find(found[i].first);
    if (it != display.end()) pts.emplace_back(found[i].second, it->second);
  }
  std::vector<double> ratios;
  for (size_t i = 0; i < pts.size(); ++i) {
    for (size_t j = i + 1; j < pts.size(); ++j) {
      const double d = (pts[i].second - pts[j].second).norm();
      if (d > 20) ratios.push_back((pts[i].first - pts[j].first).norm() / d);
    }
  }
  if (ratios.empty()) return 0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  return ratios[ratios.size() / 2];
}

// The median distance from each detected feature to its nearest neighbour, camera px (the square side of a board;
// a tag's side for tags); 0 with fewer than two features.
double FeatureSpacingPx(const std::vector<std::pair<std::string, Eigen::Vector2d>>& found) {
  std::vector<double> nearest;
  const size_t step = std::max<size_t>(1, found.size() / 60);
  for (size_t i = 0; i < found.size(); i += step) {
    double best = std::numeric_limits<double>::infinity();
    for (size_t j = 0; j < found.size(); ++j) {
      if (j != i) best = std::min(best, (found[i].second - found[j].second).norm());
    }
    if (std::isfinite(best) && best > 0) nearest.push_back(best);
  }
  if (nearest.empty()) return 0;
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  return nearest[nearest.size() / 2];
}

// The refinement's smoothing is at most this fraction of the feature spacing (RefineSigmaPx): its 3 sigma stay
// within a third of the way to the neighbouring corners.
constexpr double kMaxSigmaPerSpacing = 0.1;

// The prefilter of DetectOptions::prefilter_sigma_px, from the moire already measured in `out.moire`; sets
// out.moire.filter_sigma_px and says why in the notes.
void ChoosePrefilter(const DetectOptions& o, Detection& out) {
  MoireMeasure& m = out.moire;
  const std::string seen =
      m.patches == 0 ? "moire not measured (no bright area of the photo is large enough)"
                     : fmt::format("moire {}: contrast {:.1f}% at a period of {:.2f} px ({:.0f} x the noise floor; "
                                   "limits {:.1f}%, {:.0f}x; {} patches)",
                                   m.present ? "present" : "absent", 100 * m.contrast, m.period_px, m.peak_to_floor,
                                   100 * o.moire.min_contrast, o.moire.min_peak_to_floor, m.patches);
  if (o.prefilter_sigma_px >= 0) {
    m.filter_sigma_px = o.prefilter_sigma_px;
    out.notes.push_back(fmt::format("{}; prefilter sigma {:.2f} px as set", seen, m.filter_sigma_px));
    return;
  }
  // The broadband texture (moire.h), beside the periodic components.
  const std::string texture =
      m.patches == 0 ? ""
                     : fmt::format("; texture {:.1f}% of the white level (limit {:.0f}%{})", 100 * m.texture,
                                   100 * o.moire.texture_limit,
                                   m.texture_sigma_px > 0
                                       ? fmt::format(": sigma {:.2f} px brings it to {:.0f}%", m.texture_sigma_px,
                                                     100 * o.moire.residual_texture)
                                       : "");
  if (!m.present && !(m.texture_sigma_px > 0)) {
    m.filter_sigma_px = 0;
    out.notes.push_back(seen + texture + "; no prefilter");
    return;
  }
  constexpr double kMaxSigmaPx = 10;  // DetectOptions::Check's limit
  const bool by_texture = m.texture_sigma_px > m.needed_sigma_px;
  const double wanted = std::max(m.needed_sigma_px, m.texture_sigma_px);
  m.filter_sigma_px = std::min(wanted, kMaxSigmaPx);
  std::string components;
  for (size_t i = 0; i < m.components.size() && i < 4; ++i) {
    components += fmt::format("{}{:.1f}% at {:.2f} px", i == 0 ? "" : ", ", 100 * m.components[i].contrast,
                              m.components[i].period_px);
  }
  out.notes.push_back(fmt::format(
      "{}{}; {} component(s) above the limits{}; corners detected and refined on a Gaussian-smoothed copy (sigma "
      "{:.2f} px, set by {}){}",
      seen, texture, m.components.size(), components.empty() ? "" : " (" + components + ")", m.filter_sigma_px,
      by_texture ? std::string("the texture") : fmt::format("the period {:.2f} px", m.limiting_period_px),
      wanted > kMaxSigmaPx ? fmt::format(" (capped: {:.1f} px wanted)", wanted) : ""));
}

// The refinement's smoothing: in auto, the larger of the moire's (ChoosePrefilter) and 2 x the display's pitch in
// the photo when that exceeds 0.5 camera px. The second is kept from before the moire was measured: where the
// camera resolves the display's pixels, the pattern's anti-aliased edges are staircases of display pixels even
// without gaps between them, and smoothing over them helps (docs/bench/moire.txt, fill 1: 0.137 px RMS without,
// 0.019 px with sigma 3.3 px at 1.67 camera px per display px). Sets out.moire.display_pitch_px and
// filter_sigma_px (the sigma used for the refinement).
double RefineSigmaPx(const std::vector<std::pair<std::string, Eigen::Vector2d>>& found, const PatternFile& pattern,
                     const DetectOptions& o, Detection& out) {
  MoireMeasure& m = out.moire;
  m.display_pitch_px = DisplayPitchPx(found, pattern);
  if (o.prefilter_sigma_px >= 0) return m.filter_sigma_px;
  const double pitch = m.display_pitch_px;
  if (pitch > 0.5 && 2 * pitch > m.filter_sigma_px) {
    m.filter_sigma_px = std::min(2 * pitch, 10.0);
    out.notes.push_back(fmt::format("display pixels are {:.2f} px in the photo: corners refined on a Gaussian-smoothed "
                                    "copy (sigma {:.2f} px, 2 x the pitch) against their staircase edges",
                                    pitch, m.filter_sigma_px));
  }
  // The cap: a symmetric blur leaves an X-corner in place only while the kernel sees straight edges through it;
  // once it reaches the neighbouring corners, whose layout perspective and the screen's curvature make
  // asymmetric, it moves the corner by an amount that varies smoothly over the screen, which richer screen
  // models then take for shape. Measured (default scene at quarter resolution, 1.5 m, 30 deg yaw, a jittered pose
  // whose moire the photo shows at 19.8% contrast and a 10.67 px period): the auto sigma 4.61 px left the
  // cylinder 0.134 px of residual noise (inadequate; varying-curvature-quadratic chosen, R 927.6 mm against 1000),
  // sigma 0 or 1 px 0.035 and 0.020 px (cylinder, R 999.2-999.3 +- 0.6 mm). A long-period moire is a slow
  // shading across a corner's window, not a texture in it, and needs no kernel that wide.
  const double spacing = FeatureSpacingPx(found);
  if (spacing > 0 && m.filter_sigma_px > kMaxSigmaPerSpacing * spacing) {
    const double wanted = m.filter_sigma_px;
    m.filter_sigma_px = kMaxSigmaPerSpacing * spacing;
    out.notes.push_back(fmt::format("refinement sigma capped at {:.2f} px ({:g} x the feature spacing {:.1f} px; "
                                    "{:.2f} px wanted): a wider kernel reaches the neighbouring corners and biases "
                                    "the corner",
                                    m.filter_sigma_px, kMaxSigmaPerSpacing, spacing, wanted));
  }
  return m.filter_sigma_px;
}

// Why a board detector found nothing: tags instead, another board size, or nothing at all. Sets the failure
// and its kind.
void DiagnoseBoardFailure(const cv::Mat& gray8, const PatternInfo& info, const std::string& detector,
                          Detection& out) {
  const std::vector<DetectedTag> tags = detect_internal::RunAprilTag(gray8, 2, 0, 0);
  out.failure_kind = DetectionFailure::kPatternNotFound;
  if (!tags.empty()) {
    std::set<int> ids;
    for (const DetectedTag& t : tags) ids.insert(t.id);
    out.failure_kind = DetectionFailure::kDifferentPattern;
    out.failure = fmt::format("different pattern: the photo shows tag36h11 tags ({}), not the {}x{} checkerboard of "
                       "pattern.json",
                       TagIdRanges(ids), info.cols, info.rows);
    return;
  }
  if (detect_internal::FindAnyBoardSize(gray8)) {
    out.failure = fmt::format("pattern not found: the photo shows a checkerboard, but no complete one of {}x{} inner "
                       "corners ({}): a different pattern, or part of it outside the photo?",
                       info.cols - 1, info.rows - 1, detector);
    return;
  }
  out.failure = fmt::format("pattern not found: no checkerboard of {}x{} inner corners ({})", info.cols - 1,
                     info.rows - 1, detector);
}

// The refinement's gap closing (RefineXCorners): the parallelogram of this fraction of the board's edge vectors
// (at most 1: the black square holds it). RMS against the truth per coordinate on five point-sampled photos (fill
// 0.7 and 0.85, 1 m, 2400 x 1600; docs/bench/validity_bench.txt, twenty-ninth section): 0.30-0.80 px at 0.5,
// 0.27-0.42 px at 0.75, 0.29-0.39 px at 0.9.
constexpr double kGapClosingPerSpacing = 0.75;

// One board detector, oriented and named; false with `failure` set if it found nothing usable.
// `unmirrored_alternative`: ResolveBoardOrientation's, for the text of a mirrored naming. `retry_unsmoothed`: where the
// auto prefilter's copy hides the board from the coarse search, search the photo itself too (auto passes false for
// opencv-classic, so that opencv-sb on the prefiltered copy comes first, as before the retry). The refinement's
// response to the photo's own noise (detect.h RefinementNoise), on the refined grid: not where the display's structure
// set the refinement (the texture's prefilter, corners refined on closed patches: there the "noise" on the white
// squares is the display's, and the photo's own noise is not what moves the corners); where moire is present or the
// camera resolves the display's pixels the white squares' spread holds them (not random), and the white's noise is the
// moire measurement's broadband floor where that is smaller. Four draws on up to 120 corners (seeded by the grid's
// size: the same photo gives the same figure).
void MeasureRefinementNoise(const cv::Mat& photo, const detect_internal::CornerGrid& grid, double sigma_px,
                            const DetectOptions& o, Detection& out) {
  const MoireMeasure& m = out.moire;
  if (!o.measure_refinement_noise || m.texture_sigma_px > 0 || m.refined_on_closed_patches) return;
  RefinementNoise noise = detect_internal::MeasureSquareNoise(photo, grid);
  if (!noise.measured) return;
  const bool resolved = m.display_pitch_px > 0.5;  // RefineSigmaPx: the camera resolves the display's pixels
  noise.basis = "black and white squares";
  if (m.present || resolved) {
    // The white squares' spread holds the display's structure; their noise is the moire measurement's broadband
    // floor (the spectrum's median bin, without the periodic peaks: moire.h), where that is the smaller.
    const double floor_sd = m.texture * m.white_level;
    const bool by_floor = m.patches > 0 && floor_sd > 0 && floor_sd < noise.white_sd;
    if (by_floor) noise.white_sd = floor_sd;
    noise.basis = fmt::format("black squares; on white {}: the white squares' spread holds the display's {}, which is "
                              "not random",
                              by_floor ? "the broadband floor of the moire measurement's spectrum" : "their spread",
                              resolved ? "pixels, which the camera resolves" : "moire");
  }
  constexpr int kDraws = 4;
  detect_internal::MeasureRefinementNoise(photo, grid, sigma_px, kDraws,
                                          0x5EED0000ull + static_cast<uint64_t>(grid.px.size()), noise);
  if (noise.corners == 0) return;
  out.refinement_noise = noise;
  out.notes.push_back(fmt::format(
      "the photo's noise on the board's squares: sd {:.2f} on black, {:.2f} on white (levels {:.1f}, {:.1f}; {} and "
      "{} interiors), adjacent-pixel correlation {:.2f}; drawn {} times ({}), it moves the refined corners by {:.4f} "
      "px RMS per coordinate (the random part of their error)",
      noise.black_sd, noise.white_sd, noise.black_level, noise.white_level, noise.black_patches, noise.white_patches,
      noise.correlation_lag1, kDraws, noise.basis, noise.response_px));
}

bool DetectBoard(const std::string& detector, const cv::Mat& photo, const cv::Mat& gray8, const PatternFile& pattern,
                 const PatternInfo& info, const DetectOptions& o, Detection& out, std::string& unmirrored_alternative,
                 bool retry_unsmoothed) {
  const cv::Size inner(info.cols - 1, info.rows - 1);
  std::optional<CornerGrid> grid;
  cv::Mat coarse_input = gray8;
  // The whole photo smoothed for the coarse detector: against measured moire (auto) for every detector (the
  // classic one misses boards in strong moire), an explicit sigma for opencv-sb and mrgingham.
  const double sigma = out.moire.filter_sigma_px;
  if (sigma > 0 && (detector != "opencv-classic" || o.prefilter_sigma_px < 0)) {
    // Into a new image: gray8 may share the caller's photo (To8Bit), which must not be smoothed in place.
    cv::Mat smoothed;
    cv::GaussianBlur(gray8, smoothed, cv::Size(0, 0), sigma);
    coarse_input = smoothed;
  }
  const auto search = [&](const cv::Mat& image) {
    if (detector == "mrgingham") return detect_internal::RunMrgingham(image, inner.width);
    if (detector == "opencv-sb") return detect_internal::RunOpenCvSb(image, inner, o.sb_accuracy);
    return detect_internal::RunOpenCvClassic(image, inner, o.classic_max_px);
  };
  grid = search(coarse_input);
  // The measured moire's prefilter (auto) can hide a small board from the coarse search: on the validity bench's
  // quarter-resolution photos from 3 m at 40 deg (squares of 7-12 px, sigma 2-3.3 px) opencv-sb missed it in 23 of
  // 60 trials and found it in all 23 on the photo itself. The search is repeated there; the refinement keeps its
  // own sigma (capped by the feature spacing, below). A stated prefilter is the user's and is not undone.
  if (!grid && retry_unsmoothed && sigma > 0 && o.prefilter_sigma_px < 0) {
    grid = search(gray8);
    if (grid) {
      out.notes.push_back(fmt::format("the coarse search ({}) found the board only without the moire prefilter "
                                      "(sigma {:.2f} px hid it); the corners are refined as usual",
                                      detector, sigma));
    }
  }
  // The image the board was found on: its square colours name the corners (ResolveBoardOrientation).
  cv::Mat found_on = gray8;
  // Where the display's gaps darken the bright areas (detect_board.h; measured on the whole photo), the search is
  // repeated on closings of it, which fill them.
  if (!grid && retry_unsmoothed && o.prefilter_sigma_px < 0) {
    const detect_internal::GapDeficit gaps = detect_internal::MeasureGapDeficit(gray8, cv::Rect(0, 0, gray8.cols,
                                                                                                 gray8.rows));
    if (gaps.measured) out.moire.photo_gap_deficit = gaps.deficit;
    if (gaps.measured && gaps.deficit >= kGapDeficitLimit) {
      int k = 0;
      grid = detect_internal::SearchOnClosings(gray8, search, found_on, k);
      if (grid) out.moire.found_on_closing_px = k;
      out.notes.push_back(
          grid ? fmt::format("the coarse search ({}) found the board only on a gray closing of the photo ({} x {} "
                             "px), where the display's gaps darken the photo's bright areas by {:.1f}% on average "
                             "(limit {:.0f}%): aliased, they cross the squares as dark bands",
                             detector, k, k, 100 * gaps.deficit, 100 * kGapDeficitLimit)
               : fmt::format("the display's gaps darken the photo's bright areas by {:.1f}% on average (limit "
                             "{:.0f}%); the coarse search ({}) found no board on gray closings of it either",
                             100 * gaps.deficit, 100 * kGapDeficitLimit, detector));
    }
  }
  if (!grid) {
    out.failure_kind = DetectionFailure::kPatternNotFound;
    out.failure = fmt::format("pattern not found: no checkerboard of {}x{} inner corners ({})", inner.width,
                              inner.height, detector);
    return false;
  }
  const detect_internal::BoardOrientation orient =
      detect_internal::ResolveBoardOrientation(*grid, found_on, info.cols, info.rows, o.upright_max_deg);
  if (!orient.failure.empty()) {
    out.failure = orient.failure;
    out.failure_kind = DetectionFailure::kAmbiguousOrientation;
    return false;
  }
  out.notes.push_back(orient.note);
  unmirrored_alternative = orient.unmirrored_alternative;
  // Refined: opencv-classic's corners always; opencv-sb's and mrgingham's under the auto prefilter, as they locate
  // the corners on the smoothed copy itself and their own localisation carries a structured error: refined as
  // opencv-classic's, at RefineSigmaPx's sigma (capped). Measured on issue 16's validity trials (default scene's
  // realistic camera, quarter resolution, 1.5 m, 30 deg yaw, opencv-sb used where classic failed in moire): with a
  // 4.6 px auto prefilter the cylinder's residual noise was 0.134 px against 0.016 refined at the cap
  // (Detect.WidePrefilterIsCappedByTheFeatureSpacing); with a 2.1 px one, no cap, 0.079 px against 0.018 refined
  // (seed 20: varying-curvature-quadratic at R 966.9 mm before, the cylinder at 1000.3 +- 0.6 after).
  if (detector == "opencv-classic" || o.prefilter_sigma_px < 0) {
    std::vector<std::pair<std::string, Eigen::Vector2d>> coarse;
    for (size_t d = 0; d < grid->px.size(); ++d) {
      coarse.emplace_back(fmt::format("c{}", orient.corner_index[d]), Eigen::Vector2d(grid->px[d].x, grid->px[d].y));
    }
    const double sigma_px = RefineSigmaPx(coarse, pattern, o, out);
    if (o.prefilter_sigma_px < 0) {
      // The display's gaps on the board (detect_board.h), reported: result.json detection.moire.gap_deficit.
      const detect_internal::GapDeficit gaps =
          detect_internal::MeasureGapDeficit(photo, *grid, FeatureSpacingPx(coarse));
      out.moire.gap_deficit = gaps.measured ? gaps.deficit : -1;
      // Where the gaps darken the board's bright areas beyond the limit, the corners are refined twice: on the photo
      // and on patches closed along the board's edges (detect_board.h ClosedAlongEdges, the parallelogram of
      // kGapClosingPerSpacing of the edge vectors), which fills the gaps and keeps the X-corner. The set that
      // scatters less about a smooth grid is kept (GridRoughnessPx): a point-sampled photo's aliased gaps cross the
      // squares as dark bands and speckle that the capped Gaussian cannot average away, and the closed patches win
      // there (an independent tracer's one-ray photos at fill 0.7: docs/bench/validity_bench.txt, thirty-second
      // section); where the camera resolves the gaps the Gaussian already removes them and the photo wins
      // (Detect.MoireMeasuredAndFilteredBackToTheCleanError). Refined on closed patches, the corners carry a
      // smooth remainder of the moire that a richer screen model took for shape before the model choice's strip
      // veto (twenty-ninth and thirty-first sections).
      if (gaps.measured && gaps.deficit >= kGapDeficitLimit) {
        CornerGrid closed = *grid;
        detect_internal::RefineXCorners(photo, sigma_px, *grid);
        detect_internal::RefineXCorners(photo, sigma_px, closed, kGapClosingPerSpacing);
        const double rough_photo = detect_internal::GridRoughnessPx(*grid);
        const double rough_closed = detect_internal::GridRoughnessPx(closed);
        out.moire.refined_on_closed_patches = rough_closed < rough_photo;
        if (out.moire.refined_on_closed_patches) *grid = std::move(closed);
        out.notes.push_back(fmt::format(
            "the display's gaps darken the board's bright areas by {:.1f}% (limit {:.0f}%): the corners refined on "
            "the photo scatter by {:.3f} px about a smooth grid, on patches closed along the board's edges ({:g} x "
            "the corner spacing) by {:.3f} px; those on the {} are kept",
            100 * gaps.deficit, 100 * kGapDeficitLimit, rough_photo, kGapClosingPerSpacing, rough_closed,
            out.moire.refined_on_closed_patches ? "closed patches" : "photo"));
      } else {
        detect_internal::RefineXCorners(photo, sigma_px, *grid);
      }
    } else {
      detect_internal::RefineXCorners(photo, sigma_px, *grid);
    }
    MeasureRefinementNoise(photo, *grid, sigma_px, o, out);
  }
  out.features.clear();
  for (size_t d = 0; d < grid->px.size(); ++d) {
    DetectedFeature f;
    f.id = fmt::format("c{}", orient.corner_index[d]);
    f.px = Eigen::Vector2d(grid->px[d].x, grid->px[d].y);
    f.quality = grid->quality[d];
    out.features.push_back(std::move(f));
  }
  std::sort(out.features.begin(), out.features.end(), [](const DetectedFeature& a, const DetectedFeature& b) {
    return std::stoi(a.id.substr(1)) < std::stoi(b.id.substr(1));
  });
  return true;
}

// Board corners of kind "both", predicted from the nearest tags and refined by cornerSubPix inside the clean
// X-junction (the tags' borders are 1/6 of a square from each corner).
void BoardCornersFromTags(const cv::Mat& photo, double sigma_px, const std::vector<DetectedTag>& tags,
                          const PatternInfo& info, Detection& out) {
  struct TagOnPlane {
    const DetectedTag* tag;
    Eigen::Vector2d centre_mm;
  };
  std::vector<TagOnPlane> placed;
  for (const DetectedTag& t : tags) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (int k = 0; k < 4; ++k) c += info.pattern_mm.at(fmt::format("t{}.{}", t.id, k)) / 4;
    placed.push_back({&t, c});
  }
  int predicted = 0, refused = 0;
  for (int k = 0; k < (info.cols - 1) * (info.rows - 1); ++k) {
    const std::string id = fmt::format("c{}", k);
    const Eigen::Vector2d p = info.pattern_mm.at(id);
    std::vector<const TagOnPlane*> near;
    for (const TagOnPlane& t : placed) {
      if ((t.centre_mm - p).norm() < 2.0 * info.square_mm) near.push_back(&t);
    }
    std::sort(near.begin(), near.end(), [&](const TagOnPlane* a, const TagOnPlane* b) {
      return (a->centre_mm - p).norm() < (b->centre_mm - p).norm();
    });
    if (near.size() > 4) near.resize(4);
    std::vector<Eigen::Vector2d> from, to;
    for (const TagOnPlane* t : near) {
      for (int c = 0; c < 4; ++c) {
        from.push_back(info.pattern_mm.at(fmt::format("t{}.{}", t->tag->id, c)));
        to.push_back(t->tag->px[static_cast<size_t>(c)]);
      }
    }
    const std::optional<Eigen::Matrix3d> h = FitHomography(from, to);
    if (!h) continue;
    const Eigen::Vector2d guess = ApplyHomography(*h, p);
    const double square_px = std::min((ApplyHomography(*h, p + Eigen::Vector2d(info.square_mm, 0)) - guess).norm(),
                                      (ApplyHomography(*h, p + Eigen::Vector2d(0, info.square_mm)) - guess).norm());
    const int half = std::clamp(static_cast<int>(std::floor(0.12 * square_px)), 2, 30);
    if (guess.x() < half + 1 || guess.y() < half + 1 || guess.x() > photo.cols - half - 2 ||
        guess.y() > photo.rows - half - 2) {
      continue;
    }
    ++predicted;
    const cv::Point2d r = detect_internal::RefineXCorner(photo, sigma_px, cv::Point2d(guess.x(), guess.y()), half);
    const Eigen::Vector2d refined(r.x, r.y);
    const double moved = (refined - guess).norm();
    if (!refined.allFinite() || moved > half) {
      ++refused;
      continue;
    }
    DetectedFeature f;
    f.id = id;
    f.px = refined;
    f.quality = moved <= 0.25 * half ? 1.0 : std::max(0.0, 1 - (moved - 0.25 * half) / (0.75 * half));
    out.features.push_back(std::move(f));
  }
  if (refused > 0) {
    out.notes.push_back(fmt::format("{} of {} board corners predicted from the tags did not converge (dropped)",
                                    refused, predicted));
  }
}

// No tag of the pattern decodes in the photo. A mirrored tag never does (detect.h, handedness): look for them in
// the photo flipped left to right; if they are there, their corners mapped back to the photo name the pattern
// with a reflection, and the detection fails with kMirrored. False if no tag of the pattern decodes there either.
bool MirroredTags(const cv::Mat& gray8, const PatternInfo& info, const DetectOptions& o, Detection& out) {
  cv::Mat flipped;
  cv::flip(gray8, flipped, 1);
  std::set<int> ids;
  std::vector<Eigen::Vector2d> plane, px;
  for (const DetectedTag& t :
       detect_internal::RunAprilTag(flipped, o.apriltag_decimate, o.apriltag_max_hamming, o.apriltag_threads)) {
    if (!info.tag_ids.count(t.id) || !ids.insert(t.id).second) continue;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d& p = t.px[static_cast<size_t>(k)];
      plane.push_back(info.pattern_mm.at(fmt::format("t{}.{}", t.id, k)));
      px.emplace_back(gray8.cols - 1 - p.x(), p.y());
    }
  }
  const double handedness = detect_internal::AffineHandedness(plane, px);
  if (!(handedness > kMirroredHandedness)) return false;
  FailMirrored(out, fmt::format(" (no tag of pattern.json decodes in the photo; {} of them ({}) decode in it flipped "
                                "left to right, handedness {:+.2f})",
                                ids.size(), TagIdRanges(ids), handedness));
  return true;
}

void DetectTags(const cv::Mat& photo, const cv::Mat& gray8, const PatternFile& pattern, const PatternInfo& info,
                const DetectOptions& o, Detection& out) {
  std::vector<DetectedTag> found =
      detect_internal::RunAprilTag(gray8, o.apriltag_decimate, o.apriltag_max_hamming, o.apriltag_threads);
  const bool any_of_pattern = std::any_of(found.begin(), found.end(), [&](const DetectedTag& t) {
    return info.tag_ids.count(t.id) > 0;
  });
  if (!any_of_pattern && MirroredTags(gray8, info, o, out)) return;
  if (found.empty()) {
    out.failure = "pattern not found: no tag36h11 tag in the photo";
    out.failure_kind = DetectionFailure::kPatternNotFound;
    return;
  }
  std::map<int, DetectedTag> by_id;
  std::set<int> foreign, doubled;
  for (const DetectedTag& t : found) {
    if (!info.tag_ids.count(t.id)) {
      foreign.insert(t.id);
      continue;
    }
    auto [it, inserted] = by_id.emplace(t.id, t);
    if (!inserted) {
      doubled.insert(t.id);
      if (t.decision_margin > it->second.decision_margin) it->second = t;
    }
  }
  if (by_id.empty()) {
    out.failure_kind = DetectionFailure::kDifferentPattern;
    out.failure = fmt::format("different pattern: ids not in pattern.json: the photo shows tags {}, pattern.json "
                              "has tags {}",
                              TagIdRanges(foreign), TagIdRanges(info.tag_ids));
    return;
  }
  if (!foreign.empty()) {
    out.notes.push_back(fmt::format("ignored tags not in pattern.json: {}", TagIdRanges(foreign)));
  }
  if (!doubled.empty()) {
    out.notes.push_back(fmt::format("tags seen more than once (kept the strongest): {}", TagIdRanges(doubled)));
  }
  std::vector<std::pair<std::string, Eigen::Vector2d>> coarse;
  for (const auto& [id, t] : by_id) {
    for (int k = 0; k < 4; ++k) coarse.emplace_back(fmt::format("t{}.{}", id, k), t.px[static_cast<size_t>(k)]);
  }
  const double sigma = RefineSigmaPx(coarse, pattern, o, out);
  // The photo's tone curve from its tags' borders (detect_tags.h MeasureTagTone): the refinement reads the edges
  // in light, where neither the 50% crossing nor the smoothing against moire moves them.
  double gamma = 1;
  if (o.refine_tags && o.tag_tone_from_borders) {
    std::vector<DetectedTag> all;
    for (const auto& [id, t] : by_id) all.push_back(t);
    const detect_internal::TagTone tone = detect_internal::MeasureTagTone(photo, all);
    out.tag_border_shift_px = tone.shift_px;
    if (std::isfinite(tone.gamma)) {
      gamma = tone.gamma;
      out.tag_tone_gamma = gamma;
      std::string ladder;
      for (const auto& [g, b] : tone.ladder) ladder += fmt::format("{}{:.3f} px at {:.1f}", ladder.empty() ? "" : ", ", b, g);
      out.notes.push_back(fmt::format(
          "tag borders: the outer edges' 50% crossings sat {:.3f} px inside the tags (median of {} tags: their "
          "borders measured a cell less twice that beside white data cells), the shift of a tone curve; the "
          "code values taken to light by the power {:.2f} that makes it zero ({}) before the refinement",
          tone.shift_px, tone.tags, gamma, ladder));
    } else {
      out.notes.push_back("tag borders: the tone curve's shift could not be measured (fewer than 3 tags with cells of 4 "
                          "px and 2.5 edge widths beside white data cells); the code values are read as light");
    }
  }
  std::vector<DetectedTag> tags;
  int unrefined = 0;
  for (auto& [id, t] : by_id) {
    if (o.refine_tags && !detect_internal::RefineTagCorners(photo, t, sigma, gamma)) ++unrefined;
    tags.push_back(t);
  }
  double least = sigma, most = 0;
  for (const DetectedTag& t : tags) {
    if (t.edge_rms_px < 0) continue;  // not refined
    least = std::min(least, t.smoothing_px);
    most = std::max(most, t.smoothing_px);
  }
  if (o.refine_tags && sigma > 0 && least < sigma) {
    out.notes.push_back(fmt::format("tags refined on a smoothing of {:.2f}-{:.2f} px instead of {:.2f}: at most a sixth "
                                    "of their cell, so that it does not join the border's two edges",
                                    least, most, sigma));
  }
  if (unrefined > 0) {
    out.notes.push_back(fmt::format("{} of {} tags kept the detector's corners (border edges too small or cut by "
                                    "the image edge)",
                                    unrefined, tags.size()));
  }
  for (const DetectedTag& t : tags) {
    const double margin_quality = std::min(1.0, t.decision_margin / 100);
    const double edge_quality = t.edge_rms_px >= 0 ? 1 / (1 + std::pow(t.edge_rms_px / 0.2, 2)) : 1.0;
    for (int k = 0; k < 4; ++k) {
      DetectedFeature f;
      f.id = fmt::format("t{}.{}", t.id, k);
      f.px = t.px[static_cast<size_t>(k)];
      f.quality = margin_quality * edge_quality;
      if (t.hamming > 0) AddFlag(f, fmt::format("tag decoded with {} corrected bit(s)", t.hamming));
      out.features.push_back(std::move(f));
    }
  }
  if (info.kind == "both") BoardCornersFromTags(photo, sigma, tags, info, out);
}

}  // namespace

std::vector<std::string> ScreenFeatures(std::vector<DetectedFeature>& features, const PatternFile& pattern,
                                        const DetectOptions& options) {
  options.Check("detect options");
  const PatternInfo info = ReadPatternInfo(pattern);
  std::set<std::string> seen;
  for (const DetectedFeature& f : features) {
    if (!info.pattern_mm.count(f.id)) {
      throw Error("features", fmt::format("id '{}' is not in pattern.json", f.id), "screen features of this pattern only");
    }
    if (!seen.insert(f.id).second) {
      throw Error("features", fmt::format("id '{}' appears twice", f.id), "screen one detection per photo");
    }
  }
  std::vector<std::string> notes;
  ScreenOutliers(features, info, options, notes);
  return notes;
}

double PatternHandedness(const std::vector<DetectedFeature>& features, const PatternFile& pattern) {
  const PatternInfo info = ReadPatternInfo(pattern);
  for (const DetectedFeature& f : features) {
    if (!info.pattern_mm.count(f.id)) {
      throw Error("features", fmt::format("id '{}' is not in pattern.json", f.id), "give features of this pattern");
    }
  }
  return Handedness(features, info);
}

const char* DetectorName(Detector detector) {
  switch (detector) {
    case Detector::kAuto: return "auto";
    case Detector::kMrgingham: return "mrgingham";
    case Detector::kOpenCvSb: return "opencv-sb";
    case Detector::kOpenCvClassic: return "opencv-classic";
    case Detector::kAprilTag: return "apriltag";
  }
  return "auto";
}

Detector ParseDetector(const std::string& name, const std::string& where) {
  for (Detector d : kDetectors) {
    if (name == DetectorName(d)) return d;
  }
  throw Error(where, fmt::format("detector '{}' is not known", name),
              "use auto, mrgingham, opencv-sb, opencv-classic or apriltag");
}

void DetectOptions::Check(const std::string& where) const {
  const auto range = [&](const char* name, double v, double lo, double hi, const char* fix) {
    RequireInRange(where, name, v, lo, hi, fix);
  };
  range("apriltag_decimate", apriltag_decimate, 1, 8, "use 1 (full resolution) to 8; 2 is the default");
  range("apriltag_max_hamming", apriltag_max_hamming, 0, 2, "use 0, 1 or 2 (larger needs gigabytes of tables)");
  range("apriltag_threads", apriltag_threads, 0, 256, "use 0 for all cores");
  if (classic_max_px != 0) range("classic_max_px", classic_max_px, 200, 1e6, "use 0 (full resolution) or >= 200");
  if (prefilter_sigma_px != -1) {
    range("prefilter_sigma_px", prefilter_sigma_px, 0, 10, "use -1 (auto), 0 (none) or a sigma in px up to 10");
  }
  range("upright_max_deg", upright_max_deg, 1e-9, 45, "use an angle in (0, 45] deg, e.g. 40");
  range("screen_neighbours", screen_neighbours, 5, 100, "use 5..100, e.g. 8");
  range("outlier_sigmas", outlier_sigmas, 1e-9, 1e6, "use a positive number of sigmas, e.g. 5");
  range("outlier_min_px", outlier_min_px, 0, 1e6, "use a non-negative number of px, e.g. 0.5");
  range("border_px", border_px, 0, 1e6, "use a non-negative number of px, e.g. 4");
  moire.Check(where + ": moire");
}

cv::Mat DecodePhotoGray(std::string_view bytes, const std::string& source, GrayConversion* conversion) {
  const std::filesystem::path path(source);
  cv::Mat img = DecodeImage(bytes, source);  // header, size cap (200 Mpx), then OpenCV; keeps 16 bits
  if (img.depth() != CV_8U && img.depth() != CV_16U) {
    throw Error(path.string(), "has an unsupported pixel type (not 8 or 16 bit integers)",
                "give an 8 or 16 bit photo");
  }
  // Into a new Mat (a conversion in place first copies the whole colour image: 72 MB at 24 MP, a sixth of
  // `analyze`'s time in a profile, issue 18).
  img = ColourPhotoToGray(img, conversion);
  if (img.channels() != 1) {
    throw Error(path.string(), fmt::format("has {} channels", img.channels()), "give a gray or colour photo");
  }
  return img;
}

std::string GrayConversionNote(const GrayConversion& c) {
  if (!c.channel_mean) return "";
  return fmt::format(
      "colour aliasing: luma - the channel mean varies by {:.1f}% of the white level over the bright areas (limit "
      "{:.0f}%): the display's R, G, B sub-pixels alias in colour, so the photo was turned gray by the channel mean, "
      "which cancels that, instead of luma",
      100 * c.chroma_texture, 100 * kColourAliasingLimit);
}

cv::Mat ReadPhotoGray(const std::filesystem::path& path, GrayConversion* conversion) {
  const std::string bytes = ReadFileToString(path);
  if (bytes.empty()) throw Error(path.string(), "is empty (0 bytes)", "give a photo (PNG, JPEG, TIFF)");
  const auto starts = [&](std::string_view magic) { return bytes.compare(0, magic.size(), magic) == 0; };
  const std::string_view tail = std::string_view(bytes).substr(bytes.size() - std::min<size_t>(bytes.size(), 1024));
  if (starts("\x89PNG") && tail.find("IEND") == std::string_view::npos) {
    throw Error(path.string(), "is a truncated PNG (no IEND chunk at its end)", "copy the photo again");
  }
  if (starts("\xFF\xD8") && tail.find("\xFF\xD9") == std::string_view::npos) {
    throw Error(path.string(), "is a truncated JPEG (no end-of-image marker)", "copy the photo again");
  }
  return DecodePhotoGray(bytes, path.string(), conversion);
}

const char* DetectionFailureName(DetectionFailure failure) {
  switch (failure) {
    case DetectionFailure::kNone: return "";
    case DetectionFailure::kPatternNotFound: return "pattern_not_found";
    case DetectionFailure::kAmbiguousOrientation: return "ambiguous_orientation";
    case DetectionFailure::kDifferentPattern: return "different_pattern";
    case DetectionFailure::kMirrored: return "mirrored";
  }
  return "";
}

Detection DetectFeatures(const cv::Mat& photo_gray, const PatternFile& pattern, const DetectOptions& options) {
  const Stopwatch watch;
  options.Check("detect options");
  if (photo_gray.empty() || photo_gray.channels() != 1 ||
      (photo_gray.depth() != CV_8U && photo_gray.depth() != CV_16U) || photo_gray.cols < 8 || photo_gray.rows < 8) {
    throw Error("photo", fmt::format("is a {}x{} image with {} channel(s) of type {}", photo_gray.cols,
                                     photo_gray.rows, photo_gray.channels(), photo_gray.depth()),
                "give a gray 8 or 16 bit photo of at least 8x8 px (ReadPhotoGray)");
  }
  const PatternInfo info = ReadPatternInfo(pattern);
  const bool board_kind = info.kind != "apriltag", tag_kind = info.kind != "checkerboard";
  std::string detector = DetectorName(options.detector);
  if (options.detector == Detector::kAuto) detector = tag_kind ? "apriltag" : "opencv-classic";
  if (detector == "apriltag" && !tag_kind) {
    throw Error("detector", "apriltag cannot detect a plain checkerboard (pattern.json has no tags)",
                "use auto, opencv-classic, opencv-sb or mrgingham");
  }
  if (detector != "apriltag" && !board_kind) {
    throw Error("detector", fmt::format("{} detects checkerboards; pattern.json is an apriltag grid", detector),
                "use auto or apriltag");
  }
  if (detector == "mrgingham" && info.cols != info.rows) {
    throw Error("detector",
                fmt::format("mrgingham detects square boards (N x N inner corners) only; pattern.json has {}x{}",
                            info.cols - 1, info.rows - 1),
                "use opencv-classic or opencv-sb, or render a square board");
  }

  Detection out;
  out.detector = detector;
  const cv::Mat gray8 = To8Bit(photo_gray);
  out.moire = MeasureMoire(photo_gray, options.moire);
  ChoosePrefilter(options, out);
  std::string unmirrored_alternative;
  if (detector == "apriltag") {
    DetectTags(photo_gray, gray8, pattern, info, options, out);
  } else if (!DetectBoard(detector, photo_gray, gray8, pattern, info, options, out, unmirrored_alternative,
                          options.detector != Detector::kAuto)) {
    if (options.detector == Detector::kAuto && out.failure_kind == DetectionFailure::kPatternNotFound) {
      // auto: classic is fast but less robust to strong perspective and blur; try SB before giving up.
      const std::string first = out.failure;
      const MoireMeasure moire = out.moire;
      const std::vector<std::string> notes = out.notes;
      out = Detection();
      out.moire = moire;
      out.notes = notes;
      out.detector = "opencv-sb";
      out.notes.push_back(fmt::format("opencv-classic failed ({}); used opencv-sb", first));
      DetectBoard("opencv-sb", photo_gray, gray8, pattern, info, options, out, unmirrored_alternative, true);
    }
    if (out.failure_kind == DetectionFailure::kPatternNotFound) DiagnoseBoardFailure(gray8, info, out.detector, out);
  }
  if (out.failure.empty()) {
    // Handedness (detect.h): a photo of the front of the pattern has a negative determinant.
    const double handedness = Handedness(out.features, info);
    if (handedness > kMirroredHandedness) {
      FailMirrored(out, fmt::format(" (handedness {:+.2f}{})", handedness,
                                    unmirrored_alternative.empty()
                                        ? ""
                                        : "; the square colours also fit " + unmirrored_alternative +
                                              ": if the camera was turned, take the photo upright"));
    } else if (!(handedness < -kMirroredHandedness)) {
      out.notes.push_back(fmt::format("handedness not decided ({:+.2f}: too few features, or a grazing view)",
                                      handedness));
    }
  }
  if (out.failure.empty()) {
    ScreenOutliers(out.features, info, options, out.notes);
    FlagBorder(out.features, photo_gray, options.border_px);
    const size_t expected = (detector == "apriltag" ? static_cast<size_t>(info.tag_corners) : 0) +
                            (board_kind && (detector != "apriltag" || info.kind == "both")
                                 ? static_cast<size_t>(info.board_corners)
                                 : 0);
    if (out.features.size() < expected) {
      out.notes.push_back(fmt::format("{} of {} features of the pattern detected (the others are outside the "
                                      "photo, occluded or not found)",
                                      out.features.size(), expected));
    }
    const auto flagged = std::count_if(out.features.begin(), out.features.end(),
                                       [](const DetectedFeature& f) { return !f.flag.empty(); });
    if (flagged > 0) out.notes.push_back(fmt::format("{} features flagged", flagged));
  } else {
    out.features.clear();
  }
  out.time_ms = watch.Ms();
  return out;
}

}  // namespace curvecheck
