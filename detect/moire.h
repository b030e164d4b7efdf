// Moire from the display's pixel structure, measured in the photo itself (issue 16 item 2), and the prefilter
// chosen from it.
//
// A display's emitters are separated by dark gaps (fill factor 0.6-0.8 on real panels; shared/design/cameras.md
// "Displays"). Photographed, that grid of period p camera px shows in the white areas either as itself (p > 2) or
// aliased to a lower frequency (p < 2: the beat between the grid and the camera's pixels). Near a corner it
// adds a periodic pattern of the same size as the refinement window, which pulls the corner off the saddle.
//
// Measurement (MeasureMoire): square patches of `patch_px` on a grid over the photo; a patch is taken if it
// lies inside a bright area (its minimum over blocks of patch/4 px, averaged, above 0.6 x the photo's white
// level: the 99th percentile of the block means), so that no edge of the pattern crosses it. Each patch, minus its
// mean, times a 2-D Hann window, is transformed (cv::dft) and the power spectra are averaged over the patches
// (phases differ between patches; power adds). Every local maximum outside the lowest frequencies (more than
// 2 bins from DC in either axis: the window's main lobe and the patches' shading) is a component of the moire. Its amplitude
// A comes from the energy E in the 5 x 5 bins around the peak (the Hann main lobe, no scalloping loss) minus the
// noise floor there (the median bin power): for A cos(2 pi f.x) over N pixels with window w, one lobe holds
// N A^2 sum(w^2) / 4 of the unnormalized DFT's energy, so A = 2 sqrt(E / (N sum(w^2))). Contrast = A / the
// patches' mean level. A grid of display pixels gives several components (its two fundamentals, their
// harmonics and beats, aliased); the strongest is reported, and the filter is set by all of them. Not seen: a
// display pitch within a few percent of 1 camera px (or of 1/2), where the grid aliases to a beat longer than a
// patch; it can still bias corners (docs/bench/moire.txt).
//
// Adaptation (MoireFilterSigmaPx): a Gaussian low-pass whose transfer function exp(-2 pi^2 sigma^2 f^2) brings
// each measured component's contrast down to `residual_contrast` (the largest sigma of them): sigma = sqrt(ln(contrast / residual) / 2) / (pi f).
// Why it does not move a corner: an X-junction of two straight edges is point-symmetric about its saddle
// (I(c + d) = I(c - d)), and a rotationally symmetric kernel keeps that symmetry, so the saddle of the smoothed
// image is still c; cornerSubPix's fixed point (sum of g g^T (x - q) = 0 over a window centred on q) is c by the
// same symmetry. Curved edges (lens distortion, screen curvature) break it only at second order in the window
// size, and the edges' own blur (optics) already is such a kernel. The moire, which is not symmetric about c,
// is what the filter removes. Tested in moire_test.cc on corners with and without a large blur.
//
// Texture (the broadband part). A photo can be rough without any periodic component: point sampling of a display
// with gaps (one ray per camera pixel, jittered: each pixel sees one sub-pixel or a gap; an independent ray
// tracer's photos, 3-5 px corner errors at fill 0.7 without smoothing), or heavy sensor noise. It is taken as white
// noise at the averaged spectrum's floor (the median bin, robust to the periodic components and their leakage):
// a white texture of per-pixel variance v puts v sum(w^2) into each bin of the unnormalized DFT on average, so its
// relative standard deviation is sqrt(floor' / sum(w^2)) / level, floor' the median corrected to the mean. A
// Gaussian of sigma leaves 1 / (2 sqrt(pi) sigma) of it; where it is at least texture_limit the prefilter's sigma
// brings it to residual_texture (TextureFilterSigmaPx), and the larger of that and the moire's sigma is used.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace curvecheck {

struct MoireOptions {
  // Side of the square patches whose spectra are averaged, px (a power of two is fastest). Periods up to about
  // patch_px / 3 are resolved. 16..256.
  int patch_px = 32;
  // At most this many patches (spread over the photo), >= 1.
  int max_patches = 64;
  // Moire is "present" (and filtered against in DetectFeatures' auto mode) when its contrast is above this and
  // its peak stands above the spectrum's noise floor by `min_peak_to_floor`. 0.02 = 2% of the white level;
  // measured on synthetic photos (docs/bench/moire.txt): 0.1-0.3% with fill factor 1 and no stripes, 9-55%
  // with fill 0.5-0.85 or RGB stripes at 0.67 and 1.67 camera px per display px.
  double min_contrast = 0.02;
  double min_peak_to_floor = 10;
  // The prefilter brings the moire down to this contrast (0.5% of the white level).
  double residual_contrast = 0.005;
  // Broadband texture (above): smoothed against when its relative standard deviation reaches texture_limit, down
  // to residual_texture. A camera's noise at the white level is 0.5-3% (shot and read noise; cameras.md), which
  // the refinement's window averages by itself; point-sampled gaps give 30-65%.
  double texture_limit = 0.05;
  double residual_texture = 0.02;

  void Check(const std::string& where) const;  // throws Error naming `where`
};

// One periodic component of the white areas (a local maximum of the averaged power spectrum).
struct MoireComponent {
  double period_px = 0, frequency_x = 0, frequency_y = 0, contrast = 0, peak_to_floor = 0;
};

// What MeasureMoire saw. All frequencies and periods in camera px of the photo.
struct MoireMeasure {
  int patches = 0;              // bright patches used (0: none found; nothing else is set)
  double period_px = 0;         // period of the strongest component, 1 / |f|
  double frequency_x = 0;       // its frequency, cycles/px (image x right, y down; the sign of the pair is arbitrary)
  double frequency_y = 0;
  double contrast = 0;          // its amplitude over the mean level of the patches, 0..
  double peak_to_floor = 0;     // its peak bin power over the median bin power
  bool present = false;         // some component has contrast >= min_contrast and peak_to_floor >= min_peak_to_floor
  double white_level = 0;       // the patches' mean level, in the photo's units
  // Every component above both limits, strongest first, and the sigma of the Gaussian that brings each of them
  // down to residual_contrast (MoireFilterSigmaPx; the largest, set by the component of `limiting_period_px`).
  std::vector<MoireComponent> components;
  double needed_sigma_px = 0;
  double limiting_period_px = 0;
  // The broadband texture (above): its relative standard deviation (white at the floor), and the sigma that
  // brings it to residual_texture when it is at least texture_limit (0 otherwise).
  double texture = 0;
  double texture_sigma_px = 0;
  // Filled by DetectFeatures: the display's pixel pitch in the photo (camera px per display px, from the coarse
  // detections and pattern.json's display positions; 0 if not known), and the Gaussian prefilter (sigma, px) that
  // was applied before corner refinement (0 = none).
  double display_pitch_px = 0;
  double filter_sigma_px = 0;
  // Filled by DetectFeatures (boards, auto prefilter): the display's gaps in the photo, the mean deficit of the
  // board's bright pixels below a gray closing (detect_board.h MeasureGapDeficit; -1: not measured); the whole
  // photo's, which decides whether the coarse search is repeated on closings (-1: not measured, the board was
  // found without); and the size of the closing on which the coarse search found the board (0: found on the photo
  // or its Gaussian copy).
  double gap_deficit = -1;
  double photo_gap_deficit = -1;
  int found_on_closing_px = 0;
  // Whether the board's corners kept are those refined on patches closed along the board's edges (tried where the
  // board's gap deficit is at least kGapDeficitLimit; kept where their grid is smoother than the photo's; detect.cc
  // DetectBoard).
  bool refined_on_closed_patches = false;
};

// The gap deficit (of the whole photo) at and above which a board the coarse search did not find is searched on
// closings of the photo (detect.h DetectOptions::prefilter_sigma_px): footprint photos measure 0.4-6.5%,
// point-sampled ones 14-33% (docs/bench/validity_bench.txt, twenty-ninth section).
inline constexpr double kGapDeficitLimit = 0.1;

// The measurement above, on a one-channel photo of any depth (colour photos: convert to gray first, as
// ReadPhotoGray does). Never throws for a photo without bright areas (patches = 0); throws Error for an empty or
// multi-channel image or invalid options.
MoireMeasure MeasureMoire(const cv::Mat& photo_gray, const MoireOptions& options = {});

// Sigma (px) of the Gaussian that brings a white texture of relative standard deviation `texture` down to
// `residual_texture` (0 if it is already below it).
double TextureFilterSigmaPx(double texture, double residual_texture);

// Sigma (px) of the Gaussian that attenuates a component of `period_px` from `contrast` to `residual_contrast`
// (0 if it is already below it).
double MoireFilterSigmaPx(double period_px, double contrast, double residual_contrast);

}  // namespace curvecheck
