// The one image decoder behind every reader of image files: ReadImage8/DecodeImage8 (core/image_io.h), the photo
// readers (detect/detect.h ReadPhotoGray, which the calibration's chessboard reader uses too) and the presenter.
// OpenCV is in its interface, so it has its own header: core/image_io.h stays free of it.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <string_view>

namespace curvecheck {

// CheckImageHeader (format, declared size within kMaxImagePixels, truncation), then OpenCV's decoder with
// IMREAD_UNCHANGED: 8 or 16 bit, 1, 3 or 4 channels as stored, no EXIF rotation (the sensor's layout). Throws
// Error naming `source` when the header check fails or OpenCV cannot decode the bytes.
cv::Mat DecodeImage(std::string_view bytes, const std::string& source);

// How a colour photo became the one channel the detectors take (ColourPhotoToGray).
struct GrayConversion {
  bool colour = false;        // the photo had 3 or 4 channels
  // The colour aliasing measured: the standard deviation of luma - the channel mean over the photo's bright areas,
  // relative to its white level (0 for gray photos or photos without bright areas), and the share of the photo
  // that was bright enough to measure it on (rows sampled).
  double chroma_texture = 0;
  double bright_fraction = 0;
  bool channel_mean = false;  // converted by the channel mean (chroma_texture >= kColourAliasingLimit), else luma
};

// Colour aliasing above this (2% of the white level, the limit at which MoireOptions calls a display's moire
// present) makes ColourPhotoToGray take the channel mean.
inline constexpr double kColourAliasingLimit = 0.02;

// A photo (1, 3 or 4 channels, B, G, R order; 8 or 16 bit) as the detectors take it: one channel of the same
// depth. Gray photos are returned as given (pixels shared).
//
// Colour photos are converted by luma (OpenCV's 0.299 R + 0.587 G + 0.114 B), unless they show colour aliasing of
// the display's sub-pixels: then by the mean of B, G and R. Why: a display's R, G and B emitters sit a third of
// a display pixel apart, so where the camera samples them without first blurring them (a ray tracer without
// footprints; a camera far sharper than its pixels) each colour aliases alike but shifted by a third of the
// pitch. With equal weights the aliases' fundamental and second harmonic cancel (the weights times the cube roots
// of unity sum to 0); luma leaves 41% of a single stripe's, and turns the colour bands into light and dark bands
// across the white squares. A white-balanced white display pixel has R = G = B, so the mean is its brightness.
// Luma stays the default because a camera's Bayer colour filter samples G twice as densely as R and B, and
// weighting R and B more brings more of their interpolation error into the corners where there is nothing to
// cancel. The measurement: luma - mean is a chroma signal, 0 on white and black areas of a white-balanced photo
// without aliasing; its spread over the bright areas, relative to the white level, is `chroma_texture`. Bright:
// every 4th row, a pixel whose channel mean (which the colour aliasing leaves even, where luma shows dark bands)
// and that of the pixels 4 px away in the four directions are above 0.6 x the white level (the 99th percentile
// of 3-px means of the channel mean), so pattern edges and their colour fringes are left out. Measured
// (docs/bench/validity_bench.txt, twenty-eighth section: the default, webcam and phone scenes, 1-3 m, 0-40 deg):
// 0.09-1.65% with footprint sampling (26 photos: luma), 3.4-14.7% with point sampling (18: the mean).
cv::Mat ColourPhotoToGray(const cv::Mat& photo, GrayConversion* conversion = nullptr);

}  // namespace curvecheck
