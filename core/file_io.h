// Reading and writing whole files. Outputs are written atomically (temporary file in the same folder,
// flushed, then renamed over the target), so a crash or a full disk never leaves a half-written output and
// never damages a previous version.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace curvecheck {

// Whole file as bytes. Throws Error naming the file if it is missing, a folder, or unreadable.
std::string ReadFileToString(const std::filesystem::path& path);

// Writes `contents` to `path` atomically. Throws Error (file, reason, fix) if the folder does not exist,
// is not writable, or the disk is full; the target is then untouched and no temporary file is left.
void WriteFileAtomic(const std::filesystem::path& path, std::string_view contents);

}  // namespace curvecheck
