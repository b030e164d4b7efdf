#include "calibrate/photos.h"

#include <fmt/format.h>

#include <algorithm>

#include "core/error.h"
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
  CalibrationPhotos out;
  out.content.resize(photos.size());
  out.duplicate_of.assign(photos.size(), -1);
  // The content hash of the image each detection reads (as decoded: 16 bits stay 16 bits).
  out.detections = DetectChessboards(photos, board, options, [&](size_t i, const cv::Mat& decoded) {
    out.content[i] = HashImageContent(decoded);
  });

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
