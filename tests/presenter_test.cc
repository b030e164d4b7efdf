// End-to-end tests of `curvecheck present` (render/presenter.h) on a virtual X server: each test starts its own
// Xvfb (1024x768, 24-bit), runs the built binary on it with Mesa lavapipe, waits for the "shown k/n path" lines,
// grabs the root window with Xlib XGetImage and compares it with the PNG, pixel by pixel, for exact equality.
//
// What this proves: on the software path (lavapipe -> X PutImage -> Xvfb framebuffer) the code values in the PNG
// reach the X framebuffer unchanged, with no offset, scaling or filtering, both windowed and fullscreen; the
// stepping by signal, key and timer; the "shown" line comes after the pixels are in the framebuffer; the refusals.
// What it does not prove: that a GPU driver, a compositor or the monitor keep the values (a real rig needs a
// photo check), nor the timing of scan-out on real hardware.
// Xvfb is a project dependency (scripts/debian-packages.txt): if it is missing the tests fail, they do not skip.
#include <fcntl.h>
#include "tests/cli_test_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
// Last: Xlib's macros (None, Bool, Status, ...) must not reach the headers above.
#include <X11/Xlib.h>
#include <X11/Xutil.h>

extern char** environ;

namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

constexpr int kWidth = 1024, kHeight = 768;
constexpr double kStartSeconds = 30;  // first image: Vulkan set-up on a CPU, possibly on a loaded machine
constexpr double kStepSeconds = 10;   // any later image or the exit
const char* const kLavapipe = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";

double SecondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

using curvecheck::testing::Slurp;

// Environment of this process with `set` entries replaced or added (a later entry wins over an earlier one of
// the same name), then `unset` names removed.
std::vector<std::string> Environment(const std::vector<std::string>& set, const std::vector<std::string>& unset) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) {
    const std::string entry = *e;
    const std::string name = entry.substr(0, entry.find('='));
    bool drop = false;
    for (const std::string& u : unset) drop = drop || name == u;
    for (const std::string& s : set) drop = drop || name == s.substr(0, s.find('='));
    if (!drop) env.push_back(entry);
  }
  for (size_t i = 0; i < set.size(); ++i) {
    const std::string name = set[i].substr(0, set[i].find('='));
    bool drop = false;
    for (const std::string& u : unset) drop = drop || name == u;
    for (size_t j = i + 1; j < set.size(); ++j) drop = drop || name == set[j].substr(0, set[j].find('='));
    if (!drop) env.push_back(set[i]);
  }
  return env;
}

std::vector<char*> Pointers(std::vector<std::string>& strings) {
  std::vector<char*> out;
  for (std::string& s : strings) out.push_back(s.data());
  out.push_back(nullptr);
  return out;
}

// A child process with its stdout on a pipe (read line by line) and its stderr in a file.
class Child {
 public:
  // Starts argv[0] (searched on PATH). Returns the posix_spawn error (0 on success).
  // Other file descriptors are inherited unless close-on-exec.
  int Start(std::vector<std::string> argv, std::vector<std::string> env, const fs::path& stderr_file) {
    int out[2];
    if (::pipe2(out, O_CLOEXEC) != 0) return errno;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, stderr_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                     0644);
    std::vector<char*> args = Pointers(argv), envp = Pointers(env);
    const int err = posix_spawnp(&pid_, args[0], &actions, nullptr, args.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    ::close(out[1]);
    if (err != 0) {
      ::close(out[0]);
      pid_ = -1;
      return err;
    }
    stdout_fd_ = out[0];
    return 0;
  }

  ~Child() {
    if (pid_ > 0 && !exit_code_) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
    if (stdout_fd_ >= 0) ::close(stdout_fd_);
  }

  // SIGTERM (lets Xvfb remove its socket and lock file), then SIGKILL if it is still running after 5 s.
  void Stop() {
    if (pid_ <= 0 || exit_code_) return;
    ::kill(pid_, SIGTERM);
    Wait(5);
  }

  pid_t pid() const { return pid_; }

  // Next line of stdout (without '\n'), or nullopt at end of file or after `timeout_s`.
  std::optional<std::string> ReadLine(double timeout_s) {
    const auto t0 = Clock::now();
    while (true) {
      const size_t eol = buffer_.find('\n');
      if (eol != std::string::npos) {
        std::string line = buffer_.substr(0, eol);
        buffer_.erase(0, eol + 1);
        all_stdout_ += line + "\n";
        return line;
      }
      const double left = timeout_s - SecondsSince(t0);
      if (left <= 0 || stdout_fd_ < 0) return std::nullopt;
      pollfd p{stdout_fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left * 1000) + 1) <= 0) continue;
      char chunk[4096];
      const ssize_t n = ::read(stdout_fd_, chunk, sizeof(chunk));
      if (n <= 0) {
        ::close(stdout_fd_);
        stdout_fd_ = -1;
        return std::nullopt;
      }
      buffer_.append(chunk, static_cast<size_t>(n));
    }
  }

  // Exit code (128 + signal if killed by one), or nullopt if still running after `timeout_s`.
  std::optional<int> Wait(double timeout_s) {
    const auto t0 = Clock::now();
    while (!exit_code_) {
      int status = 0;
      const pid_t r = ::waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      } else if (SecondsSince(t0) > timeout_s) {
        return std::nullopt;
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
    return exit_code_;
  }

  const std::string& all_stdout() const { return all_stdout_; }

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string buffer_, all_stdout_;
  std::optional<int> exit_code_;
};

// Deterministic bytes (LCG), so that failures reproduce.
class Bytes {
 public:
  explicit Bytes(uint32_t seed) : state_(seed) {}
  uint8_t Next() {
    state_ = state_ * 1664525u + 1013904223u;
    return static_cast<uint8_t>(state_ >> 24);
  }

 private:
  uint32_t state_;
};

// Colour test image with fine detail, as OpenCV stores it (B, G, R): a single-pixel checkerboard of two
// colours, red/green/blue ramps over every code value, 1-px "glyph" strokes whose levels differ by one code
// value, and noise covering all values in every channel.
cv::Mat ColourPattern(int width, int height) {
  cv::Mat m(height, width, CV_8UC3);
  Bytes noise(12345);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      cv::Vec3b& px = m.at<cv::Vec3b>(y, x);
      const int band = y * 4 / height;
      if (band == 0) {
        px = (x + y) % 2 ? cv::Vec3b(128, 0, 255) : cv::Vec3b(1, 255, 0);
      } else if (band == 1) {
        px = cv::Vec3b(static_cast<uint8_t>(y % 256), static_cast<uint8_t>(255 - x % 256),
                       static_cast<uint8_t>(x % 256));
      } else if (band == 2) {
        const bool stroke = ((x * 7 + y * 3) % 11 == 0) || (x % 9 == 0 && y % 5 < 3) || ((x ^ y) & 16);
        const uint8_t v = stroke ? 128 : 127;
        px = cv::Vec3b(v, static_cast<uint8_t>(v + (x % 2)), static_cast<uint8_t>(v - (y % 2)));
      } else {
        px = cv::Vec3b(noise.Next(), noise.Next(), noise.Next());
      }
    }
  }
  return m;
}

// 8-bit gray test image: a ramp, a 0/255 single-pixel checkerboard, and noise.
cv::Mat GrayPattern(int width, int height) {
  cv::Mat m(height, width, CV_8UC1);
  Bytes noise(777);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int band = y * 3 / height;
      m.at<uint8_t>(y, x) = band == 0   ? static_cast<uint8_t>((x + y) % 256)
                            : band == 1 ? static_cast<uint8_t>((x + y) % 2 ? 255 : 0)
                                        : noise.Next();
    }
  }
  return m;
}

// RGBA image with random alpha: the presenter must show the colour and ignore alpha.
cv::Mat RgbaPattern(int width, int height) {
  cv::Mat m(height, width, CV_8UC4);
  Bytes noise(4242);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      m.at<cv::Vec4b>(y, x) = cv::Vec4b(noise.Next(), static_cast<uint8_t>((x + y) % 2 ? 200 : 3),
                                        static_cast<uint8_t>(x % 256), noise.Next());
    }
  }
  return m;
}

class Presenter : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = curvecheck::testing::FreshDir("presenter_test", true);
    StartXvfb();
  }

  void TearDown() override {
    if (x_display_) XCloseDisplay(x_display_);
    if (xvfb_) xvfb_->Stop();
    xvfb_.reset();
    fs::remove_all(dir_);
  }

  // Starts `Xvfb -displayfd`: the server picks a free display number and writes it when it accepts clients.
  void StartXvfb() {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    ::fcntl(fds[0], F_SETFD, FD_CLOEXEC);  // the write end stays open across exec, for Xvfb
    xvfb_ = std::make_unique<Child>();
    const int err = xvfb_->Start({"Xvfb", "-displayfd", std::to_string(fds[1]), "-screen", "0",
                                  std::to_string(kWidth) + "x" + std::to_string(kHeight) + "x24", "-nolisten", "tcp",
                                  "-noreset"},
                                 Environment({}, {}), dir_ / "xvfb.log");
    ::close(fds[1]);
    if (err != 0) {
      ::close(fds[0]);
      FAIL() << "cannot start Xvfb (" << std::strerror(err)
             << "); it is a project dependency: install the 'xvfb' Debian package (./bootstrap does)";
    }
    std::string number;
    const auto t0 = Clock::now();
    while (number.find('\n') == std::string::npos && SecondsSince(t0) < 15) {
      pollfd p{fds[0], POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      char c[16];
      const ssize_t n = ::read(fds[0], c, sizeof(c));
      if (n <= 0) break;
      number.append(c, static_cast<size_t>(n));
    }
    ::close(fds[0]);
    ASSERT_NE(number.find('\n'), std::string::npos)
        << "Xvfb did not report a display within 15 s; its log: " << Slurp(dir_ / "xvfb.log");
    display_ = ":" + number.substr(0, number.find('\n'));
    x_display_ = XOpenDisplay(display_.c_str());
    ASSERT_NE(x_display_, nullptr) << "cannot connect to Xvfb on " << display_;
  }

  std::string WritePng(const std::string& name, const cv::Mat& image) {
    const fs::path p = dir_ / name;
    EXPECT_TRUE(cv::imwrite(p.string(), image)) << p;
    return p.string();
  }

  // Starts `curvecheck present args...` on the Xvfb display with lavapipe.
  std::unique_ptr<Child> StartPresent(const std::vector<std::string>& args, std::vector<std::string> env = {},
                                      const std::vector<std::string>& unset = {}) {
    std::vector<std::string> argv = {CURVECHECK_BINARY, "present"};
    argv.insert(argv.end(), args.begin(), args.end());
    env.insert(env.begin(), {"DISPLAY=" + display_, std::string("VK_DRIVER_FILES=") + kLavapipe});
    auto child = std::make_unique<Child>();
    const int err = child->Start(argv, Environment(env, unset), dir_ / "err");
    EXPECT_EQ(err, 0) << "cannot start " << CURVECHECK_BINARY << ": " << std::strerror(err);
    return child;
  }

  std::string Stderr() const { return Slurp(dir_ / "err"); }

  // Waits for the next stdout line and checks it is "shown k/n path".
  void ExpectShown(Child& c, int k, int n, const std::string& path, double timeout_s = kStepSeconds) {
    const std::optional<std::string> line = c.ReadLine(timeout_s);
    ASSERT_TRUE(line) << "no 'shown " << k << "/" << n << "' line within " << timeout_s
                      << " s; stdout so far: " << c.all_stdout() << "; stderr: " << Stderr();
    EXPECT_EQ(*line, "shown " + std::to_string(k) + "/" + std::to_string(n) + " " + path);
  }

  // Grabs the root window and compares it with `expected` (gray, BGR or BGRA; alpha ignored) for equality.
  void ExpectScreenEquals(const cv::Mat& expected) {
    XImage* img = XGetImage(x_display_, DefaultRootWindow(x_display_), 0, 0, kWidth, kHeight, AllPlanes, ZPixmap);
    ASSERT_NE(img, nullptr);
    ASSERT_EQ(img->red_mask, 0xff0000u);
    ASSERT_EQ(img->green_mask, 0x00ff00u);
    ASSERT_EQ(img->blue_mask, 0x0000ffu);
    int mismatches = 0;
    std::string first;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const unsigned long px = XGetPixel(img, x, y);
        const int r = static_cast<int>((px >> 16) & 0xff), g = static_cast<int>((px >> 8) & 0xff),
                  b = static_cast<int>(px & 0xff);
        int er = 0, eg = 0, eb = 0;
        if (expected.channels() == 1) {
          er = eg = eb = expected.at<uint8_t>(y, x);
        } else {
          const uint8_t* e = expected.ptr<uint8_t>(y) + static_cast<ptrdiff_t>(x) * expected.channels();
          eb = e[0], eg = e[1], er = e[2];
        }
        if (r != er || g != eg || b != eb) {
          if (mismatches++ < 5) {
            first += "(" + std::to_string(x) + "," + std::to_string(y) + "): screen " + std::to_string(r) + "," +
                     std::to_string(g) + "," + std::to_string(b) + " expected " + std::to_string(er) + "," +
                     std::to_string(eg) + "," + std::to_string(eb) + "; ";
          }
        }
      }
    }
    XDestroyImage(img);
    EXPECT_EQ(mismatches, 0) << "first mismatches (RGB): " << first;
  }

  // Sends a key press and release for `keysym` to the presenter's window (the mapped top-level window).
  void PressKey(KeySym keysym) {
    Window root = DefaultRootWindow(x_display_), parent = 0, *children = nullptr, target = 0;
    unsigned int count = 0;
    ASSERT_TRUE(XQueryTree(x_display_, root, &root, &parent, &children, &count));
    for (unsigned int i = 0; i < count; ++i) {
      XWindowAttributes a;
      if (XGetWindowAttributes(x_display_, children[i], &a) && a.map_state == IsViewable && a.width == kWidth) {
        target = children[i];
      }
    }
    if (children) XFree(children);
    ASSERT_NE(target, 0u) << "no presenter window on " << display_;
    for (int type : {KeyPress, KeyRelease}) {
      XKeyEvent e{};
      e.type = type;
      e.display = x_display_;
      e.window = target;
      e.root = root;
      e.same_screen = True;
      e.keycode = XKeysymToKeycode(x_display_, keysym);
      e.time = CurrentTime;
      XEvent event{};
      event.xkey = e;
      XSendEvent(x_display_, target, True, type == KeyPress ? KeyPressMask : KeyReleaseMask, &event);
    }
    XSync(x_display_, False);
  }

  // Exit 1 with exactly one line on stderr containing every piece.
  void ExpectRefused(Child& c, const std::vector<std::string>& pieces) {
    const std::optional<int> code = c.Wait(kStartSeconds);
    ASSERT_TRUE(code) << "still running after " << kStartSeconds << " s";
    EXPECT_EQ(*code, 1);
    const std::string err = Stderr();
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    for (const std::string& p : pieces) EXPECT_THAT(err, HasSubstr(p));
    EXPECT_EQ(c.all_stdout(), "");
  }

  fs::path dir_;
  std::unique_ptr<Child> xvfb_;
  std::string display_;
  Display* x_display_ = nullptr;
};

TEST_F(Presenter, ShowsEachImagePixelExactAndStepsOnSignals) {
  const cv::Mat colour = ColourPattern(kWidth, kHeight), gray = GrayPattern(kWidth, kHeight);
  const std::string a = WritePng("colour.png", colour), b = WritePng("gray.png", gray);
  auto p = StartPresent({"--windowed", "--display", "0", a, b});
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 1, 2, a, kStartSeconds));
  ExpectScreenEquals(colour);
  ::kill(p->pid(), SIGUSR1);
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 2, 2, b));
  ExpectScreenEquals(gray);
  ::kill(p->pid(), SIGUSR1);  // after the last comes the first again
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 1, 2, a));
  ExpectScreenEquals(colour);
  ::kill(p->pid(), SIGTERM);
  EXPECT_EQ(p->Wait(kStepSeconds), std::optional<int>(0));
  EXPECT_EQ(Stderr(), "");
}

TEST_F(Presenter, ExclusiveFullscreenIsPixelExactToo) {
  const cv::Mat gray = GrayPattern(kWidth, kHeight);
  const std::string a = WritePng("gray.png", gray);
  auto p = StartPresent({a});
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 1, 1, a, kStartSeconds));
  ExpectScreenEquals(gray);
  ::kill(p->pid(), SIGINT);
  EXPECT_EQ(p->Wait(kStepSeconds), std::optional<int>(0));
  EXPECT_EQ(Stderr(), "");
}

TEST_F(Presenter, KeysStepBackAndForthAndQuit) {
  const cv::Mat rgba = RgbaPattern(kWidth, kHeight), colour = ColourPattern(kWidth, kHeight);
  const std::string a = WritePng("rgba.png", rgba), b = WritePng("colour.png", colour);
  auto p = StartPresent({"--windowed", a, b});
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 1, 2, a, kStartSeconds));
  ExpectScreenEquals(rgba);  // alpha ignored: the colour values are shown as stored
  PressKey(XK_Right);
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 2, 2, b));
  ExpectScreenEquals(colour);
  PressKey(XK_p);
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 1, 2, a));
  PressKey(XK_Left);  // before the first comes the last
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 2, 2, b));
  PressKey(XK_space);
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 1, 2, a));
  PressKey(XK_q);
  EXPECT_EQ(p->Wait(kStepSeconds), std::optional<int>(0));
  EXPECT_EQ(Stderr(), "");
}

TEST_F(Presenter, HoldMsAdvancesAndExitsAfterTheLast) {
  const std::string a = WritePng("a.png", GrayPattern(kWidth, kHeight)),
                    b = WritePng("b.png", ColourPattern(kWidth, kHeight)),
                    c = WritePng("c.png", RgbaPattern(kWidth, kHeight));
  auto p = StartPresent({"--windowed", "--hold-ms", "300", a, b, c});
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 1, 3, a, kStartSeconds));
  const auto t1 = Clock::now();
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 2, 3, b));
  ASSERT_NO_FATAL_FAILURE(ExpectShown(*p, 3, 3, c));
  EXPECT_GE(SecondsSince(t1), 0.6);  // two holds of 300 ms at least
  EXPECT_EQ(p->Wait(kStepSeconds), std::optional<int>(0));
  EXPECT_EQ(Stderr(), "");
}

TEST_F(Presenter, RefusesAnImageOfAnotherSize) {
  const std::string a = WritePng("small.png", GrayPattern(800, 600));
  auto p = StartPresent({"--windowed", a});
  ExpectRefused(*p, {a, "800x600", "1024x768", "never scales"});
}

TEST_F(Presenter, RefusesImagesOfDifferentSizes) {
  const std::string a = WritePng("a.png", GrayPattern(kWidth, kHeight)), b = WritePng("b.png", GrayPattern(640, 480));
  auto p = StartPresent({"--windowed", a, b});
  ExpectRefused(*p, {b, "640x480", "1024x768"});
}

TEST_F(Presenter, RefusesCorruptMissingAndSixteenBitFiles) {
  const std::string good = WritePng("good.png", GrayPattern(kWidth, kHeight));
  std::string bytes = Slurp(good);
  const fs::path truncated = dir_ / "truncated.png", garbage = dir_ / "garbage.png", missing = dir_ / "missing.png";
  std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::ofstream(garbage, std::ios::binary) << "this is not a PNG";
  {
    auto p = StartPresent({"--windowed", good, truncated.string()});
    ExpectRefused(*p, {truncated.string(), "cannot decode"});
  }
  {
    auto p = StartPresent({"--windowed", garbage.string()});
    ExpectRefused(*p, {garbage.string(), "cannot decode"});
  }
  {
    auto p = StartPresent({"--windowed", missing.string()});
    ExpectRefused(*p, {missing.string()});
  }
  {
    cv::Mat deep(kHeight, kWidth, CV_16UC1, cv::Scalar(1000));
    const std::string d = WritePng("deep.png", deep);
    auto p = StartPresent({"--windowed", d});
    ExpectRefused(*p, {d, "16-bit"});
  }
}

TEST_F(Presenter, RefusesWithoutADisplay) {
  const std::string a = WritePng("a.png", GrayPattern(kWidth, kHeight));
  {
    auto p = StartPresent({"--windowed", a}, {}, {"DISPLAY", "WAYLAND_DISPLAY"});
    ExpectRefused(*p, {"no display", "Xvfb"});
  }
  {
    // A display number with no server: no socket and no lock file.
    int dead = 5000 + ::getpid() % 1000;
    while (fs::exists("/tmp/.X11-unix/X" + std::to_string(dead)) ||
           fs::exists("/tmp/.X" + std::to_string(dead) + "-lock")) {
      ++dead;
    }
    auto p = StartPresent({"--windowed", a}, {"DISPLAY=:" + std::to_string(dead)});
    ExpectRefused(*p, {"no display", ":" + std::to_string(dead)});
  }
}

TEST_F(Presenter, RefusesAnOutputThatDoesNotExist) {
  const std::string a = WritePng("a.png", GrayPattern(kWidth, kHeight));
  auto p = StartPresent({"--windowed", "--display", "1", a});
  ExpectRefused(*p, {"--display 1", "no output 1", "1024x768"});
}

}  // namespace

namespace {

// `render --present`: the rendered pattern itself goes on screen, pixel for pixel.
TEST_F(Presenter, RenderPresentShowsTheRenderedPattern) {
  const fs::path monitor = dir_ / "xvfb-monitor.yaml";
  std::ofstream(monitor) << "name: Xvfb screen as a 1000R panel\nresolution: [" << kWidth << ", " << kHeight
                         << "]\ndiagonal_in: 24\nradius_mm: 1000\n";
  const std::string png = (dir_ / "pattern.png").string();
  std::vector<std::string> argv = {CURVECHECK_BINARY, "render", "--monitor", monitor.string(), "--pattern", "both",
                                   "--method", "exact", "-o", png, "--present", "--display", "0", "--hold-ms", "4000"};
  Child c;
  ASSERT_EQ(c.Start(argv, Environment({"DISPLAY=" + display_, std::string("VK_DRIVER_FILES=") + kLavapipe}, {}),
                    dir_ / "err"),
            0);
  std::optional<std::string> line;
  while ((line = c.ReadLine(kStartSeconds)) && line->rfind("shown", 0) != 0) {
  }
  ASSERT_TRUE(line) << "no 'shown' line; stdout: " << c.all_stdout() << "; stderr: " << Stderr();
  EXPECT_EQ(*line, "shown 1/1 " + png);
  ExpectScreenEquals(cv::imread(png, cv::IMREAD_UNCHANGED));
  const std::optional<int> code = c.Wait(10);
  ASSERT_TRUE(code);
  EXPECT_EQ(*code, 0);
}

}  // namespace
