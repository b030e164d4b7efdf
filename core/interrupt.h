// What an interrupted run leaves behind (SIGINT, SIGTERM, SIGHUP): no temporary file or folder, no child process,
// and of each output set the previous complete one or the new complete one (core/file_io.h OutputSet), then the
// process ends by the signal itself, so its exit status is 128 + N (130 for Ctrl-C, 143 for `kill`) and a shell or
// script that runs it sees an interruption, not a failure.
//
// How: InstallInterruptHandling blocks the three signals in every thread (the threads made later inherit the mask)
// and waits for them in one thread of its own (sigwait). That thread is ordinary code, not a signal handler, so it
// may use the file system freely; it takes the registry's lock (which the writers hold across the few steps that
// must not be split: creating a temporary, publishing an output set, starting a child), stops the registered
// children (SIGTERM, then SIGKILL after 2 s), removes the registered paths (newest first), and re-raises the signal
// with its default action. Work in other threads is not unwound: it simply ends with the process, and because the
// lock is never given back nothing new is created or published after the clean-up.
//
// Without InstallInterruptHandling (library tests, tools linking core) the registry is plain bookkeeping and the
// signals keep their default action. A signal ignored when the process started (nohup, `cmd &` in a script) stays
// ignored. Child processes get an empty signal mask (core/subprocess.cc), so SIGTERM still stops them.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <mutex>

namespace curvecheck {

// Call once, first thing in main(), before any other thread exists.
void InstallInterruptHandling();

// While it lives, an interruption waits (it is handled as soon as the hold goes). Holds may nest. Keep it short:
// around the creation of something registered below, or a set of renames that must happen together.
class InterruptHold {
 public:
  InterruptHold();
  ~InterruptHold();
  InterruptHold(const InterruptHold&) = delete;
  InterruptHold& operator=(const InterruptHold&) = delete;

 private:
  std::unique_lock<std::recursive_mutex> lock_;
};

// How a registered path is removed on interruption.
enum class CleanupKind {
  kFile,         // unlink
  kTree,         // the folder with everything in it
  kEmptyFolder,  // rmdir: only if nothing else was put there (an output folder this run created)
};

// While it lives (until Release), `path` is removed if the process is interrupted. It does not remove anything
// itself when it goes. Register before creating the path, inside an InterruptHold that also covers the creation,
// so that an interruption cannot fall between the two. Move-only.
class CleanupOnInterrupt {
 public:
  CleanupOnInterrupt() = default;
  CleanupOnInterrupt(const std::filesystem::path& path, CleanupKind kind);
  ~CleanupOnInterrupt() { Release(); }
  CleanupOnInterrupt(CleanupOnInterrupt&& other) noexcept : id_(other.id_) { other.id_ = 0; }
  CleanupOnInterrupt& operator=(CleanupOnInterrupt&& other) noexcept;
  CleanupOnInterrupt(const CleanupOnInterrupt&) = delete;
  CleanupOnInterrupt& operator=(const CleanupOnInterrupt&) = delete;
  // Forgets the path (it was renamed into place, or removed by its owner).
  void Release();
  bool Active() const { return id_ != 0; }

 private:
  uint64_t id_ = 0;
};

// Child processes stopped on interruption (core/subprocess.cc registers each one it starts, inside a hold).
void RegisterChildProcess(pid_t pid);
void UnregisterChildProcess(pid_t pid);

// The paths registered now (tests).
size_t RegisteredCleanupCount();

}  // namespace curvecheck
