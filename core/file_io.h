// Reading and writing whole files. Outputs are written atomically (temporary file in the same folder,
// flushed, then renamed over the target), so a crash or a full disk never leaves a half-written output and
// never damages a previous version.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/interrupt.h"

namespace curvecheck {

// Whole file as bytes. Throws Error naming the file if it is missing, a folder, or unreadable.
std::string ReadFileToString(const std::filesystem::path& path);

// Writes `contents` to `path` atomically. Throws Error (file, reason, fix) if the folder does not exist,
// is not writable, or the disk is full; the target is then untouched and no temporary file is left (nor when the
// process is interrupted: the temporary is registered with core/interrupt.h while it exists).
void WriteFileAtomic(const std::filesystem::path& path, std::string_view contents);

// Checks, before the work, that WriteFileAtomic(path, ...) can succeed (but for a full disk): the folder exists
// and takes a new file (a temporary is created and removed), and `path` is not a folder. Throws the Error that
// WriteFileAtomic would throw. For commands that work minutes before they write.
void CheckWritable(const std::filesystem::path& path);

// Files that belong together (result.json, report.html and the overlays of one analysis; a photo and its truth),
// published as one set: each member is first written under a temporary name beside its target (Stage), then
// Publish renames them all into place with interruptions held off (core/interrupt.h). An interrupted or failed
// run therefore leaves the previous complete set or the new complete set, never a new result.json beside an old
// report.html. The staged files are removed if the set is dropped unpublished or the process is interrupted.
// (A power cut during the renames, milliseconds, can still split a set.)
class OutputSet {
 public:
  OutputSet() = default;
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  // The temporary path to write `target`'s new contents to (with any writer, e.g. WriteFileAtomic or an image
  // encoder; it keeps target's extension, which some writers read): ".<stem>.tmp<N><ext>" in target's folder.
  std::filesystem::path Stage(const std::filesystem::path& target);
  // Stage, then `write(staged path)`; an Error it throws about the staged path is rethrown about `target` (the
  // file the user named: "OUT.png: write failed: No space left on device").
  void WriteWith(const std::filesystem::path& target, const std::function<void(const std::filesystem::path&)>& write);
  // WriteWith(target, WriteFileAtomic(staged, contents)).
  void Write(const std::filesystem::path& target, std::string_view contents);
  // A file of the previous set that the new one does not have (report.html after a run with --no-report): removed
  // when the set is published, so that it cannot be read as part of the new set. No effect if it does not exist.
  void RemoveOnPublish(const std::filesystem::path& target);
  // Renames every staged file over its target and removes the stale ones. Throws Error naming the file if a
  // rename fails (the files renamed before it are then published, the others removed).
  void Publish();

 private:
  struct Member {
    std::filesystem::path target, staged;
    CleanupOnInterrupt cleanup;
  };
  std::vector<Member> members_;
  std::vector<std::filesystem::path> stale_;
};

// An exclusive lock on an output folder, held while it lives: flock(2) on DIR/.curvecheck.lock, which holds the
// holder's pid and is removed when the lock goes (or the holder is interrupted). The kernel drops the lock of a
// process that dies, so a crashed run never blocks the next one. Throws Error(option, "folder 'DIR' is in use by
// another curvecheck run (pid N)", fix) if another process holds it.
class FolderLock {
 public:
  FolderLock(const std::filesystem::path& dir, const std::string& option);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  static constexpr const char* kFileName = ".curvecheck.lock";

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  CleanupOnInterrupt cleanup_;
};

// A private temporary folder (mode 0700, under TMPDIR or /tmp, named <prefix>_XXXXXX), removed with everything in
// it when the object goes or the process is interrupted (core/interrupt.h). Throws Error if it cannot be created;
// the message names `purpose` ("gnuplot").
class TempFolder {
 public:
  TempFolder(const std::string& prefix, const std::string& purpose);
  ~TempFolder();
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }
  // Creates (or finds) the folder `relative` inside (each level of it), with interruptions held off: once an
  // interruption has removed this folder nothing recreates it (a plain create_directories on another thread could,
  // racing the clean-up, and leave it behind). Throws Error if it cannot be created or leaves the folder.
  std::filesystem::path Subfolder(const std::filesystem::path& relative) const;

 private:
  std::filesystem::path path_;
  std::string purpose_;
  CleanupOnInterrupt cleanup_;
};

}  // namespace curvecheck
