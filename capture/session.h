// Capture sessions: a planned list of (pattern, viewpoint) shots, each shown on the monitor under test and
// photographed, stored in one folder with a manifest; and the import of an existing folder of photos into the
// same layout.
//
// Session folder:
//   shot_0001.png ...        the photos (a camera's own JPEG is kept as shot_0001.jpg, EXIF intact)
//   pattern_<hash>.png/.json the patterns used, named by a 64-bit FNV-1a hash of their contents (not
//                            cryptographic: it only deduplicates), so a pattern shown many times is stored once
//   manifest.json            { "format": "curvecheck.session/1", "command", "source", "shots_planned",
//                              "created_utc", "updated_utc",
//                              "shots": [ { "index", "photo", "pattern", "pattern_json", "pattern_source",
//                                           "viewpoint_mm" (or null), "time_utc", "source", "metadata" } ],
//                              "rejected": [ { "file", "reason" } ]  (import only) }
// The manifest is rewritten atomically after every shot: an interrupted session keeps every shot taken.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "capture/frame_source.h"
#include "core/progress.h"

namespace curvecheck {

struct PlannedShot {
  std::filesystem::path pattern_png;
  std::filesystem::path pattern_json;           // beside the PNG, same stem, ".json"
  std::optional<std::vector<double>> viewpoint_mm;  // a note: where the camera stands (screen frame, mm)
};

struct SessionPlan {
  std::filesystem::path source;     // the plan file
  std::vector<PlannedShot> shots;   // repeats expanded, in order
};

// Reads a plan (YAML or JSON):
//   shots:
//     - pattern: patterns/exact.png   # relative to the plan's folder; pattern.json must sit beside it
//       viewpoint_mm: [0, 0, -1500]   # optional note
//       repeat: 3                     # optional, >= 1 (default 1)
// Checks that every pattern PNG and its .json exist and that the .json has format "curvecheck.pattern/1" (the
// command line checks the .json fully). Throws Error naming the plan, the shot and the problem.
SessionPlan LoadSessionPlan(const std::filesystem::path& plan_file);

// Shows shot `index` (0-based in plan.shots) and returns once it is on screen and settled. Throws Error on
// failure (the session then stops, keeping what it has).
using ShowPattern = std::function<void(size_t index, const PlannedShot& shot)>;

struct SessionOptions {
  std::filesystem::path folder;  // the session folder (created if missing)
  bool resume = false;           // continue after the last shot of an existing manifest
  std::string command;           // the command line, recorded in the manifest
};

struct SessionResult {
  int resumed_after = 0;  // shots already in the manifest when the run started
  int taken = 0;          // shots taken by this run
  int total = 0;          // shots in the plan
};

// Runs the plan: for each shot not yet in the manifest, show, grab, write the photo (never over an existing
// file), copy the pattern files, rewrite the manifest; then one progress step (if `progress` is given).
// Without resume the folder must be missing or empty; with resume it must hold a manifest of this plan.
// If a shot fails, throws Error "session stopped at shot k/n: <cause>; ... --resume"; the shots before it stay.
SessionResult RunSession(const SessionPlan& plan, FrameSource& source, const ShowPattern& show,
                         const SessionOptions& options, Progress* progress = nullptr);

struct ImportResult {
  int imported = 0;
  std::vector<std::pair<std::string, std::string>> rejected;  // file name, reason
};

// Builds a session folder from existing photos (.png .jpg .jpeg .tif .tiff .bmp, any case; other files are
// ignored), sorted by name: each readable image is copied (the originals are never moved or modified) as
// shot_NNNN<ext>; unreadable ones are listed under "rejected" with the reason. Records per shot the original
// path, the file's modification time (time_utc) and, for JPEG/TIFF, EXIF (DateTimeOriginal, model, ...).
// pattern_json is copied (with the pattern PNG beside it, if there is one). Throws Error if the photo folder
// is missing, the session folder is not empty, or no photo is readable.
ImportResult ImportFolder(const std::filesystem::path& photos_folder, const std::filesystem::path& pattern_json,
                          const std::filesystem::path& session_folder, const std::string& command = "",
                          Progress* progress = nullptr);

// The session manifest's file name and format string.
inline constexpr const char* kManifestName = "manifest.json";
inline constexpr const char* kSessionFormat = "curvecheck.session/1";

}  // namespace curvecheck
