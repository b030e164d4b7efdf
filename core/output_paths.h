// Output paths of commands (nothing lost: outputs never replace inputs nor one another; folders and files are
// checked writable before the work starts, so a long run never fails at its end for want of a place to write).
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/file_io.h"
#include "core/interrupt.h"

namespace curvecheck {

// Whether `output` is (the same file as) one of `inputs`.
bool IsAnInput(const std::filesystem::path& output, const std::vector<std::filesystem::path>& inputs);

// Throws Error if `output` is (the same file as) one of `inputs`.
void CheckNotAnInput(const std::filesystem::path& output, const std::vector<std::filesystem::path>& inputs);

// An output of a command: the option or role that names it ("-o", "--error-map", "the truth beside -o") and the
// path.
struct NamedOutput {
  std::string what;
  std::filesystem::path path;
};

// Every output against every input (CheckNotAnInput) and against every other output: two outputs that are one
// file (the same path spelled differently, or a symlink to it, existing or not) would leave only the one written
// last while the command says it wrote both. Throws Error(OUTPUT, "is written twice: as WHAT and as WHAT", fix).
void CheckOutputs(const std::vector<NamedOutput>& outputs, const std::vector<std::filesystem::path>& inputs);

// Creates `dir` if missing and checks that it is a folder we can write into (by creating and removing a
// probe file). Throws Error naming `option` and the folder otherwise.
void PrepareOutputDir(const std::filesystem::path& dir, const std::string& option);

// PrepareOutputDir, locked against a second run (core/file_io.h FolderLock), and undone if the command does not
// get as far as writing: the folders it created are removed again when it goes (or the process is interrupted)
// while they are still empty, unless Keep() was called.
class OutputFolder {
 public:
  OutputFolder(const std::filesystem::path& dir, const std::string& option);
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;
  // Something was written: keep the folder.
  void Keep() { keep_ = true; }

 private:
  std::vector<std::pair<std::filesystem::path, CleanupOnInterrupt>> created_;  // outermost first
  std::unique_ptr<FolderLock> lock_;
  bool keep_ = false;
};

}  // namespace curvecheck
