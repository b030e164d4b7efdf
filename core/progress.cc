#include "core/progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <iostream>
#include <utility>

namespace curvecheck {

bool IsTerminal(const std::ostream& out) {
  if (&out == &std::cout) return ::isatty(STDOUT_FILENO) == 1;
  if (&out == &std::cerr || &out == &std::clog) return ::isatty(STDERR_FILENO) == 1;
  return false;
}

Progress::Progress(std::string what, int total, std::ostream& out, std::optional<bool> tty)
    : what_(std::move(what)),
      total_(std::max(total, 0)),
      out_(out),
      tty_(tty.value_or(IsTerminal(out))) {}

Progress::~Progress() {
  if (drawn_) out_ << "\n" << std::flush;
}

void Progress::Skip(int done) {
  done_ = std::max(done, 0);
  skipped_ = done_;
  watch_.Restart();
}

void Progress::Step(const std::string& item) {
  ++done_;
  if (!tty_) {
    // total 0: not known in advance; the count alone is shown.
    out_ << (total_ > 0 ? fmt::format("{}: {}/{} {}", what_, done_, total_, item)
                        : fmt::format("{}: {} {}", what_, done_, item))
         << std::endl;
    return;
  }
  constexpr int kWidth = 30;
  const double fraction = total_ > 0 ? std::min(1.0, static_cast<double>(done_) / total_) : 1.0;
  const int filled = static_cast<int>(fraction * kWidth);
  std::string bar(static_cast<size_t>(filled), '=');
  if (filled < kWidth) bar += '>';
  bar.resize(kWidth, ' ');
  std::string left;
  const int timed = done_ - skipped_;
  if (timed >= 2 && done_ < total_) {
    const double elapsed_s = watch_.Seconds();
    left = fmt::format(" {:.1f} s left", elapsed_s / timed * (total_ - done_));
  }
  // \r returns to the line start; \x1b[K clears what a longer previous line left behind.
  out_ << fmt::format("\r[{}] {}/{} {}{}\x1b[K", bar, done_, total_, item, left) << std::flush;
  drawn_ = true;
}

}  // namespace curvecheck
