// The one way the project starts another program: an argv vector (never a shell string, so no quoting and no
// injection), stdin from /dev/null, stdout and stderr on pipes, exit status checked by the caller or by
// RunProcessChecked. Programs without a '/' in argv[0] are looked up on PATH.
//
// Exit status convention of ProcessResult::status: the program's exit code (0..255); 127 when it could not be
// started (not found or not executable); 128 + N when it was killed by signal N.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace curvecheck {

// A child process with its stdout and stderr on pipes (both close-on-exec in the parent). Move-only; the
// destructor sends SIGTERM to a child that is still running and reaps it, so no zombie and no orphan is left
// when an exception unwinds.
class ChildProcess {
 public:
  // Starts argv (argv[0]: the program) in `cwd` (empty: the current folder). Throws Error if argv is empty or
  // no process can be created; a program that cannot be executed shows as status 127 from Wait().
  static ChildProcess Start(const std::vector<std::string>& argv, const std::filesystem::path& cwd = {});
  ChildProcess() = default;
  ChildProcess(ChildProcess&& other) noexcept;
  ChildProcess& operator=(ChildProcess&& other) noexcept;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  ~ChildProcess();

  pid_t pid() const { return pid_; }
  int stdout_fd() const { return out_fd_; }  // read end; -1 once closed
  int stderr_fd() const { return err_fd_; }
  bool running() const { return pid_ > 0; }
  // Sends a signal (no effect once reaped).
  void Signal(int signal) const;
  // Waits for the child and returns its status (convention above). The pipes stay open until destruction.
  int Wait();
  // The status if the child has exited (reaping it), else nullopt; does not block.
  std::optional<int> TryWait();

 private:
  void Release();
  pid_t pid_ = -1;
  int out_fd_ = -1, err_fd_ = -1;
};

struct ProcessResult {
  int status = 0;             // see the convention above
  std::string stdout_text;    // everything the program wrote
  std::string stderr_text;
  // The last non-empty line of stderr (or of stdout when stderr is empty): what a one-line error quotes.
  std::string LastLine() const;
};

// Runs argv to completion, collecting its stdout and stderr. Never throws for a non-zero status.
ProcessResult RunProcess(const std::vector<std::string>& argv, const std::filesystem::path& cwd = {});

// RunProcess, then throws Error(argv[0], "<what> failed (exit status N): <last line>", fix) unless status is 0.
ProcessResult RunProcessChecked(const std::vector<std::string>& argv, const std::string& what, const std::string& fix,
                                const std::filesystem::path& cwd = {});

}  // namespace curvecheck
