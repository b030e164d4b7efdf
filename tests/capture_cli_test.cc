// End-to-end tests of `curvecheck capture`: without cameras (this machine has none) the camera paths fail with
// one clear line; import builds a session folder; a session runs the real presenter on Xvfb (lavapipe) with
// photos from a folder standing in for the camera.
#include "tests/cli_test_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>

namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr const char* kLavapipe = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";

using curvecheck::testing::CliRun;
using curvecheck::testing::Quote;
using curvecheck::testing::Slurp;

class CaptureCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("curvecheck_capture_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // env: "NAME=value" assignments put before the command ("-u NAME" unsets).
  CliRun Curvecheck(const std::vector<std::string>& args, const std::string& env = "") {
    return curvecheck::testing::RunBinary(CURVECHECK_BINARY, args, dir_, env);
  }

  void ExpectFailure(const CliRun& r, const std::vector<std::string>& pieces) {
    curvecheck::testing::ExpectOneLineFailure(r, pieces);
  }

  // A flat 1024x768 monitor's pattern (the Xvfb screen's size), rendered with lavapipe.
  fs::path RenderPattern() {
    const fs::path monitor = dir_ / "monitor.yaml";
    std::ofstream(monitor) << "resolution: [1024, 768]\ndiagonal_in: 20\nradius_mm: flat\n";
    const fs::path png = dir_ / "pattern.png";
    const CliRun r = Curvecheck({"render", "--monitor", monitor.string(), "--viewpoint", "0,0,600", "-o", png.string()},
                                std::string("VK_DRIVER_FILES=") + kLavapipe);
    EXPECT_EQ(r.code, 0) << r.err;
    return png;
  }

  fs::path PhotoFolder(int n) {
    const fs::path photos = dir_ / "photos";
    fs::create_directories(photos);
    for (int i = 0; i < n; ++i) {
      cv::imwrite((photos / ("IMG_" + std::to_string(1000 + i) + ".png")).string(),
                  cv::Mat(30, 40, CV_8UC3, cv::Scalar(10 * i, 20, 30)));
    }
    return photos;
  }

  fs::path dir_;
};

TEST_F(CaptureCli, NoV4l2Camera) {
  const CliRun r = Curvecheck({"capture", "camera", "--device", "/dev/video99", "-o", (dir_ / "x.png").string()});
  ExpectFailure(r, {"no camera found: /dev/video99 does not exist or cannot be opened",
                    "v4l2-ctl --list-devices", "--device"});
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
}

TEST_F(CaptureCli, NoGphoto2Camera) {
  const CliRun r = Curvecheck({"capture", "gphoto2", "-o", (dir_ / "x.jpg").string()});
  ExpectFailure(r, {"no camera found: libgphoto2 detected no camera", "gphoto2 --auto-detect"});
  EXPECT_FALSE(fs::exists(dir_ / "x.jpg"));
}

TEST_F(CaptureCli, UsageErrors) {
  EXPECT_EQ(Curvecheck({"capture"}).code, 2);
  EXPECT_EQ(Curvecheck({"capture", "camera", "--frames", "0", "-o", "x.png"}).code, 2);
  EXPECT_EQ(Curvecheck({"capture", "session", "--plan", (dir_ / "missing.yaml").string(), "-o", "s"}).code, 2);
  const CliRun help = Curvecheck({"capture", "--help"});
  EXPECT_EQ(help.code, 0);
  for (const char* sub : {"camera", "gphoto2", "session", "import"}) EXPECT_THAT(help.out, HasSubstr(sub));
  ExpectFailure(Curvecheck({"capture", "camera", "--device", "/dev/video99", "-o", (dir_ / "x.jpg").string()}),
                {"-o", "does not end in .png"});
}

TEST_F(CaptureCli, ImportAFolderWithACorruptPhoto) {
  const fs::path pattern = RenderPattern();
  const fs::path photos = PhotoFolder(2);
  std::ofstream(photos / "IMG_0999.png") << "not a png at all";
  const CliRun r = Curvecheck({"capture", "import", "--photos", photos.string(), "--pattern",
                               fs::path(pattern).replace_extension(".json").string(), "-o", (dir_ / "s").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("rejected IMG_0999.png: not a readable image"));
  EXPECT_THAT(r.out, HasSubstr("import: 2 photos imported, 1 rejected"));
  EXPECT_THAT(r.out, HasSubstr("import: 1 shot_0001.png"));
  const nlohmann::json m = nlohmann::json::parse(Slurp(dir_ / "s" / "manifest.json"));
  EXPECT_EQ(m["format"], "curvecheck.session/1");
  ASSERT_EQ(m["shots"].size(), 2u);
  EXPECT_TRUE(fs::exists(dir_ / "s" / m["shots"][0]["pattern"].get<std::string>()));
  EXPECT_TRUE(fs::exists(photos / "IMG_0999.png"));  // never moved
}

TEST_F(CaptureCli, ImportNeedsAValidPatternJson) {
  const fs::path photos = PhotoFolder(1);
  std::ofstream(dir_ / "p.json") << R"({"format": "curvecheck.pattern/1"})";
  ExpectFailure(Curvecheck({"capture", "import", "--photos", photos.string(), "--pattern", (dir_ / "p.json").string(),
                            "-o", (dir_ / "s").string()}),
                {"p.json"});
  EXPECT_FALSE(fs::exists(dir_ / "s"));
}

TEST_F(CaptureCli, SessionWithoutADisplayFailsClearly) {
  const fs::path pattern = RenderPattern();
  std::ofstream(dir_ / "plan.yaml") << "shots:\n  - pattern: pattern.png\n    repeat: 2\n";
  const CliRun r = Curvecheck({"capture", "session", "--plan", (dir_ / "plan.yaml").string(), "--source", "fake-folder",
                               PhotoFolder(2).string(), "-o", (dir_ / "s").string()},
                              "-u DISPLAY -u WAYLAND_DISPLAY");
  ExpectFailure(r, {"session stopped at shot 1/2", "curvecheck present", "--resume"});
  const nlohmann::json m = nlohmann::json::parse(Slurp(dir_ / "s" / "manifest.json"));
  EXPECT_EQ(m["shots"].size(), 0u);
}

// The whole production path: the presenter shows each pattern on Xvfb, the session waits for its "shown" line and
// the settle time, "photographs" (the next photo of a folder) and writes the session; then --resume on a complete
// session takes nothing more.
TEST_F(CaptureCli, SessionOnXvfbWithTheRealPresenter) {
  const fs::path pattern = RenderPattern();
  std::ofstream(dir_ / "plan.yaml") << "shots:\n  - pattern: pattern.png\n    viewpoint_mm: [0, 0, 600]\n"
                                       "    repeat: 3\n";
  const int display = 80 + ::getpid() % 100;
  const fs::path pid_file = dir_ / "xvfb.pid";
  const std::string start = "Xvfb :" + std::to_string(display) + " -screen 0 1024x768x24 -nolisten tcp >" +
                            Quote((dir_ / "xvfb.log").string()) + " 2>&1 & echo $! >" + Quote(pid_file.string());
  ASSERT_EQ(std::system(start.c_str()), 0);
  const fs::path socket = "/tmp/.X11-unix/X" + std::to_string(display);
  for (int i = 0; i < 150 && !fs::exists(socket); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(fs::exists(socket)) << Slurp(dir_ / "xvfb.log");
  const CliRun r =
      Curvecheck({"capture", "session", "--plan", (dir_ / "plan.yaml").string(), "--source", "fake-folder",
                  PhotoFolder(2).string(), "--windowed", "--settle-ms", "60", "-o", (dir_ / "s").string()},
                 "DISPLAY=:" + std::to_string(display) + " VK_DRIVER_FILES=" + kLavapipe);
  const CliRun again = Curvecheck(
      {"capture", "session", "--plan", (dir_ / "plan.yaml").string(), "--source", "fake-folder",
       (dir_ / "photos").string(), "--windowed", "--resume", "-o", (dir_ / "s").string()},
      "DISPLAY=:" + std::to_string(display) + " VK_DRIVER_FILES=" + kLavapipe);
  ::kill(std::stoi(Slurp(pid_file)), SIGTERM);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("capture: 3/3 shot_0003.png"));
  EXPECT_THAT(r.out, HasSubstr("session: 3 shots taken, 3 of 3"));
  const nlohmann::json m = nlohmann::json::parse(Slurp(dir_ / "s" / "manifest.json"));
  ASSERT_EQ(m["shots"].size(), 3u);
  EXPECT_EQ(m["shots"][2]["photo"], "shot_0003.png");
  EXPECT_THAT(m["shots"][0]["source"].get<std::string>(), StartsWith("fake (2 files"));
  EXPECT_TRUE(fs::exists(dir_ / "s" / m["shots"][0]["pattern_json"].get<std::string>()));
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_THAT(again.out, HasSubstr("session: 0 shots taken after 3 resumed"));
}

}  // namespace
