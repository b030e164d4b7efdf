#include "capture/presenter_display.h"

#include <fmt/format.h>
#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "core/error.h"

namespace curvecheck {

PresenterProcess::PresenterProcess(std::filesystem::path binary, const SessionPlan& plan, int display, bool windowed,
                                   int settle_ms, int timeout_ms)
    : binary_(std::move(binary)),
      plan_(plan),
      display_(display),
      windowed_(windowed),
      settle_ms_(settle_ms),
      timeout_ms_(timeout_ms) {}

PresenterProcess::~PresenterProcess() = default;  // the child gets SIGTERM and is reaped (ChildProcess)

void PresenterProcess::Start(size_t first) {
  std::vector<std::string> args = {binary_.string(), "present", "--display", std::to_string(display_)};
  if (windowed_) args.emplace_back("--windowed");
  for (size_t i = first; i < plan_.shots.size(); ++i) args.push_back(plan_.shots[i].pattern_png.string());
  child_ = ChildProcess::Start(args);
  first_ = first;
}

void PresenterProcess::WaitForShown(int k) {
  const std::string wanted = fmt::format("shown {}/", k);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms_);
  const auto last_err_line = [&] {
    std::string e = err_buf_;
    while (!e.empty() && e.back() == '\n') e.pop_back();
    const size_t nl = e.rfind('\n');
    std::string line = nl == std::string::npos ? e : e.substr(nl + 1);
    const std::string prefix = "curvecheck: error: ";  // the child's own prefix; ours comes on top
    if (line.rfind(prefix, 0) == 0) line.erase(0, prefix.size());
    return line;
  };
  for (;;) {
    for (size_t nl; (nl = out_buf_.find('\n')) != std::string::npos;) {
      const std::string line = out_buf_.substr(0, nl);
      out_buf_.erase(0, nl + 1);
      if (line.rfind(wanted, 0) == 0) return;
    }
    const int left_ms = static_cast<int>(
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count());
    if (left_ms <= 0) {
      throw Error("curvecheck present", fmt::format("did not report image {} on screen within {} ms", k, timeout_ms_),
                  "check the display (--display) and that the patterns match its resolution");
    }
    pollfd fds[2] = {{child_.stdout_fd(), POLLIN, 0}, {child_.stderr_fd(), POLLIN, 0}};
    ::poll(fds, 2, left_ms);
    bool out_closed = false;
    for (int i = 0; i < 2; ++i) {
      if ((fds[i].revents & (POLLIN | POLLHUP)) == 0) continue;
      char buf[4096];
      const ssize_t n = ::read(fds[i].fd, buf, sizeof buf);
      if (n > 0) {
        (i == 0 ? out_buf_ : err_buf_).append(buf, static_cast<size_t>(n));
      } else if (i == 0) {
        out_closed = true;
      }
    }
    if (out_closed && out_buf_.find('\n') == std::string::npos) {
      // Collect what it said on stderr, then reap it.
      char buf[4096];
      for (ssize_t n; (n = ::read(child_.stderr_fd(), buf, sizeof buf)) > 0;) {
        err_buf_.append(buf, static_cast<size_t>(n));
      }
      const int status = child_.Wait();
      const std::string said = last_err_line();
      throw Error("curvecheck present",
                  fmt::format("exited (status {}) before showing image {}{}", status < 128 ? status : -1, k,
                              said.empty() ? "" : ": " + said),
                  "");
    }
  }
}

void PresenterProcess::Show(size_t index, const PlannedShot& /*shot*/) {
  if (!child_.running() && shown_ == 0) {
    Start(index);
  } else if (!child_.running() || index != first_ + static_cast<size_t>(shown_)) {
    throw Error("capture session", fmt::format("shot {} shown out of order", index + 1), "");
  } else {
    child_.Signal(SIGUSR1);
  }
  WaitForShown(shown_ + 1);
  ++shown_;
  std::this_thread::sleep_for(std::chrono::milliseconds(settle_ms_));
}

}  // namespace curvecheck
