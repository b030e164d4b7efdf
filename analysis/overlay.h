// The overlay images of an analysis (analysis/pipeline.h): each photo with the expected planar perspective grid,
// the verification residuals and the screen fit's residuals drawn on it, as `curvecheck analyze` and `demo` write
// them (overlay-<stem>.png, report.h OverlayFileName). A photo left out as a duplicate of an earlier one gets its
// own overlay too: the earlier photo's detections (the same content), marked as not used in the fit.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "analysis/pipeline.h"

namespace curvecheck {

// The image an overlay is drawn on: `photo_gray` (8 or 16 bit) as 8 bit, scaled to at most max_px on its longer
// side with INTER_AREA; and the scale (<= 1).
std::pair<cv::Mat, double> OverlayBase(const cv::Mat& photo_gray, int max_px);

// The overlay of result.photos[index] as PNG bytes (see WriteOverlays); the photo must have one
// (AnalysisResult::OverlaySource >= 0). The residual vectors are clipped to the image, so any magnification draws
// in the same time. Draws on PhotoAnalysis::overlay_gray when it was kept at this max_px, else reads the photo
// again.
std::string OverlayPng(const AnalysisResult& result, size_t index, double magnification = 50,
                       int max_px = kOverlayMaxPx);

// Overlay images, one per photo that has one (AnalysisResult::OverlaySource): the photo (gray, scaled to at most
// max_px on its longer side) with the expected planar perspective grid (green), the verification residuals (red)
// and the screen fit's residuals (blue), both magnified by `magnification`; a duplicate's says so in its legend.
// Written atomically into `dir` as OverlayFileName(name) (report.h); returns the paths.
std::vector<std::filesystem::path> WriteOverlays(const AnalysisResult& result, const std::filesystem::path& dir,
                                                 double magnification = 50, int max_px = kOverlayMaxPx);

}  // namespace curvecheck
