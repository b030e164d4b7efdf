// GLFW + Vulkan implementation of the presenter (render/presenter.h). Each image is copied byte for byte from a
// host-visible buffer into the acquired swapchain image with vkCmdCopyBufferToImage (no sampler, no blit, no
// scaling) and presented. Every Vulkan call is checked: Vulkan-Hpp's RAII wrappers throw vk::SystemError on any
// failing VkResult, which is turned into curvecheck::Error here.
#include "render/presenter.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <deque>
#include <opencv2/core.hpp>
#include <vulkan/vulkan_raii.hpp>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_decode.h"
#include "core/stopwatch.h"
#include "render/presentation.h"
#include "render/vulkan_error.h"
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
// Last: Xlib's macros (None, Success, Bool, ...) must not reach the headers above.
#include <X11/Xlib.h>

// From GLFW/glfw3native.h, declared here because that header also needs X11/extensions/Xrandr.h (libxrandr-dev)
// for declarations we do not use. Weak, so that a GLFW built for Wayland only (no such function) still links and
// the X11 round trip is skipped there.
extern "C" __attribute__((weak)) Display* glfwGetX11Display(void);

namespace curvecheck {
namespace {

namespace fs = std::filesystem;

constexpr double kPollSeconds = 0.01;                  // event wait granularity (signals are polled)
constexpr double kWindowSettleSeconds = 2.0;           // time a window manager gets to place the window

// ---------------------------------------------------------------------------------------------------------------
// Signals: only flags are touched in the handlers; the event loop polls them.

std::atomic<int> g_next_requests{0};
std::atomic<bool> g_quit_requested{false};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free,
              "signal handlers need lock-free atomics");

extern "C" void OnNextSignal(int) { g_next_requests.fetch_add(1); }
extern "C" void OnQuitSignal(int) { g_quit_requested.store(true); }

// Installs the presenter's handlers for SIGUSR1, SIGTERM and SIGINT; restores the previous ones when destroyed.
class SignalScope {
 public:
  SignalScope() {
    g_next_requests.store(0);
    g_quit_requested.store(false);
    Install(SIGUSR1, OnNextSignal, 0);
    Install(SIGTERM, OnQuitSignal, 1);
    Install(SIGINT, OnQuitSignal, 2);
  }
  ~SignalScope() {
    for (int i = 0; i < 3; ++i) {
      if (installed_[i]) sigaction(signals_[i], &previous_[i], nullptr);
    }
  }
  SignalScope(const SignalScope&) = delete;
  SignalScope& operator=(const SignalScope&) = delete;

 private:
  void Install(int signal, void (*handler)(int), int slot) {
    struct sigaction action {};
    action.sa_handler = handler;
    sigemptyset(&action.sa_mask);
    signals_[slot] = signal;
    installed_[slot] = sigaction(signal, &action, &previous_[slot]) == 0;
  }
  std::array<int, 3> signals_{};
  std::array<struct sigaction, 3> previous_{};
  std::array<bool, 3> installed_{};
};

// ---------------------------------------------------------------------------------------------------------------
// Images.

// libpng (inside OpenCV, behind core/image_decode.h) prints its errors to stderr; they are captured so that the
// one-line Error carries them and nothing else reaches the terminal. Redirects the process-wide stderr for its
// lifetime.
class StderrCapture {
 public:
  StderrCapture() {
    std::fflush(stderr);
    file_ = std::tmpfile();
    saved_fd_ = file_ ? ::dup(STDERR_FILENO) : -1;
    if (saved_fd_ >= 0 && ::dup2(::fileno(file_), STDERR_FILENO) < 0) {
      ::close(saved_fd_);
      saved_fd_ = -1;
    }
  }
  ~StderrCapture() {
    Restore();
    if (file_) std::fclose(file_);
  }
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;

  // Stops capturing; returns what was written, on one line.
  std::string Finish() {
    Restore();
    std::string text;
    if (!file_) return text;
    std::rewind(file_);
    char buffer[512];
    size_t n = 0;
    while ((n = std::fread(buffer, 1, sizeof(buffer), file_)) > 0) text.append(buffer, n);
    std::string line;
    for (char c : text) {
      if (c == '\n' || c == '\r') {
        if (!line.empty() && line.back() != ' ') line += "; ";
      } else {
        line += c;
      }
    }
    while (!line.empty() && (line.back() == ' ' || line.back() == ';')) line.pop_back();
    return line;
  }

 private:
  void Restore() {
    if (saved_fd_ < 0) return;
    std::fflush(stderr);
    ::dup2(saved_fd_, STDERR_FILENO);
    ::close(saved_fd_);
    saved_fd_ = -1;
  }
  std::FILE* file_ = nullptr;
  int saved_fd_ = -1;
};

struct LoadedImage {
  fs::path path;
  cv::Mat pixels;  // CV_8UC1 (gray), CV_8UC3 (BGR) or CV_8UC4 (BGRA), as decoded
};

// Decodes with the project's one decoder (core/image_decode.h: the header and the size cap are checked before
// OpenCV decodes), which keeps the stored bit depth so that 16-bit images are refused, not scaled.
LoadedImage LoadImage(const fs::path& path) {
  const std::string bytes = ReadFileToString(path);
  const std::string fix = "the presenter shows 8-bit PNG images (gray, RGB or RGBA); re-render or re-export it";
  if (bytes.empty()) throw Error(path.string(), "the file is empty", fix);
  cv::Mat decoded;
  std::string problem;
  {
    StderrCapture capture;
    try {
      decoded = DecodeImage(bytes, path.string());
    } catch (const Error& e) {
      problem = "the file " + e.problem();
    }
    const std::string printed = capture.Finish();
    if (!printed.empty()) problem += (problem.empty() ? "" : "; ") + printed;
  }
  if (decoded.empty()) throw Error(path.string(), "cannot decode the image: " + problem, fix);
  if (decoded.depth() != CV_8U) {
    throw Error(path.string(), fmt::format("the image has {}-bit samples", decoded.elemSize1() * 8),
                "the presenter shows 8-bit code values unchanged; write the pattern as an 8-bit PNG");
  }
  if (decoded.channels() != 1 && decoded.channels() != 3 && decoded.channels() != 4) {
    throw Error(path.string(), fmt::format("the image has {} channels", decoded.channels()), fix);
  }
  return {path, decoded};
}

// Writes the image as 4 bytes per pixel, tightly packed rows, in the swapchain's byte order: B, G, R, x when
// bgra, else R, G, B, x. Code values are copied, never changed; the fourth byte is 255 (alpha is ignored).
void PackPixels(const cv::Mat& image, bool bgra, uint8_t* out) {
  const int channels = image.channels();
  for (int y = 0; y < image.rows; ++y) {
    const uint8_t* row = image.ptr<uint8_t>(y);
    for (int x = 0; x < image.cols; ++x, out += 4) {
      const uint8_t* px = row + static_cast<ptrdiff_t>(x) * channels;
      uint8_t b = px[0], g = px[0], r = px[0];  // gray
      if (channels >= 3) b = px[0], g = px[1], r = px[2];  // OpenCV order: B, G, R(, A)
      out[0] = bgra ? b : r;
      out[1] = g;
      out[2] = bgra ? r : b;
      out[3] = 255;
    }
  }
}

// ---------------------------------------------------------------------------------------------------------------
// GLFW.

std::string& GlfwLastError() {
  static std::string message;
  return message;
}

extern "C" void OnGlfwError(int code, const char* description) {
  GlfwLastError() = fmt::format("{} (GLFW error 0x{:x})", description ? description : "?", code);
}

class GlfwSession {
 public:
  GlfwSession() {
    GlfwLastError().clear();
    glfwSetErrorCallback(OnGlfwError);
    if (!glfwInit()) {
      glfwSetErrorCallback(nullptr);
      throw Error("", "no display: GLFW cannot open one (" + GlfwLastError() + ")",
                  "run under X11 or Wayland (XWayland), or headless under Xvfb "
                  "(e.g. xvfb-run -s '-screen 0 1920x1080x24' curvecheck present ...)");
    }
  }
  ~GlfwSession() {
    glfwTerminate();
    glfwSetErrorCallback(nullptr);
  }
  GlfwSession(const GlfwSession&) = delete;
  GlfwSession& operator=(const GlfwSession&) = delete;
};

std::string DescribeMonitor(GLFWmonitor* monitor, int index) {
  int x = 0, y = 0;
  glfwGetMonitorPos(monitor, &x, &y);
  const GLFWvidmode* mode = glfwGetVideoMode(monitor);
  const char* name = glfwGetMonitorName(monitor);
  std::string text = fmt::format("{} '{}' at ({}, {})", index, name ? name : "?", x, y);
  if (!mode) return text + " without a video mode";
  text += fmt::format(" {}x{}", mode->width, mode->height);
  if (mode->refreshRate > 0) text += fmt::format(" {} Hz", mode->refreshRate);
  return text;
}

// What the event loop is asked to do, in order of arrival.
enum class Action { kNext, kPrevious, kQuit };

struct WindowState {
  std::deque<Action> actions;
  bool needs_redraw = false;  // the window system lost the window's contents (expose)
};

extern "C" void OnKey(GLFWwindow* window, int key, int /*scancode*/, int action, int /*mods*/) {
  if (action != GLFW_PRESS) return;  // one step per press, not per auto-repeat
  auto* state = static_cast<WindowState*>(glfwGetWindowUserPointer(window));
  switch (key) {
    case GLFW_KEY_SPACE:
    case GLFW_KEY_RIGHT:
    case GLFW_KEY_N: state->actions.push_back(Action::kNext); break;
    case GLFW_KEY_LEFT:
    case GLFW_KEY_P: state->actions.push_back(Action::kPrevious); break;
    case GLFW_KEY_ESCAPE:
    case GLFW_KEY_Q: state->actions.push_back(Action::kQuit); break;
    default: break;
  }
}

extern "C" void OnRefresh(GLFWwindow* window) {
  static_cast<WindowState*>(glfwGetWindowUserPointer(window))->needs_redraw = true;
}

struct WindowDeleter {
  void operator()(GLFWwindow* w) const { glfwDestroyWindow(w); }
};
using WindowPtr = std::unique_ptr<GLFWwindow, WindowDeleter>;

// ---------------------------------------------------------------------------------------------------------------
// GLFW's side of the Vulkan presentation (render/presentation.h).

// The instance extensions GLFW's surfaces need.
std::vector<const char*> SurfaceExtensions() {
  uint32_t count = 0;
  const char** extensions = glfwGetRequiredInstanceExtensions(&count);
  if (!extensions) {
    throw Error("Vulkan", "the Vulkan loader has no window-system surface support (" + GlfwLastError() + ")",
                "install libvulkan1 and a driver with window-system support (mesa-vulkan-drivers for lavapipe)");
  }
  return {extensions, extensions + count};
}

Presentation::MakeSurface SurfaceMaker(GLFWwindow* window) {
  return [window](VkInstance instance) {
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    const VkResult result = glfwCreateWindowSurface(instance, window, nullptr, &surface);
    if (result != VK_SUCCESS) {
      throw Error("Vulkan",
                  fmt::format("cannot create a Vulkan surface for the window ({}; {})",
                              vk::to_string(static_cast<vk::Result>(result)), GlfwLastError()),
                  "install a Vulkan driver with window-system support (mesa-vulkan-drivers for lavapipe)");
    }
    return surface;
  };
}

// Makes the window system finish what the presenter asked of it: on X11, a round trip on the connection that
// GLFW and the Vulkan driver share, so that a software present (lavapipe: PutImage) has been executed by the
// server before the image is reported shown.
void SyncWindowSystem() {
  if (glfwGetX11Display == nullptr) return;
  if (Display* display = glfwGetX11Display()) XSync(display, False);
}

}  // namespace

void PresenterOptions::Check(const std::string& where) const {
  if (display < 0) {
    throw Error(where, fmt::format("display {} is not an output number", display), "use 0 (primary), 1, ...");
  }
  if (images.empty()) throw Error(where, "no image to show", "give one or more PNG files");
  if (hold_ms && *hold_ms <= 0) {
    throw Error(where, fmt::format("hold time {} ms is not positive", *hold_ms),
                "give the time each image stays on screen in milliseconds, e.g. 2000");
  }
}

int RunPresenter(const PresenterOptions& options, std::ostream& log) {
  options.Check("presenter");
  SignalScope signals;

  // Decode and check every image before anything appears on screen.
  std::vector<LoadedImage> images;
  images.reserve(options.images.size());
  for (const fs::path& path : options.images) {
    images.push_back(LoadImage(path));
    const cv::Mat& first = images.front().pixels;
    const cv::Mat& last = images.back().pixels;
    if (last.size() != first.size()) {
      throw Error(path.string(),
                  fmt::format("the image is {}x{} px, but {} is {}x{}", last.cols, last.rows,
                              images.front().path.string(), first.cols, first.rows),
                  "all images shown on one output must have the output's resolution");
    }
  }
  const int width = images.front().pixels.cols, height = images.front().pixels.rows;

  GlfwSession glfw;
  if (!glfwVulkanSupported()) {
    throw Error("Vulkan", "GLFW finds no Vulkan loader with window-system support (" + GlfwLastError() + ")",
                "install libvulkan1 and a Vulkan driver (mesa-vulkan-drivers for lavapipe)");
  }
  int monitor_count = 0;
  GLFWmonitor** monitors = glfwGetMonitors(&monitor_count);
  std::vector<std::string> outputs;
  for (int i = 0; i < monitor_count; ++i) outputs.push_back(DescribeMonitor(monitors[i], i));
  const std::string where_display = fmt::format("--display {}", options.display);
  if (options.display >= monitor_count) {
    throw Error(where_display,
                monitor_count == 0 ? "the display has no output (monitor)"
                                   : fmt::format("there is no output {}; the outputs are: {}", options.display,
                                                 fmt::join(outputs, ", ")),
                "choose one of the outputs listed (0 is the primary)");
  }
  GLFWmonitor* monitor = monitors[options.display];
  const GLFWvidmode* mode = glfwGetVideoMode(monitor);
  if (!mode) throw Error(where_display, "the output has no video mode (" + GlfwLastError() + ")", "");
  if (mode->width != width || mode->height != height) {
    throw Error(images.front().path.string(),
                fmt::format("the image is {}x{} px, but output {} ('{}') shows {}x{}", width, height,
                            options.display, glfwGetMonitorName(monitor) ? glfwGetMonitorName(monitor) : "?",
                            mode->width, mode->height),
                fmt::format("the presenter never scales: render the pattern at {}x{}, or set the output to a {}x{} "
                            "mode first",
                            mode->width, mode->height, width, height));
  }
  int monitor_x = 0, monitor_y = 0;
  glfwGetMonitorPos(monitor, &monitor_x, &monitor_y);

  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
  glfwWindowHint(GLFW_AUTO_ICONIFY, GLFW_FALSE);      // keep the pattern up if another window takes the focus
  glfwWindowHint(GLFW_SCALE_TO_MONITOR, GLFW_FALSE);  // size in pixels, whatever the desktop's scale
  glfwWindowHint(GLFW_FOCUS_ON_SHOW, GLFW_TRUE);
  if (options.windowed) {
    glfwWindowHint(GLFW_DECORATED, GLFW_FALSE);
    glfwWindowHint(GLFW_FLOATING, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);  // placed on the output before it is shown
  } else {
    // Ask for exactly the current mode so that GLFW does not switch modes.
    glfwWindowHint(GLFW_RED_BITS, mode->redBits);
    glfwWindowHint(GLFW_GREEN_BITS, mode->greenBits);
    glfwWindowHint(GLFW_BLUE_BITS, mode->blueBits);
    glfwWindowHint(GLFW_REFRESH_RATE, mode->refreshRate);
  }
  WindowState state;  // before the window: it must outlive the window's callbacks
  WindowPtr window(
      glfwCreateWindow(width, height, "curvecheck present", options.windowed ? nullptr : monitor, nullptr));
  if (!window) {
    throw Error(where_display, "cannot open a window on the output (" + GlfwLastError() + ")",
                "check that the display accepts new windows");
  }
  glfwSetWindowUserPointer(window.get(), &state);
  glfwSetKeyCallback(window.get(), OnKey);
  glfwSetWindowRefreshCallback(window.get(), OnRefresh);
  glfwSetInputMode(window.get(), GLFW_CURSOR, GLFW_CURSOR_HIDDEN);  // no pointer over the pattern
  if (options.windowed) {
    glfwSetWindowPos(window.get(), monitor_x, monitor_y);
    glfwShowWindow(window.get());
  }

  // The window must cover the output exactly, framebuffer pixel for output pixel. A window manager may take a
  // moment to place it; give it that, then refuse.
  auto geometry = [&] {
    int fb_w = 0, fb_h = 0, x = 0, y = 0;
    glfwGetFramebufferSize(window.get(), &fb_w, &fb_h);
    glfwGetWindowPos(window.get(), &x, &y);
    const GLFWvidmode* now = glfwGetVideoMode(monitor);
    const bool exact = fb_w == width && fb_h == height && x == monitor_x && y == monitor_y && now &&
                       now->width == width && now->height == height;
    return std::make_pair(exact, fmt::format("the window's framebuffer is {}x{} px at ({}, {}) and the output "
                                             "shows {}x{} at ({}, {}); both must be the image's {}x{} at the "
                                             "output's position",
                                             fb_w, fb_h, x, y, now ? now->width : 0, now ? now->height : 0,
                                             monitor_x, monitor_y, width, height));
  };
  const Stopwatch settle;
  auto [exact, why] = geometry();
  while (!exact && settle.Seconds() < kWindowSettleSeconds) {
    glfwWaitEventsTimeout(kPollSeconds);
    std::tie(exact, why) = geometry();
  }
  if (!exact) {
    throw Error(where_display, why,
                "the presenter never scales: disable desktop scaling for this output and keep its mode at the "
                "image's size" +
                    std::string(options.windowed ? ", or use exclusive fullscreen (without --windowed)" : ""));
  }

  return WithVulkanErrors([&] {
    Presentation presentation(SurfaceExtensions(), SurfaceMaker(window.get()), static_cast<uint32_t>(width),
                              static_cast<uint32_t>(height));
    const size_t n = images.size();
    size_t current = 0;
    auto show = [&](size_t index, bool report) {
      PackPixels(images[index].pixels, presentation.bgra(), presentation.staging_bytes());
      presentation.Present();
      SyncWindowSystem();
      state.needs_redraw = false;
      if (report) log << fmt::format("shown {}/{} {}", index + 1, n, images[index].path.string()) << std::endl;
    };
    show(current, true);
    Stopwatch shown;  // since the current image was reported shown

    while (!g_quit_requested.load() && !glfwWindowShouldClose(window.get())) {
      glfwWaitEventsTimeout(kPollSeconds);
      if (g_quit_requested.load() || glfwWindowShouldClose(window.get())) break;
      int step = 0;
      if (!state.actions.empty()) {
        const Action action = state.actions.front();
        state.actions.pop_front();
        if (action == Action::kQuit) break;
        step = action == Action::kNext ? 1 : -1;
      } else if (g_next_requests.load() > 0) {
        g_next_requests.fetch_sub(1);
        step = 1;
      } else if (options.hold_ms && shown.Ms() >= *options.hold_ms) {
        if (current + 1 == n) break;
        step = 1;
      }
      if (step != 0) {
        current = step > 0 ? (current + 1) % n : (current + n - 1) % n;
        show(current, true);
        shown.Restart();
      } else if (state.needs_redraw) {
        show(current, false);  // same image again after an expose: not a new image, not reported
      }
    }
    return 0;
  }, VulkanUse::kWindow);
}

}  // namespace curvecheck
