// The presenter for real rigs: shows PNG images fullscreen on one output (monitor), pixel for pixel, and steps
// through them on keys, signals or a timer, telling a capture script on a stream when each image is on screen.
//
// Pixel-exact means: image size == the output's current video mode == the window's framebuffer == the swapchain
// extent, the pixels are copied (no sampling, no filtering, no scaling), and the swapchain format is UNORM so the
// stored code values reach the output unchanged (no sRGB encoding). If any of these does not hold, the presenter
// refuses with an Error instead of showing something else. The API is CPU-side; GLFW and Vulkan stay inside
// render/presenter.cc.
#pragma once

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace curvecheck {

struct PresenterOptions {
  // Output to show on, in GLFW's order (0 = the primary output). Its current video mode is used, never changed.
  int display = 0;
  // Images to show, in order: 8-bit PNG (gray, gray+alpha, RGB or RGBA; alpha is ignored, the output is opaque),
  // each exactly the size of the output's current video mode. At least one.
  std::vector<std::filesystem::path> images;
  // If set: keep each image on screen this long (ms, from the moment it is reported shown), then show the next,
  // and return after the last one's time is up (unattended runs). Unset: wait for keys or signals.
  std::optional<int> hold_ms;
  // false: exclusive fullscreen on the output. true: an undecorated, always-on-top window at the output's
  // position and size (tests under Xvfb, or desktops where fullscreen is unwanted); the same size checks apply.
  bool windowed = false;

  // Throws Error (naming `where`, e.g. the subcommand) if a field is out of range.
  void Check(const std::string& where) const;
};

// Opens the window on options.display and shows options.images[0], then:
//   next image:     Space, Right, N, or SIGUSR1 (after the last comes the first again)
//   previous image: Left, P (before the first comes the last)
//   quit:           Escape, Q, closing the window, SIGTERM or SIGINT; or the end of the last hold (hold_ms)
// Each time a new image is on screen it writes one line to `log` and flushes it:
//   "shown <k>/<n> <path as given>"
// "On screen" means: vkQueuePresentKHR has returned, the queue is idle, and on X11 a round trip to the X server
// has completed after the present (for the software presentation path, e.g. lavapipe, the pixels are then in
// the X framebuffer). With a GPU presenting in FIFO mode the image reaches the panel at the next vertical
// blank, up to one refresh period later: capture scripts should allow that settle time.
// All images are decoded and checked before the window opens. The signal handlers are installed for the
// duration of the call only (the previous ones are restored). Not thread-safe: one presenter per process.
// Returns 0 on a normal quit. Throws Error for: an unreadable, corrupt or unsupported image (naming it); images
// of different sizes or of a size other than the output's mode; no display (GLFW cannot initialise); no such
// output; a window or swapchain whose size differs from the image; no Vulkan device that can present to the
// window; a swapchain without an 8-bit UNORM format; any failing Vulkan call.
int RunPresenter(const PresenterOptions& options, std::ostream& log);

}  // namespace curvecheck
