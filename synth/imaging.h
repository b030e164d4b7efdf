// Internal to synth/ (namespace synth_internal): not part of the synthetic camera's interface.
// The stages of the realistic colour chain (Imaging in synth/scene.h) after the trace (tracer.h TraceColour):
// veiling glare, the optics' blur with depth-dependent defocus, vignetting and exposure, the raw sensor
// (mosaic, electrons, PRNU, noise, clipping, ADC), demosaicing, tone curve and JPEG. Each is a function of
// images so that the tests can measure it alone.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "core/camera_model.h"
#include "synth/scene.h"

namespace curvecheck::synth_internal {

// The lens's focal length, mm: fx (px) times the pixel pitch.
double FocalLengthMm(const CameraModel& camera, const Imaging& imaging);

// Defocus of a thin lens of focal length f (mm) and f-number N focused at s (mm, along the axis): a point at
// depth d images as a disc (circle of confusion) of diameter c = f^2 / N * |d - s| / (d (s - f)) on the sensor
// (mm); returned as the Gaussian of the disc's second moment, sigma = c / 4 (radius c / 2, sigma = radius / 2),
// in px of `pitch_um`. 0 for N = 0 (pinhole) or a depth that is not a number (the room: in focus, it is uniform).
double DefocusSigmaPx(double depth_mm, double focus_mm, double focal_mm, double f_number, double pitch_um);

// Adds `glare` x the image's mean radiance (per channel) everywhere: veiling glare, light the lens scatters
// over the whole frame.
void AddVeilingGlare(double glare, cv::Mat* radiance);

// Blurs `radiance` (CV_32FC1 or C3) with a Gaussian whose sigma varies per pixel (`sigma_px`, CV_32F, the same
// size). Approximation: the image is blurred at a few sigma levels (from the smallest to the largest sigma,
// evenly in log sigma, at most 25% apart) and each pixel blends the two levels that bracket its sigma, with
// weights that give the blended PSF exactly the pixel's variance (linear in sigma^2). The blend is a sum of two Gaussians,
// not one, and a pixel's PSF is taken where it lands rather than where its light comes from; both matter only
// where the blur changes fast across the image, which defocus over a smooth screen does not. Returns the
// number of levels used. In place, by strips of rows on all cores.
int BlurBySigmaMap(const cv::Mat& sigma_px, cv::Mat* radiance);

// Relative illumination at r = distance from the image centre / distance of the corner (0..1), for a corner
// loss of `ev` stops: cos4 = (1 + a r^2)^-2 (the cos^4 law of a lens whose corner field angle makes the corner
// gain 2^-ev), quadratic = 1 - (1 - 2^-ev) r^2.
double VignettingGain(VignettingModel model, double ev, double r);

// The raw sensor: radiance (CV_32FC3 B, G, R, relative to a full white display pixel) times exposure and
// vignetting to electrons of imaging.full_well_e, times the PRNU gain (1 + prnu N(0, 1) per site, fixed per
// sensor.seed), Poisson shot and Gaussian read noise (sensor.noise, seeded per row), clipped to 0..full well,
// then the ADC: full well = 2^raw_bits - 1 DN, rounded. RGGB: one CV_16U site per pixel (R at even row and even
// column, B at odd and odd); cfa none: CV_16UC3 B, G, R. Runs on all cores. Written into `storage`'s memory when
// it is large enough (core/large_buffer.h ReuseOrNewLargeMat; the caller is done with its values).
cv::Mat ExposeRaw(const Imaging& imaging, const Sensor& sensor, const cv::Mat& radiance,
                  const cv::Mat& storage = cv::Mat());

// Demosaics an RGGB raw (CV_16U, DN) to CV_16UC3 B, G, R in DN with OpenCV's cv::demosaicing: bilinear, VNG
// (variable number of gradients; OpenCV's takes 8 bits, so the raw is scaled to 8 bits first) or edge-aware.
// A CV_16UC3 raw (cfa none) is returned as it is. Written into `storage`'s memory when it is large enough.
cv::Mat DemosaicRaw(const cv::Mat& raw, const Imaging& imaging, const cv::Mat& storage = cv::Mat());

// DN (CV_16UC3, 0..2^raw_bits - 1) to 8-bit code values by the tone curve: sRGB's (linear below 0.0031308, then
// 1.055 x^(1/2.4) - 0.055) or linear.
cv::Mat ToneMap8(const cv::Mat& dn, int raw_bits, ToneCurve tone);

// JPEG of an 8-bit BGR image at `quality` (1..100) in memory (OpenCV's libjpeg: YCbCr with 4:2:0 chroma, its
// default for colour), and the image decoded from it, into `into`'s pixels when it has the image's size and type
// (CV_8UC3; a fresh image otherwise).
std::vector<uint8_t> EncodeJpeg(const cv::Mat& bgr8, int quality);
cv::Mat DecodeJpeg(const std::vector<uint8_t>& jpeg, cv::Mat into = cv::Mat());

}  // namespace curvecheck::synth_internal
