// Dataset files (scenes and camera models of datasets/), embedded at build time, for commands that must work
// without a checkout (`curvecheck demo`).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace curvecheck {

// Relative paths of the embedded files ("scenes/default.yaml", "cameras/default-24mp-opencv8.cameramodel"),
// sorted.
std::vector<std::string> DatasetFileNames();

// The text of an embedded file; throws Error naming it if there is none.
std::string DatasetFileText(const std::string& relative_path);

// Writes every embedded file under `dir` with its relative path (so that a scene finds its camera model at
// the relative path it names), atomically, and returns `dir`. Files that exist with the same content are left
// alone; a file that exists with other content is an Error (nothing is overwritten).
std::filesystem::path WriteDatasetFiles(const std::filesystem::path& dir);

}  // namespace curvecheck
