// Issue 17 ("Robustness, round 2"), the outputs: what the `curvecheck` binary leaves when it is interrupted, run
// twice into one folder, or given outputs that collide with its inputs or with one another. Each test asserts the
// exit status, the one stderr line, and that nothing was lost (the files of the folder hashed before and after).
// The photos are small (the default scene's camera at a quarter of its resolution), made once per process.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <thread>

#include "core/camera_model.h"
#include "core/subprocess.h"
#include "tests/cli_test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using curvecheck::testing::CliRun;
using curvecheck::testing::ExpectOneLineFailure;
using curvecheck::testing::Slurp;
using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

// Every file under `dir` (hidden ones too), by path relative to it, with a hash of its contents.
std::map<std::string, size_t> Snapshot(const fs::path& dir) {
  std::map<std::string, size_t> files;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = std::hash<std::string>()(Slurp(e.path()));
  }
  return files;
}

std::vector<std::string> Names(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// Temporary files of WriteFileAtomic and OutputSet: ".NAME.tmpN" and ".STEM.tmpN.EXT".
std::vector<std::string> Temporaries(const fs::path& dir) {
  std::vector<std::string> tmp;
  for (const std::string& n : Names(dir)) {
    if (n.find(".tmp") != std::string::npos) tmp.push_back(n);
  }
  return tmp;
}

// Processes whose command line mentions `text` (a child left running after its parent was interrupted).
std::vector<std::string> ProcessesMentioning(const std::string& text) {
  std::vector<std::string> found;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string pid = e.path().filename().string();
    if (pid.find_first_not_of("0123456789") != std::string::npos || pid == std::to_string(::getpid())) continue;
    std::string cmdline = Slurp(e.path() / "cmdline");
    std::replace(cmdline.begin(), cmdline.end(), '\0', ' ');
    if (cmdline.find(text) != std::string::npos) found.push_back(pid + ": " + cmdline);
  }
  return found;
}

// Waits up to `seconds` for `ready`; false if it never held.
bool WaitFor(const std::function<bool()>& ready, double seconds) {
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (Clock::now() < end) {
    if (ready()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

// Exit status of a started child, waiting at most `seconds` (then it is killed and the test fails).
int WaitExit(ChildProcess& child, double seconds) {
  std::optional<int> status;
  WaitFor([&] { return (status = child.TryWait()).has_value(); }, seconds);
  if (!status) {
    ADD_FAILURE() << "the command did not end within " << seconds << " s";
    child.Signal(SIGKILL);
    return child.Wait();
  }
  return *status;
}

class RobustnessOutputs : public ::testing::Test {
 protected:
  // One folder per process (ctest runs each test in a process of its own, in parallel); a fresh one per test.
  static fs::path Shared() { return curvecheck::testing::ProcessDir("robustness_outputs_cli_test"); }
  void SetUp() override {
    dir_ = Shared() / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::create_directories(dir_);
    tmpdir_ = dir_ / "tmpdir";  // the TMPDIR of the commands: chart folders show there
    fs::create_directories(tmpdir_);
  }
  static void TearDownTestSuite() { fs::remove_all(Shared()); }

  static CliRun Curvecheck(const std::vector<std::string>& args, const std::string& env = "") {
    return curvecheck::testing::RunBinary(CURVECHECK_BINARY, args, Shared(), env);
  }
  ChildProcess Start(const std::vector<std::string>& args) {
    std::vector<std::string> argv = {"env", "TMPDIR=" + tmpdir_.string(), CURVECHECK_BINARY};
    argv.insert(argv.end(), args.begin(), args.end());
    return ChildProcess::Start(argv);
  }

  // The rendering, two photos of it (two noise seeds) and the camera model for them, made once per process.
  static const fs::path& Photos() {
    static const fs::path dir = [] {
      const fs::path d = Shared() / "photos";
      fs::create_directories(d);
      CameraModel cam = ReadCameraModel(fs::path(std::getenv("CURVECHECK_SOURCE_DIR")) /
                                        "datasets/cameras/default-24mp-opencv8.cameramodel");
      const double s = 0.25;  // pixel centres at integers: x' = (x + 0.5) s - 0.5
      cam.intrinsics[0] *= s;
      cam.intrinsics[1] *= s;
      cam.intrinsics[2] = (cam.intrinsics[2] + 0.5) * s - 0.5;
      cam.intrinsics[3] = (cam.intrinsics[3] + 0.5) * s - 0.5;
      cam.width = static_cast<int>(cam.width * s);
      cam.height = static_cast<int>(cam.height * s);
      WriteCameraModel(d / "small.cameramodel", cam);
      std::ofstream(d / "scene.yaml")
          << "format: curvecheck.scene/1\nmonitor: default\n"
          << "camera: {model: small.cameramodel, position_mm: [0, 0, 500], look_at_mm: [0, 0, -1000]}\n"
          << "optics: {supersample: 2, blur: gaussian, blur_px: 0.7}\nsensor: {full_well_e: 20000, bits: 8}\n";
      CliRun r = Curvecheck({"render", "--monitor", "default", "--viewpoint", "0,0,500", "--squares", "24x7", "-o",
                             (d / "a.png").string()});
      EXPECT_EQ(r.code, 0) << r.err;
      for (const std::string seed : {"1", "2"}) {
        r = Curvecheck({"capture", "synth", "--scene", (d / "scene.yaml").string(), "--display",
                        (d / "a.png").string(), "--set", "sensor.seed=" + seed, "-o",
                        (d / ("photo" + seed + ".png")).string()});
        EXPECT_EQ(r.code, 0) << r.err;
      }
      return d;
    }();
    return dir;
  }
  static std::vector<std::string> AnalyzeArgs(const fs::path& out, const std::vector<std::string>& photos) {
    std::vector<std::string> args = {"analyze", "--camera", (Photos() / "small.cameramodel").string(), "--pattern",
                                     (Photos() / "a.json").string()};
    args.insert(args.end(), photos.begin(), photos.end());
    args.insert(args.end(), {"-o", out.string()});
    return args;
  }
  static std::string Photo(int k) { return (Photos() / ("photo" + std::to_string(k) + ".png")).string(); }

  fs::path dir_, tmpdir_;
};

// Case 1. Interrupted in the middle of its report (gnuplot running, the new set staged beside the old one),
// analyze removes its temporaries, stops gnuplot, keeps the previous complete set and ends by the signal (130 for
// SIGINT); capture synth the same under SIGTERM (143), in the middle of its ray tracing.
TEST_F(RobustnessOutputs, InterruptedRunsLeaveNoTemporaryAndThePreviousSet) {
  const fs::path out = dir_ / "out";
  const CliRun first = Curvecheck(AnalyzeArgs(out, {Photo(1)}));
  ASSERT_EQ(first.code, 0) << first.err;
  const auto before = Snapshot(out);
  ASSERT_TRUE(before.count("result.json") && before.count("report.html") && before.count("overlay-photo1.png"));

  // The rerun (two photos, so a different set) is stopped once its first chart folder exists.
  ChildProcess rerun = Start(AnalyzeArgs(out, {Photo(1), Photo(2)}));
  const bool charting = WaitFor([&] { return !Names(tmpdir_).empty(); }, 60);
  ASSERT_TRUE(charting) << "no chart folder appeared in " << tmpdir_;
  rerun.Signal(SIGINT);
  EXPECT_EQ(WaitExit(rerun, 20), 130);
  EXPECT_THAT(Temporaries(out), ::testing::IsEmpty());
  EXPECT_THAT(Names(tmpdir_), ::testing::IsEmpty()) << "chart folders left";
  EXPECT_THAT(ProcessesMentioning(tmpdir_.string()), ::testing::IsEmpty()) << "gnuplot left running";
  EXPECT_EQ(Snapshot(out), before);  // the previous set, whole; no lock file either

  // capture synth at full size (seconds of ray tracing), SIGTERM half a second in.
  const fs::path photo = dir_ / "p.png";
  const CliRun synth = Curvecheck({"capture", "synth", "--scene", (Photos() / "scene.yaml").string(), "--display",
                                   (Photos() / "a.png").string(), "--scale", "0.25", "-o", photo.string()});
  ASSERT_EQ(synth.code, 0) << synth.err;
  const auto photo_before = Snapshot(dir_);
  const fs::path scene = dir_ / "big.yaml";  // the small camera's scene, its model at full size
  std::ofstream(scene) << "format: curvecheck.scene/1\nmonitor: default\n"
                       << "camera: {model: " << std::getenv("CURVECHECK_SOURCE_DIR")
                       << "/datasets/cameras/default-24mp-opencv8.cameramodel, position_mm: [0, 0, 500], "
                          "look_at_mm: [0, 0, -1000]}\n";
  const auto snapshot_without_scene = [&] {
    auto s = Snapshot(dir_);
    s.erase("big.yaml");
    return s;
  };
  ChildProcess big = Start({"capture", "synth", "--scene", scene.string(), "--display", (Photos() / "a.png").string(),
                            "-o", photo.string()});
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_FALSE(big.TryWait().has_value()) << "capture synth ended within 0.5 s: the test needs a longer run";
  big.Signal(SIGTERM);
  EXPECT_EQ(WaitExit(big, 20), 143);
  EXPECT_THAT(Temporaries(dir_), ::testing::IsEmpty());
  EXPECT_EQ(snapshot_without_scene(), photo_before);  // p.png and p.truth.json as they were
}

// Case 2. A second analyze into a folder that a first one is writing refuses at once and names the first; the
// first completes, and its result.json and report.html are one run's.
TEST_F(RobustnessOutputs, TwoRunsIntoOneFolderNeverMix) {
  const fs::path out = dir_ / "out";
  ChildProcess first = Start(AnalyzeArgs(out, {Photo(1)}));
  ASSERT_TRUE(WaitFor([&] { return fs::exists(out / ".curvecheck.lock"); }, 30));
  const CliRun second = Curvecheck(AnalyzeArgs(out, {Photo(2)}));
  ExpectOneLineFailure(second, {"curvecheck: error: -o: folder '" + out.string() +
                                    "' is in use by another curvecheck run (pid ",
                                "); wait for it to finish, or choose another output folder"});
  std::smatch pid;
  ASSERT_TRUE(std::regex_search(second.err, pid, std::regex("pid ([0-9]+)")));
  // The holder is the curvecheck that env(1) became: same pid.
  EXPECT_EQ(pid[1].str(), std::to_string(first.pid()));
  EXPECT_TRUE(second.out.empty()) << second.out;  // refused before any work
  EXPECT_EQ(WaitExit(first, 60), 0);
  const nlohmann::json result = nlohmann::json::parse(Slurp(out / "result.json"));
  ASSERT_EQ(result["inputs"]["photos"].size(), 1u);
  EXPECT_EQ(result["inputs"]["photos"][0]["name"], "photo1.png");
  const std::string html = Slurp(out / "report.html");
  std::smatch radius;
  ASSERT_TRUE(std::regex_search(html, radius, std::regex("id=\"radius-mm\"[^>]*data-value=\"([^\"]+)\"")));
  EXPECT_EQ(std::stod(radius[1].str()), result["fit"]["radius_mm"].get<double>());
  EXPECT_THAT(html, HasSubstr("photo1.png"));
  EXPECT_THAT(html, ::testing::Not(HasSubstr("photo2.png")));
  EXPECT_FALSE(fs::exists(out / ".curvecheck.lock"));

  // After it, a rerun into the same folder is fine.
  EXPECT_EQ(Curvecheck(AnalyzeArgs(out, {Photo(2)}) ).code, 0);
}

// Case 3. A failing analyze leaves no folder it made; every command checks where it will write before it works.
TEST_F(RobustnessOutputs, OutputsAreCheckedBeforeTheWorkAndAFailureLeavesNoFolder) {
  // Fails after making the folder (the camera model is read by the analysis): the nested folders go again.
  const fs::path out = dir_ / "new" / "deeper";
  CliRun r = Curvecheck({"analyze", "--camera", (dir_ / "missing.cameramodel").string(), "--pattern",
                         (Photos() / "a.json").string(), Photo(1), "-o", out.string()});
  ExpectOneLineFailure(r, {"missing.cameramodel: file does not exist; check the path"});
  EXPECT_FALSE(fs::exists(dir_ / "new"));
  // A photo without any pattern in it: everything is analysed, nothing written, no folder left.
  r = Curvecheck(AnalyzeArgs(out, {(Photos() / "a.png").string()}));
  EXPECT_EQ(r.code, 1);
  EXPECT_FALSE(fs::exists(dir_ / "new"));

  // Unwritable places are refused before the work: no summary printed, no seconds of tracing or solving.
  const std::string unwritable = ::geteuid() == 0 ? "/proc/1" : "/";
  r = Curvecheck(AnalyzeArgs(unwritable, {Photo(1)}));
  ExpectOneLineFailure(r, {"-o: folder '" + unwritable + "' is not writable; choose a folder you can write to"});
  EXPECT_TRUE(r.out.empty()) << r.out;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"capture", "synth", "--scene", (Photos() / "scene.yaml").string(), "--display",
                                 (Photos() / "a.png").string(), "-o", (dir_ / "nowhere" / "p.png").string()},
        std::vector<std::string>{"calibrate", "--board", "9x6", "--square-mm", "20", Photo(1), "-o",
                                 (dir_ / "nowhere" / "cam.cameramodel").string()},
        std::vector<std::string>{"render", "-o", (dir_ / "nowhere" / "x.png").string()}}) {
    const auto start = Clock::now();
    r = Curvecheck(args);
    const double s = std::chrono::duration<double>(Clock::now() - start).count();
    ExpectOneLineFailure(r, {"nowhere' does not exist; create it first"});
    EXPECT_TRUE(r.out.empty()) << args[0] << ": " << r.out;
    EXPECT_LT(s, 5) << args[0];
  }
  EXPECT_FALSE(fs::exists(dir_ / "nowhere"));
}

// Case 4. capture synth reads the display PNG, its pattern.json and the scene's camera model, and writes the photo
// and PHOTO.truth.json: `--display X.truth.png -o X.png` would replace the display's pattern.json (X.truth.json).
// The truth then takes the photo's whole file name (X.png.truth.json); a photo over an input is refused.
TEST_F(RobustnessOutputs, CaptureSynthNeverOverwritesItsInputs) {
  fs::copy_file(Photos() / "a.png", dir_ / "q.truth.png");
  fs::copy_file(Photos() / "a.json", dir_ / "q.truth.json");
  fs::copy_file(Photos() / "small.cameramodel", dir_ / "small.cameramodel");
  fs::copy_file(Photos() / "scene.yaml", dir_ / "scene.yaml");
  const auto before = Snapshot(dir_);
  const std::string scene = (dir_ / "scene.yaml").string();
  CliRun r = Curvecheck({"capture", "synth", "--scene", scene, "--display", (dir_ / "q.truth.png").string(), "-o",
                         (dir_ / "q.truth.png").string()});
  ExpectOneLineFailure(r, {(dir_ / "q.truth.png").string() + ": is an input of this command; choose another output path"});
  EXPECT_EQ(Snapshot(dir_), before);

  r = Curvecheck({"capture", "synth", "--scene", scene, "--display", (dir_ / "q.truth.png").string(), "-o",
                  (dir_ / "q.png").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("note: " + (dir_ / "q.truth.json").string() +
                               " is an input of this command, so the truth is written as " +
                               (dir_ / "q.png.truth.json").string()));
  const auto after = Snapshot(dir_);
  for (const auto& [name, hash] : before) EXPECT_EQ(after.at(name), hash) << name;  // q.truth.json kept
  EXPECT_EQ(after.size(), before.size() + 3);  // the photo, its truth and its camera model
  EXPECT_TRUE(after.count("q.cameramodel")) << "no camera model beside the photo";
  const nlohmann::json truth = nlohmann::json::parse(Slurp(dir_ / "q.png.truth.json"));
  EXPECT_EQ(truth["photo"], "q.png");
  EXPECT_EQ(truth["pattern_json"], (dir_ / "q.truth.json").string());
}

// Case 5. Two outputs of one render that are one file: refused, nothing written.
TEST_F(RobustnessOutputs, RenderOutputsThatAreOneFileAreRefused) {
  std::ofstream(dir_ / "x.json") << "{}";  // a file of the user's, kept
  const auto before = Snapshot(dir_);
  const std::string png = (dir_ / "x.png").string();
  CliRun r = Curvecheck({"render", "--error-map", png, "-o", png});
  ExpectOneLineFailure(r, {png + ": is written twice: as -o and as --error-map; give the outputs different names"});
  r = Curvecheck({"render", "--error-map", (dir_ / "x.json").string(), "-o", png});
  ExpectOneLineFailure(r, {"x.json: is written twice: as the pattern.json beside -o and as --error-map; "});
  // The same file spelled another way.
  r = Curvecheck({"render", "--error-map", (dir_ / "." / "sub" / ".." / "x.png").string(), "-o", png});
  ExpectOneLineFailure(r, {"is written twice: as -o and as --error-map"});
  EXPECT_EQ(Snapshot(dir_), before);
  r = Curvecheck({"render", "--error-map", (dir_ / "map.png").string(), "-o", png});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "map.png") && fs::exists(dir_ / "x.png"));
}

// Case 6. Photos sharing a file name get overlays of their own, and the report shows each photo's.
TEST_F(RobustnessOutputs, PhotosSharingAFileNameKeepSeparateOverlays) {
  fs::create_directories(dir_ / "x");
  fs::create_directories(dir_ / "y");
  fs::copy_file(Photo(1), dir_ / "x" / "p.png");
  fs::copy_file(Photo(2), dir_ / "y" / "p.png");
  const fs::path out = dir_ / "out";
  const CliRun r = Curvecheck(AnalyzeArgs(out, {(dir_ / "x" / "p.png").string(), (dir_ / "y" / "p.png").string()}));
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json result = nlohmann::json::parse(Slurp(out / "result.json"));
  ASSERT_EQ(result["inputs"]["photos"].size(), 2u);
  EXPECT_EQ(result["inputs"]["photos"][0]["name"], "p.png");
  EXPECT_EQ(result["inputs"]["photos"][1]["name"], "p-2.png");
  const std::string a = Slurp(out / "overlay-p.png"), b = Slurp(out / "overlay-p-2.png");
  ASSERT_FALSE(a.empty());
  ASSERT_FALSE(b.empty());
  EXPECT_NE(a, b);  // two noise seeds, two photos
  const std::string html = Slurp(out / "report.html");
  size_t images = 0;
  for (size_t at = html.find("class=\"overlay\""); at != std::string::npos;
       at = html.find("class=\"overlay\"", at + 1)) {
    ++images;
  }
  EXPECT_EQ(images, 2u);
  EXPECT_THAT(html, HasSubstr("data-photo=\"p-2.png\""));
}

// Case 7. `report` with a damaged overlay (its middle overwritten: the PNG signature and end intact) says so in
// the page and on stdout instead of embedding a broken image.
TEST_F(RobustnessOutputs, ReportSaysADamagedOverlayInsteadOfEmbeddingIt) {
  const fs::path out = dir_ / "out";
  ASSERT_EQ(Curvecheck(AnalyzeArgs(out, {Photo(1)})).code, 0);
  std::string png = Slurp(out / "overlay-photo1.png");
  ASSERT_GT(png.size(), 1000u);
  for (size_t i = png.size() / 3; i < png.size() / 3 + 200; ++i) png[i] = static_cast<char>(png[i] ^ 0x5a);
  std::ofstream(out / "overlay-photo1.png", std::ios::binary) << png;
  const CliRun r = Curvecheck({"report", (out / "result.json").string(), "-o", (dir_ / "page.html").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("0 overlay image(s) embedded, 1 missing"));
  EXPECT_THAT(r.out, HasSubstr("no overlay for photo1.png: overlay-photo1.png is damaged ("));
  EXPECT_TRUE(r.err.empty()) << r.err;
  const std::string html = Slurp(dir_ / "page.html");
  EXPECT_THAT(html, HasSubstr("No overlay image: overlay-photo1.png is damaged"));
  EXPECT_THAT(html, ::testing::Not(HasSubstr("class=\"overlay\"")));
}

// Case 8. The overlays' magnification costs no time (the vectors are clipped to the image); a factor that is not
// a positive finite number is refused.
TEST_F(RobustnessOutputs, AHugeMagnificationCostsNoTime) {
  // Against the default factor in the same conditions (the machine's load varies): before, 1e12 took 65 s.
  const auto seconds = [&](const std::string& factor) {
    auto args = AnalyzeArgs(dir_ / factor, {Photo(1)});
    args.insert(args.end(), {"--magnify", factor, "--no-report"});
    const auto start = Clock::now();
    const CliRun r = Curvecheck(args);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir_ / factor / "overlay-photo1.png"));
    return std::chrono::duration<double>(Clock::now() - start).count();
  };
  const double normal = seconds("50"), huge = seconds("1e12");
  EXPECT_LT(huge, 1.5 * normal + 3) << "--magnify 50: " << normal << " s";
  CliRun r;
  for (const std::string bad : {"inf", "nan", "0", "-5"}) {
    auto args = AnalyzeArgs(dir_ / "bad", {Photo(1)});
    args.insert(args.end(), {"--magnify", bad});
    r = Curvecheck(args);
    // inf and nan are refused by the number parser (core/decimal.h) before the factor's own check.
    if (bad == "inf" || bad == "nan") {
      ExpectOneLineFailure(r, {"--magnify: '" + bad + "' is not a finite number; give a decimal number such as 50"});
    } else {
      ExpectOneLineFailure(r, {"--magnify: ", " is not a positive finite factor; give e.g. 50"});
    }
  }
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

}  // namespace
}  // namespace curvecheck
