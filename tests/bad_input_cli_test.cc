// Bad input, command by command (issue 8, items 1, 2 and 5): every row of the README's "Bad input" table is a
// case here, run through the real `curvecheck` binary, asserting the exit code, that stderr is one line, and the
// pieces of that line (the file or option, what is wrong, what to do). Where a command writes, the test also
// checks that nothing was lost: no partial or temporary file, a previous output intact, inputs unmodified.
//
// How the hard cases are made without privileges or hardware:
// - a missing Vulkan device: VK_DRIVER_FILES / VK_ICD_FILENAMES point at an ICD json that does not exist;
// - a full disk: the child runs with RLIMIT_FSIZE (`ulimit -f`) and SIGXFSZ ignored, so its writes fail with
//   EFBIG exactly where a full disk fails them with ENOSPC (same code path in WriteFileAtomic);
// - a folder that is not writable: mode 0555; root ignores modes, so as root the folder is /proc/1 (no one can
//   create files there);
// - photos of a different pattern, a duplicated feature id, a camera model of another imager size: made from the
//   rig's own render and synthetic camera (small: a 1200 x 800 camera before a 27" flat monitor).
// - a Vulkan device lost in the middle of a render, or out of device memory (lavapipe never is): the test-only
//   layer VK_LAYER_CURVECHECK_fault (tests/vulkan_fault_layer.cc) between curvecheck and lavapipe returns
//   VK_ERROR_DEVICE_LOST / VK_ERROR_OUT_OF_DEVICE_MEMORY where CURVECHECK_VULKAN_FAULT says.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>
#include <vector>

#include "tests/cli_test_util.h"

namespace {
namespace fs = std::filesystem;
using curvecheck::testing::CliRun;
using curvecheck::testing::ExpectOneLineFailure;
using curvecheck::testing::Quote;
using curvecheck::testing::Slurp;
using ::testing::HasSubstr;

constexpr const char* kLavapipe = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";

struct Case {
  std::string name;                    // the README row
  std::vector<std::string> args;       // the command line
  std::vector<std::string> expected;   // pieces of the one stderr line
};

class BadInput : public ::testing::Test {
 protected:
  // One folder per process (ctest runs every test in its own process, in parallel); inputs are made on first use.
  static fs::path Dir() { return curvecheck::testing::ProcessDir("bad_input_cli_test"); }
  static fs::path P(const std::string& name) { return Dir() / name; }
  static std::string S(const std::string& name) { return P(name).string(); }

  static void SetUpTestSuite() {
    curvecheck::testing::FreshDir("bad_input_cli_test");
  }
  static void TearDownTestSuite() {
    ::chmod(Dir().c_str(), 0755);
    std::error_code ec;
    for (const auto& e : fs::recursive_directory_iterator(Dir(), ec)) ::chmod(e.path().c_str(), 0755);
    fs::remove_all(Dir(), ec);
  }

  // `curvecheck args...`; `shell` is put before the command in the same /bin/sh (e.g. "ulimit -f 4;").
  static CliRun Run(const std::vector<std::string>& args, const std::string& env = "", const std::string& shell = "") {
    if (shell.empty()) return curvecheck::testing::RunBinary(CURVECHECK_BINARY, args, Dir(), env);
    std::string cmd = shell + " exec " + (env.empty() ? "" : "env " + env + " ") + Quote(CURVECHECK_BINARY);
    for (const auto& a : args) cmd += " " + Quote(a);
    cmd += " >" + Quote(S("out")) + " 2>" + Quote(S("err"));
    const int status = std::system(cmd.c_str());
    CliRun r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
    r.out = Slurp(P("out"));
    r.err = Slurp(P("err"));
    return r;
  }

  static void Write(const std::string& name, const std::string& text) {
    std::ofstream(P(name), std::ios::binary) << text;
  }

  static void RunCases(const std::vector<Case>& cases, const std::string& env = "") {
    for (const Case& c : cases) {
      SCOPED_TRACE(c.name);
      ExpectOneLineFailure(Run(c.args, env), c.expected);
    }
  }

  // A folder the child cannot create files in (see the header comment).
  static fs::path UnwritableFolder() {
    if (::geteuid() == 0) return "/proc/1";
    const fs::path d = P("readonly");
    fs::create_directories(d);
    ::chmod(d.c_str(), 0555);
    return d;
  }

  // Files of `folder` whose name holds ".tmp" (WriteFileAtomic's temporary files).
  static std::vector<std::string> TempFiles(const fs::path& folder) {
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(folder)) {
      if (e.path().filename().string().find(".tmp") != std::string::npos) found.push_back(e.path().string());
    }
    return found;
  }

  // ---- Inputs, made once per process on first use ----

  // pattern.png/.json: a 10x6 checkerboard for the 27" flat monitor seen from (50, 30, 700) mm.
  static void Pattern() {
    if (fs::exists(P("pattern.json"))) return;
    const CliRun r = Run({"render", "--monitor", "27in-2560x1440-flat", "--viewpoint", "50,30,700", "--squares",
                          "10x6", "-o", S("pattern.png")});
    ASSERT_EQ(r.code, 0) << r.err;
  }
  // small.cameramodel (1200 x 800 px), scene.yaml and photo.png: the synthetic camera photographing pattern.png.
  static void Photo() {
    Pattern();
    if (fs::exists(P("photo.png"))) return;
    Write("small.cameramodel",
          "{ 'lensmodel': 'LENSMODEL_OPENCV8', 'intrinsics': [1400, 1400, 599.5, 399.5, -0.05, 0.02, 0.0002, "
          "-0.0002, -0.005, 0.001, 0.001, -0.001], 'imagersize': [1200, 800], 'extrinsics': [0,0,0,0,0,0] }\n");
    Write("scene.yaml", SceneText());
    const CliRun r = Run({"capture", "synth", "--scene", S("scene.yaml"), "--display", S("pattern.png"), "-o",
                          S("photo.png")});
    ASSERT_EQ(r.code, 0) << r.err;
  }
  static std::string SceneText(const std::string& camera_extra = "", const std::string& extra = "") {
    return "format: curvecheck.scene/1\nmonitor: 27in-2560x1440-flat\n"
           "camera: {model: small.cameramodel, position_mm: [50, 30, 700]" + camera_extra + "}\n"
           "optics: {supersample: 2, blur: gaussian, blur_px: 0.5}\nsensor: {seed: 3, bits: 8}\n" + extra;
  }
  // tags.png/.json and tags-photo.png: an AprilTag grid on the same monitor, photographed the same way.
  static void TagPhoto() {
    Photo();
    if (fs::exists(P("tags-photo.png"))) return;
    CliRun r = Run({"render", "--monitor", "27in-2560x1440-flat", "--viewpoint", "50,30,700", "--pattern", "apriltag",
                    "-o", S("tags.png")});
    ASSERT_EQ(r.code, 0) << r.err;
    r = Run({"capture", "synth", "--scene", S("scene.yaml"), "--display", S("tags.png"), "-o", S("tags-photo.png")});
    ASSERT_EQ(r.code, 0) << r.err;
  }
  // pattern.json with its first feature's id given to the second one too.
  static void DuplicateIdPattern() {
    Pattern();
    nlohmann::json j = nlohmann::json::parse(Slurp(P("pattern.json")));
    j["features"][1]["id"] = j["features"][0]["id"];
    Write("dup.json", j.dump());
    j = nlohmann::json::parse(Slurp(P("pattern.json")));
    j["features"][2]["id"] = "corner7";
    Write("unknown-id.json", j.dump());
  }
  static std::string PngBytes() { return Slurp(P("pattern.png")); }
  // The first half of a real JPEG (a grey gradient, 640 x 480): header and part of the image data, no end.
  static std::string HalfAJpeg() {
    cv::Mat img(480, 640, CV_8UC1);
    for (int y = 0; y < img.rows; ++y) img.row(y).setTo(cv::Scalar(y % 256));
    std::vector<uchar> jpeg;
    EXPECT_TRUE(cv::imencode(".jpg", img, jpeg));
    return std::string(jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(jpeg.size() / 2));
  }
};

// ---- info (and every command that reads a monitor spec or a viewpoint) ----

TEST_F(BadInput, Info) {
  const std::string rest = "diagonal_in: 49\nradius_mm: 1000\n";
  Write("malformed.yaml", "resolution: [5120, 1440\n" + rest);
  Write("missing.yaml", "resolution: [5120, 1440]\ndiagonal_in: 49\n");
  Write("type.yaml", "resolution: [5120, 1440]\ndiagonal_in: [49]\nradius_mm: 1000\n");
  Write("nan.yaml", "resolution: [5120, 1440]\ndiagonal_in: .nan\nradius_mm: 1000\n");
  Write("inf.yaml", "resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: .inf\n");
  Write("negative.yaml", "resolution: [5120, 1440]\ndiagonal_in: -49\nradius_mm: 1000\n");
  Write("radius.yaml", "resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: 50\n");
  Write("huge-radius.yaml", "resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: 1e9\n");
  Write("typo.yaml", "resolution: [5120, 1440]\ndiagonal: 49\nradius_mm: 1000\n");
  RunCases({
      {"malformed YAML", {"info", "--monitor", S("malformed.yaml")},
       {S("malformed.yaml"), "not valid YAML at line", "fix the syntax"}},
      {"missing key", {"info", "--monitor", S("missing.yaml")},
       {S("missing.yaml"), "key 'radius_mm' is missing", "give the nominal radius"}},
      {"wrong type", {"info", "--monitor", S("type.yaml")},
       {S("type.yaml"), "key 'diagonal_in' must be a number, got a list", "write a single number"}},
      {"NaN", {"info", "--monitor", S("nan.yaml")},
       {S("nan.yaml"), "key 'diagonal_in' is '.nan', not a finite number", "write a finite number"}},
      {"inf", {"info", "--monitor", S("inf.yaml")}, {S("inf.yaml"), "radius_mm", "not a finite number"}},
      {"negative size", {"info", "--monitor", S("negative.yaml")},
       {S("negative.yaml"), "key 'diagonal_in' is -49, but must be greater than zero", "give a positive value"}},
      {"absurd radius (small)", {"info", "--monitor", S("radius.yaml")},
       {S("radius.yaml"), "radius 50.0 mm is too small", "wrap more than 360 deg"}},
      {"absurd radius (large)", {"info", "--monitor", S("huge-radius.yaml")}, {S("huge-radius.yaml"), "which is flat for every purpose", "write radius_mm: flat"}},
      {"unknown key", {"info", "--monitor", S("typo.yaml")},
       {S("typo.yaml"), "key 'diagonal' is not a known key", "expected one of"}},
      {"missing monitor file", {"info", "--monitor", S("absent.yaml")},
       {S("absent.yaml"), "is neither a monitor preset nor an existing file", "give a YAML file or one of"}},
      {"viewpoint behind the screen", {"info", "--viewpoint", "0,0,-1200"},
       {"--viewpoint", "(0, 0, -1200) mm is on or behind the screen surface"}},
      {"malformed viewpoint", {"info", "--viewpoint", "0,0"}, {"--viewpoint", "expected 3 numbers, got 2"}},
      {"non-finite viewpoint", {"info", "--viewpoint", "0,inf,500"}, {"--viewpoint", "not finite"}},
  });
}

// ---- render ----

TEST_F(BadInput, Render) {
  Write("nan2.yaml", "resolution: [5120, 1440]\ndiagonal_in: .nan\nradius_mm: 1000\n");
  const std::string before = "resolution: [1280, 720]\ndiagonal_in: 27\nradius_mm: flat\n";
  RunCases({
      {"monitor spec with NaN", {"render", "--monitor", S("nan2.yaml"), "-o", S("x.png")},
       {S("nan2.yaml"), "key 'diagonal_in' is '.nan', not a finite number"}},
      {"viewpoint behind the screen", {"render", "--viewpoint", "0,0,-1500", "-o", S("x.png")},
       {"--viewpoint", "on or behind the screen"}},
      {"output not a .png", {"render", "-o", S("x.jpg")}, {"-o", "does not end in .png"}},
      {"output folder missing", {"render", "-o", S("missing-folder/x.png")}, {"missing-folder", "does not exist"}},
  });
  Write("mon.png", before);  // a monitor spec named .png, so that -o reaches the input check
  ExpectOneLineFailure(Run({"render", "--monitor", S("mon.png"), "--viewpoint", "0,0,600", "-o", S("mon.png")}),
                       {S("mon.png"), "is an input of this command", "choose another output path"});
  EXPECT_EQ(Slurp(P("mon.png")), before);
  EXPECT_FALSE(fs::exists(P("x.png")));
}

TEST_F(BadInput, RenderWithoutAVulkanDevice) {
  const CliRun r = Run({"render", "-o", S("x.png")},
                       "VK_DRIVER_FILES=/nonexistent/icd.json VK_ICD_FILENAMES=/nonexistent/icd.json");
  ExpectOneLineFailure(r, {"Vulkan", "install mesa-vulkan-drivers"});
  EXPECT_FALSE(fs::exists(P("x.png")));
}

// The environment that puts VK_LAYER_CURVECHECK_fault between curvecheck and lavapipe, breaking what `fault` says
// (tests/vulkan_fault_layer.cc); any other value (the tests use "none") passes everything through.
std::string FaultLayer(const std::string& fault) {
  return std::string("VK_LAYER_PATH=") + CURVECHECK_FAULT_LAYER_DIR +
         " VK_INSTANCE_LAYERS=VK_LAYER_CURVECHECK_fault CURVECHECK_VULKAN_FAULT=" + fault;
}

// The device lost at the first submit, or device memory exhausted: one line saying which, nothing written. The
// control run (the same layer, no fault) renders, so the failures are the faults', not the layer's.
TEST_F(BadInput, RenderWhenTheVulkanDeviceIsLostOrOutOfMemory) {
  const std::vector<std::string> args = {"render", "--monitor", "27in-2560x1440-flat", "--viewpoint", "0,0,600", "-o",
                                         S("lost.png")};
  CliRun r = Run(args, FaultLayer("none"));
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(P("lost.png")));
  fs::remove(P("lost.png"));
  fs::remove(P("lost.json"));

  r = Run(args, FaultLayer("device-lost"));
  ExpectOneLineFailure(r, {"curvecheck: error: Vulkan: the device was lost: ", "ErrorDeviceLost",
                           "run again; if it repeats, update the driver or use lavapipe"});
  r = Run(args, FaultLayer("out-of-device-memory"));
  ExpectOneLineFailure(r, {"curvecheck: error: Vulkan: out of memory: ", "ErrorOutOfDeviceMemory",
                           "close other programs that use the GPU"});
  EXPECT_FALSE(fs::exists(P("lost.png")));
  EXPECT_FALSE(fs::exists(P("lost.json")));
  EXPECT_THAT(TempFiles(Dir()), ::testing::IsEmpty());
}

// The device lost after the demo's first render went through: the demo stops with the same one line (not a crash
// in the clean-up of a lost device), and leaves no temporary file.
TEST_F(BadInput, DemoWhenTheVulkanDeviceIsLostMidway) {
  const fs::path out = P("demo-lost");
  const CliRun r = Run({"demo", "-o", out.string()}, FaultLayer("device-lost-after=1"));
  ExpectOneLineFailure(r, {"Vulkan: the device was lost: ", "ErrorDeviceLost", "run again"});
  if (fs::exists(out)) {
    for (const auto& e : fs::recursive_directory_iterator(out)) {
      EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
    }
  }
}

TEST_F(BadInput, RenderIntoAFolderThatIsNotWritable) {
  const fs::path folder = UnwritableFolder();
  const CliRun r = Run({"render", "--monitor", "27in-2560x1440-flat", "--viewpoint", "0,0,600", "-o",
                        (folder / "x.png").string()});
  ExpectOneLineFailure(r, {(folder / "x.png").string(), "cannot write in", "choose a writable output folder"});
}

// A full disk: the previous pattern.png/.json stay as they were and no temporary file is left.
TEST_F(BadInput, RenderOntoAFullDisk) {
  Pattern();
  const std::string png = Slurp(P("pattern.png")), json = Slurp(P("pattern.json"));
  const CliRun r = Run({"render", "--monitor", "27in-2560x1440-flat", "--viewpoint", "0,0,900", "--squares", "8x5",
                        "-o", S("pattern.png")},
                       "", "trap '' XFSZ; ulimit -f 4;");
  ExpectOneLineFailure(r, {S("pattern.png"), "write failed: File too large", "free disk space and run again"});
  EXPECT_EQ(Slurp(P("pattern.png")), png);
  EXPECT_EQ(Slurp(P("pattern.json")), json);
  EXPECT_THAT(TempFiles(Dir()), ::testing::IsEmpty());
}

// ---- capture synth ----

TEST_F(BadInput, CaptureSynth) {
  Photo();
  DuplicateIdPattern();
  const std::string png = PngBytes();
  const std::string json = Slurp(P("pattern.json"));
  // Display images beside a copy of the valid pattern.json (the command reads it first).
  const auto display = [&](const std::string& stem, const std::string& bytes) {
    Write(stem + ".png", bytes);
    Write(stem + ".json", json);
    return S(stem + ".png");
  };
  const std::string corrupt = display("garbage", "this is not a PNG at all");
  const std::string truncated = display("truncated", png.substr(0, png.size() / 2));
  const std::string jpeg_cut = display("cut-jpeg", HalfAJpeg());
  const std::string jpeg_header = display("bad-jpeg", std::string("\xFF\xD8\xFF\xE0\x00\x10JFIF", 10));
  const std::string photo_bytes = Slurp(P("photo.png"));
  const std::string small = display("small-display", photo_bytes);  // 1200 x 800, not the monitor's 2560 x 1440
  Write("dup.png", png);  // its pattern.json is dup.json
  Write("no-json.png", png);
  const auto scene = [&](const std::string& name, const std::string& text) {
    Write(name, text);
    return S(name);
  };
  const std::string no_camera = scene("no-camera.yaml", "format: curvecheck.scene/1\nmonitor: 27in-2560x1440-flat\n");
  const std::string nan_pos = scene("nan-pos.yaml", "format: curvecheck.scene/1\nmonitor: 27in-2560x1440-flat\n"
                                                    "camera: {model: small.cameramodel, position_mm: [0, .nan, 700]}\n");
  const std::string neg_blur = scene("neg-blur.yaml", "format: curvecheck.scene/1\nmonitor: 27in-2560x1440-flat\n"
                                                      "camera: {model: small.cameramodel, position_mm: [0, 0, 700]}\n"
                                                      "optics: {blur: gaussian, blur_px: -1}\n");
  const std::string type = scene("type.yaml", "format: curvecheck.scene/1\nmonitor: 27in-2560x1440-flat\n"
                                              "camera: {model: small.cameramodel, position_mm: [0, 0, 700]}\n"
                                              "sensor: {seed: [3]}\n");
  const std::string behind = scene("behind.yaml", "format: curvecheck.scene/1\nmonitor: 27in-2560x1440-flat\n"
                                                  "camera: {model: small.cameramodel, position_mm: [0, 0, -700]}\n");
  Write("garbage.cameramodel", "{ 'lensmodel': 'LENSMODEL_OPENCV8', 'intrinsics': [1400, ");
  const std::string bad_model = scene("bad-model.yaml", "format: curvecheck.scene/1\nmonitor: 27in-2560x1440-flat\n"
                                                        "camera: {model: garbage.cameramodel, position_mm: [0, 0, 700]}\n");
  const auto synth = [&](const std::string& scene_path, const std::string& display_path) {
    return std::vector<std::string>{"capture", "synth", "--scene", scene_path, "--display", display_path,
                                    "--scale", "0.25", "-o", S("out.png")};
  };
  RunCases({
      {"display not an image", synth(S("scene.yaml"), corrupt),
       {corrupt, "is not a PNG, JPEG, TIFF or BMP image", "give a PNG or JPEG file"}},
      {"display PNG truncated", synth(S("scene.yaml"), truncated),
       {truncated, "is a truncated PNG (no IEND chunk at its end)", "copy or export the file again"}},
      {"display JPEG truncated", synth(S("scene.yaml"), jpeg_cut),
       {jpeg_cut, "is a truncated JPEG (no end-of-image marker after its image data)", "copy or export"}},
      {"display JPEG with a damaged header", synth(S("scene.yaml"), jpeg_header),
       {jpeg_header, "is not a readable JPEG image (damaged or truncated header)", "give a complete PNG or JPEG"}},
      {"display of the wrong size for the monitor", synth(S("scene.yaml"), small),
       {small, "is 1200x800 px but the scene's monitor is 2560x1440 px", "show the PNG that render wrote"}},
      {"display without its pattern.json", synth(S("scene.yaml"), S("no-json.png")),
       {"no-json.json", "does not exist"}},
      {"pattern.json with a duplicated feature id", synth(S("scene.yaml"), S("dup.png")),
       {"dup.json", "appears twice"}},
      {"scene: missing key", synth(no_camera, S("pattern.png")), {no_camera, "camera", "missing"}},
      {"scene: NaN", synth(nan_pos, S("pattern.png")), {nan_pos, "not a finite number"}},
      {"scene: negative size", synth(neg_blur, S("pattern.png")),
       {neg_blur, "key 'optics.blur_px' is -1, below zero", "give 0 or more px"}},
      {"scene: wrong type", synth(type, S("pattern.png")), {type, "seed", "must be"}},
      {"scene: camera behind the screen", synth(behind, S("pattern.png")), {behind, "behind"}},
      {"scene: unreadable .cameramodel", synth(bad_model, S("pattern.png")),
       {"garbage.cameramodel", "is not a readable mrcal .cameramodel (mrcal's parser rejected it: ",
        "Error parsing", "regenerate it with `curvecheck calibrate`"}},
  });
  EXPECT_FALSE(fs::exists(P("out.png")));
  EXPECT_EQ(PngBytes(), png);
}

TEST_F(BadInput, CaptureSynthOntoAFullDiskOrAReadOnlyFolder) {
  Photo();
  const std::string photo = Slurp(P("photo.png")), truth = Slurp(P("photo.truth.json"));
  const std::vector<std::string> args = {"capture", "synth", "--scene", S("scene.yaml"), "--display",
                                         S("pattern.png"), "--set", "sensor.seed=9", "-o", S("photo.png")};
  ExpectOneLineFailure(Run(args, "", "trap '' XFSZ; ulimit -f 4;"),
                       {S("photo.png"), "write failed: File too large", "free disk space and run again"});
  EXPECT_EQ(Slurp(P("photo.png")), photo);
  EXPECT_EQ(Slurp(P("photo.truth.json")), truth);
  EXPECT_THAT(TempFiles(Dir()), ::testing::IsEmpty());
  const fs::path folder = UnwritableFolder();
  ExpectOneLineFailure(Run({"capture", "synth", "--scene", S("scene.yaml"), "--display", S("pattern.png"), "-o",
                            (folder / "p.png").string()}),
                       {(folder / "p.png").string(), "cannot write in", "choose a writable output folder"});
}

// ---- capture import / session ----

TEST_F(BadInput, CaptureImportAndSession) {
  Pattern();
  DuplicateIdPattern();
  fs::create_directories(P("bad-photos"));
  Write("bad-photos/IMG_1.png", "not a png");
  Write("bad-photos/IMG_2.jpg", std::string("\xFF\xD8\xFF\xE0", 4));
  fs::create_directories(P("good-photos"));
  fs::copy_file(P("pattern.png"), P("good-photos/IMG_1.png"), fs::copy_options::overwrite_existing);
  Write("plan-nokey.yaml", "shot:\n  - pattern: pattern.png\n");
  Write("plan-missing.yaml", "shots:\n  - pattern: nowhere.png\n");
  Write("plan.yaml", "shots:\n  - pattern: pattern.png\n");
  RunCases({
      {"import: no readable photo",
       {"capture", "import", "--photos", S("bad-photos"), "--pattern", S("pattern.json"), "-o", S("s1")},
       {S("bad-photos"), "none of its 2 photos is readable (IMG_1.png: not a readable image: is not a PNG",
        "IMG_2.jpg: not a readable image: is not a readable JPEG image (damaged or truncated header)",
        "replace or remove the damaged files"}},
      {"import: photo folder missing",
       {"capture", "import", "--photos", S("nowhere"), "--pattern", S("pattern.json"), "-o", S("s2")},
       {S("nowhere"), "is not a folder"}},
      {"import: pattern.json with a duplicated feature id",
       {"capture", "import", "--photos", S("good-photos"), "--pattern", S("dup.json"), "-o", S("s3")},
       {S("dup.json"), "appears twice"}},
      {"import: pattern.json with an unknown feature id",
       {"capture", "import", "--photos", S("good-photos"), "--pattern", S("unknown-id.json"), "-o", S("s3")},
       {S("unknown-id.json"), "is 'corner7', not a feature id"}},
      {"session: plan without 'shots'",
       {"capture", "session", "--plan", S("plan-nokey.yaml"), "--source", "fake-folder", S("good-photos"), "-o",
        S("s4")},
       {S("plan-nokey.yaml"), "key 'shot' is not a known key", "expected one of: shots"}},
      {"session: plan naming a missing pattern",
       {"capture", "session", "--plan", S("plan-missing.yaml"), "--source", "fake-folder", S("good-photos"), "-o",
        S("s5")},
       {"nowhere.png", "does not exist"}},
      {"session: --resume without a session",
       {"capture", "session", "--plan", S("plan.yaml"), "--source", "fake-folder", S("good-photos"), "--resume",
        "-o", S("s6")},
       {S("s6"), "has no manifest.json to resume"}},
  });
  for (const char* s : {"s1", "s2", "s3"}) EXPECT_FALSE(fs::exists(P(s))) << s;
  EXPECT_EQ(Slurp(P("bad-photos/IMG_1.png")), "not a png");
}

// An interrupted session keeps every shot already taken and resumes to completion (issue 8 item 2), through the
// real presenter on Xvfb: the "camera" is a folder of photos whose second one is damaged, so shot 2 of 3 fails;
// after the photo is repaired, --resume takes shots 2 and 3 and leaves shot 1 as it was.
TEST_F(BadInput, InterruptedSessionKeepsItsShotsAndResumes) {
  const fs::path monitor = P("xvfb-monitor.yaml");
  std::ofstream(monitor) << "resolution: [1024, 768]\ndiagonal_in: 20\nradius_mm: flat\n";
  CliRun r = Run({"render", "--monitor", monitor.string(), "--viewpoint", "0,0,600", "-o", S("xvfb.png")},
                 std::string("VK_DRIVER_FILES=") + kLavapipe);
  ASSERT_EQ(r.code, 0) << r.err;
  std::ofstream(P("xvfb-plan.yaml")) << "shots:\n  - pattern: xvfb.png\n    repeat: 3\n";
  fs::create_directories(P("camera"));
  fs::copy_file(P("xvfb.png"), P("camera/IMG_1.png"), fs::copy_options::overwrite_existing);
  const std::string good = Slurp(P("xvfb.png"));
  Write("camera/IMG_2.png", good.substr(0, good.size() / 3));  // cut short, as by a failing card reader

  const int display = 100 + ::getpid() % 100;
  const std::string start = "Xvfb :" + std::to_string(display) + " -screen 0 1024x768x24 -nolisten tcp >" +
                            Quote(S("xvfb.log")) + " 2>&1 & echo $! >" + Quote(S("xvfb.pid"));
  ASSERT_EQ(std::system(start.c_str()), 0);
  const fs::path socket = "/tmp/.X11-unix/X" + std::to_string(display);
  for (int i = 0; i < 150 && !fs::exists(socket); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(fs::exists(socket)) << Slurp(P("xvfb.log"));
  const std::string env = "DISPLAY=:" + std::to_string(display) + " VK_DRIVER_FILES=" + kLavapipe;
  const std::vector<std::string> session = {"capture", "session", "--plan", S("xvfb-plan.yaml"), "--source",
                                            "fake-folder", S("camera"), "--windowed", "--settle-ms", "50", "-o",
                                            S("session")};
  const CliRun first = Run(session, env);
  const std::string shot1 = Slurp(P("session/shot_0001.png"));
  Write("camera/IMG_2.png", good);  // repaired
  std::vector<std::string> resume = session;
  resume.push_back("--resume");
  const CliRun second = Run(resume, env);
  ::kill(std::stoi(Slurp(P("xvfb.pid"))), SIGTERM);

  ExpectOneLineFailure(first, {S("session"), "session stopped at shot 2/3", "camera/IMG_2.png: is a truncated PNG",
                               "the 1 shot taken are in its manifest", "--resume"});
  EXPECT_THAT(first.out, HasSubstr("capture: 1/3 shot_0001.png"));
  ASSERT_EQ(second.code, 0) << second.err;
  EXPECT_THAT(second.out, HasSubstr("session: 2 shots taken after 1 resumed, 3 of 3"));
  const nlohmann::json m = nlohmann::json::parse(Slurp(P("session/manifest.json")));
  ASSERT_EQ(m["shots"].size(), 3u);
  EXPECT_EQ(m["shots"][2]["photo"], "shot_0003.png");
  EXPECT_EQ(Slurp(P("session/shot_0001.png")), shot1);
  EXPECT_FALSE(shot1.empty());
}

// ---- calibrate ----

TEST_F(BadInput, Calibrate) {
  Pattern();
  DuplicateIdPattern();
  Write("corrupt1.png", "not an image");
  Write("corrupt2.jpg", HalfAJpeg());
  const std::string blank = PngBytes();
  const fs::path folder = UnwritableFolder();
  RunCases({
      {"photos that cannot be read",
       {"calibrate", "--board", "9x6", "--square-mm", "25", S("corrupt1.png"), S("corrupt2.jpg"), "-o",
        S("cam.cameramodel")},
       {"photos", "only 0 of 2 photos show the whole 9x6 board"}},
      {"--board-from pattern.json with a duplicated feature id",
       {"calibrate", "--board-from", S("dup.json"), S("pattern.png"), "-o", S("cam.cameramodel")},
       {S("dup.json"), "appears twice"}},
      {"photo missing",
       {"calibrate", "--board", "9x6", "--square-mm", "25", S("absent.png"), "-o", S("cam.cameramodel")},
       {S("absent.png"), "is not a file"}},
  });
  const CliRun r = Run({"calibrate", "--board", "9x6", "--square-mm", "25", S("corrupt1.png"), S("corrupt2.jpg"),
                        "-o", S("cam.cameramodel")});
  EXPECT_THAT(r.out, HasSubstr(S("corrupt1.png") + ": is not a PNG, JPEG, TIFF or BMP image (unknown header); not used"));
  EXPECT_THAT(r.out, HasSubstr(S("corrupt2.jpg") + ": is a truncated JPEG (no end-of-image marker after its image data); not used"));
  EXPECT_FALSE(fs::exists(P("cam.cameramodel")));
}

// ---- analyze ----

TEST_F(BadInput, Analyze) {
  TagPhoto();
  DuplicateIdPattern();
  const std::string png = Slurp(P("photo.png"));
  Write("garbage.png", "not a photo at all");
  Write("truncated.png", png.substr(0, png.size() / 2));
  Write("truncated.jpg", HalfAJpeg());
  std::string huge = png;
  for (size_t at : {16u, 20u}) huge.replace(at, 4, std::string("\x00\x00\x75\x30", 4));  // 30000 x 30000 px
  Write("huge.png", huge);
  // A grey photo of the camera's size: no pattern in it.
  ASSERT_TRUE(cv::imwrite(S("blank.png"), cv::Mat(800, 1200, CV_8UC1, cv::Scalar(128))));
  const CliRun r = Run({"render", "--monitor", "27in-2560x1440-flat", "--viewpoint", "50,30,700", "--squares", "12x7",
                  "-o", S("other.png")});
  ASSERT_EQ(r.code, 0) << r.err;
  Write("garbage.cameramodel", "{ 'lensmodel': 'LENSMODEL_OPENCV8', 'intrinsics': [1400, ");
  std::string other_size = Slurp(P("small.cameramodel"));
  other_size.replace(other_size.find("[1200, 800]"), 11, "[1500, 1000]");
  Write("other-size.cameramodel", other_size);
  const auto analyze = [&](const std::string& camera, const std::string& pattern, const std::string& photo) {
    return std::vector<std::string>{"analyze", "--camera", S(camera), "--pattern", S(pattern), S(photo), "-o",
                                    S("analysis"), "--no-fit", "--no-overlays"};
  };
  RunCases({
      {"photo not an image", analyze("small.cameramodel", "pattern.json", "garbage.png"),
       {S("garbage.png"), "is not a PNG, JPEG, TIFF or BMP image"}},
      {"photo PNG truncated", analyze("small.cameramodel", "pattern.json", "truncated.png"),
       {S("truncated.png"), "is a truncated PNG (no IEND chunk at its end)", "copy the photo again"}},
      {"photo JPEG truncated", analyze("small.cameramodel", "pattern.json", "truncated.jpg"),
       {S("truncated.jpg"), "is a truncated JPEG (no end-of-image marker)", "copy the photo again"}},
      {"photo declaring 30000 x 30000 px", analyze("small.cameramodel", "pattern.json", "huge.png"),
       {S("huge.png"), "declares 30000 x 30000 px, outside 1 px .. 200 Mpx"}},
      {"photo of the wrong size for the camera model (a mismatched .cameramodel)",
       analyze("other-size.cameramodel", "pattern.json", "photo.png"),
       {S("photo.png"), "the photo is 1200 x 800 px but the camera model", "is for 1500 x 1000 px",
        "use the model calibrated for this camera at this resolution"}},
      {"photo with no pattern in it", analyze("small.cameramodel", "pattern.json", "blank.png"),
       {S("blank.png"), "pattern not found: no checkerboard of 9x5 inner corners"}},
      {"photo of a tag grid, pattern.json a checkerboard", analyze("small.cameramodel", "pattern.json",
                                                                  "tags-photo.png"),
       {S("tags-photo.png"), "different pattern: the photo shows tag36h11 tags", "not the 10x6 checkerboard"}},
      {"photo of a 10x6 checkerboard, pattern.json 12x7", analyze("small.cameramodel", "other.json", "photo.png"),
       {S("photo.png"), "no complete one of 11x6 inner corners", "a different pattern"}},
      {"pattern.json with a duplicated feature id", analyze("small.cameramodel", "dup.json", "photo.png"),
       {S("dup.json"), "appears twice"}},
      {"pattern.json with an unknown feature id", analyze("small.cameramodel", "unknown-id.json", "photo.png"),
       {S("unknown-id.json"), "is 'corner7', not a feature id"}},
      {"unreadable .cameramodel", analyze("garbage.cameramodel", "pattern.json", "photo.png"),
       {S("garbage.cameramodel"), "is not a readable mrcal .cameramodel (mrcal's parser rejected it: ",
        "Error parsing", "regenerate it with `curvecheck calibrate`"}},
      {"missing .cameramodel", analyze("nope.cameramodel", "pattern.json", "photo.png"),
       {S("nope.cameramodel"), "does not exist"}},
  });
  EXPECT_FALSE(fs::exists(P("analysis/result.json")));
  EXPECT_EQ(Slurp(P("photo.png")), png);
}

// With some bad photos, the good one is analysed and the others are listed with their reasons (exit 0).
TEST_F(BadInput, AnalyzeKeepsTheGoodPhotosAndListsTheRejected) {
  TagPhoto();
  const std::string png = Slurp(P("photo.png"));
  Write("truncated.png", png.substr(0, png.size() / 2));
  const CliRun r = Run({"analyze", "--camera", S("small.cameramodel"), "--pattern", S("pattern.json"),
                        S("truncated.png"), S("tags-photo.png"), S("photo.png"), "-o", S("mixed"), "--no-fit",
                        "--no-overlays"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("rejected: " + S("truncated.png") + ": is a truncated PNG"));
  EXPECT_THAT(r.out, HasSubstr("rejected: " + S("tags-photo.png") + ": different pattern"));
  const nlohmann::json j = nlohmann::json::parse(Slurp(P("mixed/result.json")));
  ASSERT_EQ(j["inputs"]["photos"].size(), 3u);
  EXPECT_EQ(j["inputs"]["photos"][0]["status"], "rejected");
  EXPECT_EQ(j["inputs"]["photos"][1]["status"], "rejected");
  EXPECT_EQ(j["inputs"]["photos"][2]["status"], "used");
}

TEST_F(BadInput, AnalyzeOntoAFullDiskOrAReadOnlyFolder) {
  Photo();
  const std::vector<std::string> args = {"analyze", "--camera", S("small.cameramodel"), "--pattern",
                                         S("pattern.json"), S("photo.png"), "--no-fit", "--no-overlays", "-o"};
  std::vector<std::string> first = args;
  first.push_back(S("full"));
  ASSERT_EQ(Run(first).code, 0);
  const std::string before = Slurp(P("full/result.json"));
  std::vector<std::string> again = args;
  again.insert(again.end() - 1, {"--tolerance", "0.2"});
  again.push_back(S("full"));
  ExpectOneLineFailure(Run(again, "", "trap '' XFSZ; ulimit -f 4;"),
                       {S("full/result.json"), "write failed: File too large", "free disk space and run again"});
  EXPECT_EQ(Slurp(P("full/result.json")), before);
  EXPECT_THAT(TempFiles(P("full")), ::testing::IsEmpty());
  std::vector<std::string> readonly = args;
  readonly.push_back(UnwritableFolder().string());
  ExpectOneLineFailure(Run(readonly), {"-o", "folder '" + UnwritableFolder().string() + "' is not writable",
                                       "choose a folder you can write to"});
}

}  // namespace
