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

// A private temporary folder (mode 0700, under TMPDIR or /tmp, named <prefix>_XXXXXX), removed with everything in
// it when the object goes. Throws Error if it cannot be created; the message names `purpose` ("gnuplot").
class TempFolder {
 public:
  TempFolder(const std::string& prefix, const std::string& purpose);
  ~TempFolder();
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace curvecheck
