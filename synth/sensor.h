// Internal to synth/ (namespace synth_internal): not part of the synthetic camera's interface.
// The optics and sensor stages of RenderSyntheticPhoto: blur of the traced radiance, then vignetting, exposure,
// Poisson-Gaussian noise, sensor gamma and quantization to code values.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "synth/scene.h"

namespace curvecheck::synth_internal {

// Blurs `radiance` (CV_32F, camera px) in place by the optics' PSF: a Gaussian of sigma blur_px, or a disc of
// radius blur_px (normalized); replicated borders. Nothing for blur "none" or blur_px 0.
void BlurRadiance(const Optics& optics, cv::Mat* radiance);

// Code values (CV_8U 0..255 or CV_16U 0..65535 by sensor.bits) of `radiance` (CV_32F, relative to a full white
// display pixel): times exposure and the vignetting gain 1 - v (r / r_corner)^2, Poisson-Gaussian noise in
// electrons of the full well (when on), clamped to 0..1, sensor gamma, rounded. The noise is seeded per row from
// (sensor.seed, row), so it does not depend on the thread count. Runs on all cores.
cv::Mat ExposeSensor(const Optics& optics, const Sensor& sensor, const cv::Mat& radiance);

}  // namespace curvecheck::synth_internal
