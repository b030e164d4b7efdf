// Checkerboard detectors and the board's orientation, internal to detect/: shared by the feature detection
// (detect.h, which gives the rules) and the calibration chessboards (chessboard.h). A board detector returns an
// unnamed grid of inner corners; ResolveBoardOrientation maps it onto the pattern's inner-corner indices (col,
// row), row 0 at the top of the pattern.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "detect/detect.h"

namespace curvecheck::detect_internal {

// A grid of corners as a detector returns it: `width` points per row, `height` rows, row-major, in full-
// resolution image coordinates (pixel centres at integers).
struct CornerGrid {
  int width = 0, height = 0;
  std::vector<cv::Point2d> px;
  std::vector<double> quality;  // per point, 0..1 (detect.h documents each detector's meaning)
};

// mrgingham library on an 8-bit photo: gridn x gridn corners, or nullopt.
std::optional<CornerGrid> RunMrgingham(const cv::Mat& gray8, int gridn);
// findChessboardCornersSB (+ CALIB_CB_ACCURACY if asked); CALIB_CB_NORMALIZE_IMAGE only if it fails without. At
// full resolution with max_px = 0 (its own sub-pixel corners); else on a copy scaled down by an integer factor to
// at most max_px on the longer side, the corners mapped to full resolution (coarse: refine them).
std::optional<CornerGrid> RunOpenCvSb(const cv::Mat& gray8, cv::Size inner, bool accuracy, int max_px = 0);
// findChessboardCorners on a copy scaled down by an integer factor to at most max_px on the longer side (0 =
// full resolution); the coarse corners mapped to full resolution (refine them with RefineXCorners).
std::optional<CornerGrid> RunOpenCvClassic(const cv::Mat& gray8, cv::Size inner, int max_px);

// cornerSubPix at full resolution on each point of the grid, on a patch of `image` (any depth) smoothed by a
// Gaussian of sigma_px if > 0, with a half-window of 0.3 x the distance to the nearest grid neighbour, clamped to
// 3..40 px. gap_closing_per_spacing > 0: each patch is first closed by the parallelogram of the board's two edge
// vectors there (from the neighbouring corners) times that fraction (ClosedAlongEdges), which fills a display's
// dark gap bands and leaves the X-corner where it is.
void RefineXCorners(const cv::Mat& image, double sigma_px, CornerGrid& grid, double gap_closing_per_spacing = 0);
// The half-window RefineXCorners gives corner (i, j) of a width x height grid of points px (row-major): 0.3 x the
// distance to its nearest 4-neighbour, clamped to 3..40 px (refinement_noise.cc reads the same regions).
int RefinementHalfWindowPx(const std::vector<cv::Point2d>& px, int width, int height, int i, int j);

// A patch closed (dilation, then erosion) by the parallelogram of sides u and v centred on the origin. A board's
// straight edges are kept (a monotone edge profile is unchanged by any closing), and so is an X-corner whose edges
// run along u and v (each black wedge holds translates of the parallelogram right up to its tip), unlike a
// square's, which rounds the tips off and leaves the saddle on a plateau (moire_test
// ClosingAlongTheEdgesFillsTheGapsAndKeepsTheCorner: a 15 px square moved corners at 45 deg roll by 0.27 and 10.8
// px, for 90 and 70 deg crossings and a 12 px window; the parallelogram by at most 0.016 px). A dark band is filled
// where the parallelogram does not fit inside it.
cv::Mat ClosedAlongEdges(const cv::Mat& patch, cv::Point2d u, cv::Point2d v);

// How much a grid's corners scatter about a smooth mapping, px per coordinate: the third differences along its rows
// and columns (a perspective view of a smooth surface has nearly none; independent errors of sigma give differences
// of variance 20 sigma^2), robust sigma (1.4826 x the median absolute value) / sqrt(20). NaN with no run of 4.
double GridRoughnessPx(const CornerGrid& grid);

// The photo's noise on the board's square interiors (detect.h RefinementNoise: the noise fields filled, response
// not): each square's centre (the mean of its four corners), an axis-aligned patch of half-size h = floor((d -
// 1.5) / sqrt 2), d the centre's distance to the square's nearest edge line (the patch stays 1.5 px inside the
// square at any rotation), h from 1 to 8; its pixels about their mean. Patches are black or white by their mean
// (above or below the midpoint of the 10th and 90th percentiles of the means); per colour the pooled variance of
// the patches whose variance is at most 3 x the colour's median (an edge, a tag's bits or glare in a patch is left
// out), and the pooled lag-1 correlation of adjacent pixels (corrected for the mean's removal, -1 / (n - 1) for a
// patch of n pixels). measured = false with fewer than 8 patches of a colour.
RefinementNoise MeasureSquareNoise(const cv::Mat& photo, const CornerGrid& grid);

// Up to 120 of the refined grid's corners, evenly through it, refined again (RefineXCorner with the same sigma and
// half-window as RefineXCorners, no closing) on the photo plus `draws` seeded draws of noise like the photo's
// (MeasureSquareNoise): Gaussian, per pixel of standard deviation at the brightness there (the photo smoothed by 1 px;
// refinement_noise.cc VarianceAt), spatially correlated by a Gaussian filter whose adjacent-pixel correlation exp(-1 /
// (4 s^2)) is correlation_lag1 (white below 0.05; s at most 3 px); the displacement's RMS per coordinate over corners
// and draws in response_px (in the linear regime a corner's response to a noise equals its response to another draw of
// the same noise), its standard uncertainty in response_u_px (detect.h RefinementNoise). The noise fields as given
// (the caller may replace white_sd where the white squares hold the display's structure).
void MeasureRefinementNoise(const cv::Mat& photo, const CornerGrid& refined, double sigma_px, int draws,
                            uint64_t seed, RefinementNoise& noise);

// cornerSubPix of one X-corner with the given half-window on a smoothed patch; returns the refined position.
cv::Point2d RefineXCorner(const cv::Mat& image, double sigma_px, cv::Point2d guess, int half);

// Dark bands of a display's gaps across the white squares. A panel whose emitters have gaps between them (fill
// factor below 1), photographed without a pixel's area averaging their light (a ray tracer with a few rays per
// pixel; a sensor sampling a sharp image near the emitters' frequency), aliases the gaps into dark bands of any
// width and slope across the white squares; the board detectors take their edges for the board's, and a
// Gaussian the feature spacing allows does not remove them. A gray closing (dilation, then erosion, by a k x k
// square) fills dark structures narrower than k and keeps wider ones, the black squares among them: the board is
// found on it. Its corners are refined on the photo and, where the board's deficit reaches kGapDeficitLimit, on
// patches closed along the board's edges (ClosedAlongEdges; a square would round the X-corners' black tips off),
// and the smoother grid is kept (detect.cc DetectBoard; docs/bench/validity_bench.txt, twenty-ninth and
// thirty-second sections).

// The coarse search `search` on closings of gray8 by 5, 9, 15, 25, 35 and 49 px squares, smallest first: the first
// grid found, with its image in `found_on` and its size in `size_px`; nullopt if none.
std::optional<CornerGrid> SearchOnClosings(const cv::Mat& gray8,
                                           const std::function<std::optional<CornerGrid>(const cv::Mat&)>& search,
                                           cv::Mat& found_on, int& size_px);

// The deficit of the board's area (the grid's bounding box and one corner spacing around it: its outer squares):
// the mean of (closing - photo) / closing over its bright pixels (closing above 0.6 of its 99th percentile, that
// sampled on every 4th row and 2nd column; the mean on every 2nd row), the closing by a square of
// kGapMeasureSizePx, or of about half the black squares where they are smaller (a closing wider than them would
// fill them), small enough that the scene's smooth shading stays out of it. Footprint photos measure 0.4-6.5%
// (6.5% at full resolution from 1 m, where the camera resolves the display's pixels), point-sampled ones 14-33%
// (docs/bench/validity_bench.txt, twenty-ninth section). The photo is 8 or 16 bit, one channel; `measured` false
// where the area is too small or has no bright pixel.
inline constexpr int kGapMeasureSizePx = 15;
struct GapDeficit {
  bool measured = false;
  double deficit = 0;
  int size_px = 0;  // the closing's
};
GapDeficit MeasureGapDeficit(const cv::Mat& photo, const CornerGrid& grid, double spacing_px);
// The same on a rectangle of the photo (the whole photo: before the board is found) with a closing of size_px.
GapDeficit MeasureGapDeficit(const cv::Mat& photo, cv::Rect area, int size_px = kGapMeasureSizePx);

// Board inner corner indices of every grid point, or the failure.
struct BoardOrientation {
  std::vector<int> corner_index;  // per grid point: k = row * (cols - 1) + col of the pattern
  std::string failure;            // "" or "ambiguous orientation: ..."
  std::string note;               // how it was decided
  // The naming needs a reflection (pattern right x down < 0 in the image): a mirrored view of the board.
  bool mirrored = false;
  // The square colours fit orientations of one handedness only (all unmirrored or all mirrored), so `mirrored`
  // does not rest on the upright rule.
  bool handedness_from_colours = false;
  // When a mirrored naming was chosen by the upright rule over unmirrored ones that the colours also fit: what
  // those are ("an unmirrored photo turned by 180 deg"); "" otherwise.
  std::string unmirrored_alternative;
};
// `cols` x `rows` squares, the top-left square black. `image` (8-bit) is sampled for the square colours.
// Candidates are all the symmetries of the board that keep its size, mirrored ones included (detect.h gives the
// rule); the caller decides what a mirrored naming means (DetectFeatures refuses it).
BoardOrientation ResolveBoardOrientation(const CornerGrid& grid, const cv::Mat& image, int cols, int rows,
                                         double upright_max_deg);

// Handedness of the map from a plane to the image: the linear part A of the affine map fitted by least squares
// to the pairs plane[i] -> image[i], as det(A) / s1(A)^2 = +-s2/s1 (s1 >= s2 its singular values): in [-1, 1],
// scale-free, near 0 only for a grazing view. Its sign is the orientation of the map (lens distortion and
// perspective keep it; a mirror flips it). NaN for fewer than 3 pairs, sizes that differ, or collinear plane
// points.
double AffineHandedness(const std::vector<Eigen::Vector2d>& plane, const std::vector<Eigen::Vector2d>& image);

// Whether the photo shows some checkerboard: findChessboardCornersSB with CALIB_CB_LARGER from 3 x 3 inner corners
// on a copy of at most 1600 px; the size it returns (its meta array) is a lower bound, often part of the board
// only. Used to explain a failed detection.
std::optional<cv::Size> FindAnyBoardSize(const cv::Mat& gray8);

}  // namespace curvecheck::detect_internal
