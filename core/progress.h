// Progress of long work (a synthetic batch, a capture session) on a stream.
//
// On a terminal (the stream is std::cout or std::cerr and that file descriptor is a TTY, or `tty` forced) one
// line is redrawn in place:   [=====>    ] 12/40 shot_0012.png 3.1 s left
// Otherwise one plain line per step, for logs and pipes:   capture: 12/40 shot_0012.png
// The time left is the mean time per step so far times the steps left (shown from the second step on).
#pragma once

#include <optional>
#include <ostream>
#include <string>

#include "core/stopwatch.h"

namespace curvecheck {

class Progress {
 public:
  // what: a short name of the work ("capture"); total: number of steps (0: not known); out: where to write.
  // tty: force the terminal (true) or plain (false) form; unset: detect with isatty.
  Progress(std::string what, int total, std::ostream& out, std::optional<bool> tty = std::nullopt);
  // Ends the redrawn line with a newline if one was drawn.
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // One step done; `item` names it (a file name). Steps beyond `total` are shown as they come.
  void Step(const std::string& item);
  // Starts the count at `done` steps (a resumed session): they count as done but not toward the time left.
  void Skip(int done);

  bool is_tty() const { return tty_; }
  int done() const { return done_; }

 private:
  std::string what_;
  int total_;
  std::ostream& out_;
  bool tty_;
  int done_ = 0;
  int skipped_ = 0;
  bool drawn_ = false;
  Stopwatch watch_;  // since the first counted step
};

// True if `out` is std::cout or std::cerr (or clog) and its file descriptor is a terminal.
bool IsTerminal(const std::ostream& out);

}  // namespace curvecheck
