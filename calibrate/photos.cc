#include "calibrate/photos.h"

#include <fmt/format.h>

#include <algorithm>

#include "core/error.h"
#include "core/file_io.h"
#include "core/parallel.h"
#include "core/stopwatch.h"
#include "detect/detect.h"

namespace curvecheck {

int CalibrationPhotos::Duplicates() const {
  return static_cast<int>(std::count_if(duplicate_of.begin(), duplicate_of.end(), [](int d) { return d >= 0; }));
}

std::vector<std::string> CalibrationPhotos::DuplicateNotes() const {
  std::vector<std::string> notes;
  for (size_t i = 0; i < duplicate_of.size(); ++i) {
    if (duplicate_of[i] < 0) continue;
    const size_t first = static_cast<size_t>(duplicate_of[i]);
    notes.push_back(fmt::format("{} has the same decoded content as {} ({}): used once, as {}",
                                detections[i].photo.string(), detections[first].photo.string(),
                                content[i]->Describe(), detections[first].photo.string()));
  }
  return notes;
}

CalibrationPhotos DetectCalibrationPhotos(const std::vector<std::filesystem::path>& photos, const BoardSpec& board,
                                          const ChessboardOptions& options) {
  DetectChessboards({}, board, options);  // its checks of the options, before any photo is read
  CalibrationPhotos out;
  out.detections.resize(photos.size());
  out.content.resize(photos.size());
  out.duplicate_of.assign(photos.size(), -1);
  // One photo per core (at most options.threads); a photo's failure is kept in its detection.
  ParallelFor(static_cast<int>(photos.size()), [&](int k) {
    const size_t i = static_cast<size_t>(k);
    const Stopwatch watch;
    ChessboardDetection& d = out.detections[i];
    try {
      // Core's one decoder with its header checks (format, size cap, cut-off files), as gray.
      cv::Mat gray;
      try {
        gray = DecodePhotoGray(ReadFileToString(photos[i]), photos[i].string());
      } catch (const Error& e) {
        d.problem = e.problem();
      }
      if (d.problem.empty()) {
        out.content[i] = HashImageContent(gray);  // as decoded (16 bits stay 16 bits)
        if (gray.depth() == CV_16U) gray.convertTo(gray, CV_8U, 1.0 / 257.0);
        d = DetectChessboard(gray, board, options);
      }
    } catch (const std::exception& e) {  // the failure stays with its photo, the others go on
      d = ChessboardDetection();
      d.problem = fmt::format("detection failed: {}", e.what());
    }
    d.photo = photos[i];
    d.ms = watch.Ms();
  }, 1, options.threads);

  // The first photo of each content keeps it; later ones are its duplicates (input order, not finishing order).
  for (size_t i = 0; i < photos.size(); ++i) {
    if (!out.content[i]) continue;
    for (size_t j = 0; j < i; ++j) {
      if (out.duplicate_of[j] < 0 && out.content[j] && *out.content[j] == *out.content[i]) {
        out.duplicate_of[i] = static_cast<int>(j);
        break;
      }
    }
  }
  return out;
}

}  // namespace curvecheck
