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

}  // namespace curvecheck
