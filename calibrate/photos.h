// The photos of a calibration, gathered: each read and decoded once, its decoded content hashed
// (core/image_hash.h) and its board detected (detect/chessboard.h), photos in parallel. A photo whose decoded
// content repeats an earlier one's (the same file twice, a copy under another name, a lossless re-encoding) is
// marked as a duplicate of the first: Calibrate uses each content once, so that the same view counted twice
// neither shrinks the calibration's uncertainty nor tips its adequacy tests (issue 15 item 4; metrology.md
// section 3).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/image_hash.h"
#include "detect/chessboard.h"
#include "pattern/board.h"

namespace curvecheck {

struct CalibrationPhotos {
  std::vector<ChessboardDetection> detections;      // every photo, in input order
  std::vector<std::optional<ContentHash>> content;  // of the decoded gray image; none when unreadable
  std::vector<int> duplicate_of;                    // -1, or the index of the first photo with the same content

  int Duplicates() const;
  // One note per duplicate: "<photo> has the same decoded content as <first> (<size, hash>): used once".
  std::vector<std::string> DuplicateNotes() const;
};

// Reads, hashes and detects every photo, options.threads at a time (the reading and detection of
// DetectChessboards, with the content hash of the same decoded image: nothing is decoded twice). A photo that
// cannot be read or holds no complete board comes back with found = false and the reason. Throws what
// DetectChessboards throws for the options (mrgingham on a board that is not square).
CalibrationPhotos DetectCalibrationPhotos(const std::vector<std::filesystem::path>& photos, const BoardSpec& board,
                                          const ChessboardOptions& options);

}  // namespace curvecheck
