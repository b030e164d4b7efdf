// The production display step of a capture session: `curvecheck present` (render/presenter.h) as a child
// process. The presenter API runs its own loop over a list of images, so instead of adding a stepping API to it
// the session starts `curvecheck present --display N [--windowed] img...` once with the remaining shots' patterns,
// steps it with SIGUSR1 (the presenter's "next image" signal), and reads its "shown k/n path" lines: a pattern
// counts as on screen when its line arrives, and the session then waits settle_ms more for the panel.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "capture/session.h"
#include "core/subprocess.h"

namespace curvecheck {

class PresenterProcess {
 public:
  // binary: the curvecheck executable; plan: the session's plan (its shots are shown from the first Show()'s
  // index on); settle_ms >= 0: wait after each "shown" line; timeout_ms: longest wait for a "shown" line.
  PresenterProcess(std::filesystem::path binary, const SessionPlan& plan, int display, bool windowed, int settle_ms,
                   int timeout_ms = 30000);
  // Stops the presenter (SIGTERM) and reaps it.
  ~PresenterProcess();
  PresenterProcess(const PresenterProcess&) = delete;
  PresenterProcess& operator=(const PresenterProcess&) = delete;

  // A ShowPattern: shows plan.shots[index] (indices must come in order, one step at a time) and returns after
  // it is on screen and settled. Throws Error if the presenter fails (its last stderr line is quoted), exits,
  // or does not report the image within timeout_ms.
  void Show(size_t index, const PlannedShot& shot);

 private:
  void Start(size_t first);
  void WaitForShown(int k);

  std::filesystem::path binary_;
  const SessionPlan& plan_;
  int display_;
  bool windowed_;
  int settle_ms_, timeout_ms_;
  ChildProcess child_;  // `curvecheck present`, stdout and stderr on pipes
  size_t first_ = 0;
  int shown_ = 0;
  std::string out_buf_, err_buf_;
};

}  // namespace curvecheck
