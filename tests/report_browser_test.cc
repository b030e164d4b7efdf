// report.html end to end: a real analysis (`render` -> `capture synth` -> `analyze`, the quarter-resolution camera
// of analyze_cli_test.cc and a true radius of 1080 mm on a nominal 1000R monitor) writes report.html; Debian's
// Chromium opens it headless and the rendered DOM must show the numbers of result.json (verdict, radius, sigma,
// interval, chosen model, feature count, one row per photo), every image must have decoded, the file must name no
// http(s) URL, and a screenshot must not be blank. Also `curvecheck report`: regenerating the page, a missing
// overlay, refusing to overwrite its input, a broken result.json.
//
// Chromium runs with --no-sandbox (the tests run as root, where its sandbox refuses to start), a private profile,
// and a dead proxy, so that any attempt to fetch from the network fails instead of reaching it. If chromium is not
// installed the tests fail saying so (scripts/debian-packages.txt lists it).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <string>

#include "core/camera_model.h"
#include "tests/cli_test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using curvecheck::testing::CliRun;
using curvecheck::testing::ExpectOneLineFailure;
using curvecheck::testing::Slurp;
using json = nlohmann::json;
using ::testing::HasSubstr;
using ::testing::Not;

class ReportBrowser : public ::testing::Test {
 protected:
  static fs::path Dir() { return curvecheck::testing::ProcessDir("report_browser_test"); }
  static CliRun Curvecheck(const std::vector<std::string>& args) {
    return curvecheck::testing::RunBinary(CURVECHECK_BINARY, args, Dir());
  }
  static fs::path Out() { return Dir() / "analysis"; }

  // The analysis every test reads. A failure here is kept and fails each test in SetUp (a failed
  // SetUpTestSuite would only mark the tests skipped, and ctest counts skipped tests as passed).
  static void SetUpTestSuite() { setup_failure_ = MakeAnalysis(); }
  static void TearDownTestSuite() { fs::remove_all(Dir()); }
  void SetUp() override { ASSERT_EQ(setup_failure_, "") << "setting up the analysis failed"; }

  static std::string MakeAnalysis() {
    curvecheck::testing::FreshDir("report_browser_test");
    // The default scene's 24 MP OPENCV8 lens at a quarter of the resolution (as in analyze_cli_test.cc).
    CameraModel cam = ReadCameraModel(fs::path(std::getenv("CURVECHECK_SOURCE_DIR")) /
                                      "datasets/cameras/default-24mp-opencv8.cameramodel");
    const double s = 0.25;
    cam.intrinsics[0] *= s;
    cam.intrinsics[1] *= s;
    cam.intrinsics[2] = (cam.intrinsics[2] + 0.5) * s - 0.5;
    cam.intrinsics[3] = (cam.intrinsics[3] + 0.5) * s - 0.5;
    cam.width = static_cast<int>(cam.width * s);
    cam.height = static_cast<int>(cam.height * s);
    WriteCameraModel(Dir() / "small.cameramodel", cam);
    CliRun r = Curvecheck({"render", "--monitor", "default", "--viewpoint", "0,0,500", "--squares", "24x7",
                           "--method", "exact", "-o", (Dir() / "pattern.png").string()});
    if (r.code != 0) return "render: " + r.err;
    std::ofstream(Dir() / "scene.yaml")
        << "format: curvecheck.scene/1\nmonitor: default\n"
        << "camera: {model: small.cameramodel, position_mm: [0, 0, 500], look_at_mm: [0, 0, -1000]}\n"
        << "true_monitor: {radius_mm: 1080}\n"
        << "optics: {supersample: 2, blur: gaussian, blur_px: 0.7, vignetting: 0.2, exposure: 0.9}\n"
        << "sensor: {gamma: 1, full_well_e: 20000, read_noise_e: 3, seed: 3, bits: 8}\n";
    r = Curvecheck({"capture", "synth", "--scene", (Dir() / "scene.yaml").string(), "--display",
                    (Dir() / "pattern.png").string(), "-o", (Dir() / "photo.png").string()});
    if (r.code != 0) return "capture synth: " + r.err;
    r = Curvecheck({"analyze", "--camera", (Dir() / "small.cameramodel").string(), "--pattern",
                    (Dir() / "pattern.json").string(), (Dir() / "photo.png").string(), "-o", Out().string()});
    if (r.code != 0) return "analyze: " + r.err + r.out;
    std::cout << r.out;
    return "";
  }
  static inline std::string setup_failure_;

  // Chromium, headless, on `page`; extra: --dump-dom or --screenshot=...; returns its run (stdout = the DOM).
  static CliRun Chromium(const fs::path& page, const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"--headless", "--no-sandbox", "--disable-gpu",
                                     "--user-data-dir=" + (Dir() / "chromium-profile").string(),
                                     "--proxy-server=http://127.0.0.1:9", "--virtual-time-budget=10000",
                                     "--window-size=1280,3000"};
    args.insert(args.end(), extra.begin(), extra.end());
    args.push_back("file://" + fs::absolute(page).string());
    return curvecheck::testing::RunBinary("timeout", [&] {
      std::vector<std::string> with_timeout = {"120", "chromium"};
      with_timeout.insert(with_timeout.end(), args.begin(), args.end());
      return with_timeout;
    }(), Dir());
  }

  static void RequireChromium() {
    ASSERT_EQ(std::system("command -v chromium >/dev/null 2>&1"), 0)
        << "chromium is not installed: this test needs Debian's chromium package (scripts/debian-packages.txt; "
           "./bootstrap installs it)";
  }
};

// Plain string searches, not std::regex: the page holds megabytes of base64 inside single tags, and libstdc++'s
// regex recurses per character.
// The start tag of the element with `id` in `dom`, "" if there is none.
std::string Tag(const std::string& dom, const std::string& id) {
  const size_t at = dom.find(" id=\"" + id + "\"");
  if (at == std::string::npos) return "";
  const size_t start = dom.rfind('<', at), end = dom.find('>', at);
  return dom.substr(start, end - start + 1);
}
std::string Attr(const std::string& tag, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const size_t at = tag.find(key);
  if (at == std::string::npos) return "(absent)";
  const size_t begin = at + key.size();
  return tag.substr(begin, tag.find('"', begin) - begin);
}
// The text of `<x id=...>text<`.
std::string Text(const std::string& dom, const std::string& id) {
  const std::string tag = Tag(dom, id);
  if (tag.empty()) return "(absent)";
  const size_t begin = dom.find(tag) + tag.size();
  return dom.substr(begin, dom.find('<', begin) - begin);
}

// The shown (rounded) text of `id` is the document's value to its last printed digit, and its data-value is the
// exact number.
void ExpectNumber(const std::string& dom, const std::string& id, double value) {
  SCOPED_TRACE(id);
  const std::string tag = Tag(dom, id);
  ASSERT_FALSE(tag.empty());
  EXPECT_EQ(std::strtod(Attr(tag, "data-value").c_str(), nullptr), value);
  const std::string text = Text(dom, id);
  const size_t dot = text.find('.');
  const int decimals = dot == std::string::npos ? 0 : static_cast<int>(text.size() - dot - 1);
  EXPECT_NEAR(std::strtod(text.c_str(), nullptr), value, 0.5 * std::pow(10.0, -decimals) + 1e-9) << text;
}

// The page (as Chromium rendered it) against result.json.
void ExpectPageShowsResult(const std::string& dom, const json& j) {
  const std::string verdict = Tag(dom, "verdict");
  EXPECT_EQ(Attr(verdict, "data-pass"), j["verification"]["pass"].get<bool>() ? "true" : "false");
  std::string verdict_name = j["verification"].value("verdict", "");
  for (char& ch : verdict_name) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  EXPECT_EQ(Text(dom, "verdict"), verdict_name);
  ExpectNumber(dom, "radius-mm", j["fit"]["radius_mm"].get<double>());
  ExpectNumber(dom, "radius-sigma-mm", j["fit"]["radius_sigma_mm"].get<double>());
  ExpectNumber(dom, "radius-ci95-lo-mm", j["fit"]["radius_ci95_mm"][0].get<double>());
  ExpectNumber(dom, "radius-ci95-hi-mm", j["fit"]["radius_ci95_mm"][1].get<double>());
  ExpectNumber(dom, "p95-display-px", j["verification"]["p95_display_px"].get<double>());
  ExpectNumber(dom, "feature-count", static_cast<double>(j["features"].size()));
  EXPECT_EQ(Attr(Tag(dom, "chosen-model"), "data-value"), j["fit"]["model"].get<std::string>());
  for (const json& p : j["inputs"]["photos"]) {
    const std::string name = p["name"];
    SCOPED_TRACE(name);
    const size_t at = dom.find("<tr data-photo=\"" + name + "\"");
    ASSERT_NE(at, std::string::npos);
    const std::string row = dom.substr(at, dom.find('>', at) - at + 1);
    EXPECT_EQ(Attr(row, "data-status"), p["status"].get<std::string>());
    EXPECT_EQ(Attr(row, "data-features"), std::to_string(p["detection"]["features"].get<int>()));
    EXPECT_EQ(std::strtod(Attr(row, "data-rms-px").c_str(), nullptr), p["verification"]["rms_px"].get<double>());
  }
}

TEST_F(ReportBrowser, ChromiumRendersThePageWithTheNumbersOfResultJson) {
  RequireChromium();
  const fs::path page = Out() / "report.html";
  ASSERT_TRUE(fs::exists(page));
  const json j = json::parse(Slurp(Out() / "result.json"));
  ASSERT_FALSE(j["fit"]["radius_mm"].is_null()) << j["fit"].dump(1);

  // Self-contained: no URL, every src a data: URI.
  const std::string file = Slurp(page);
  EXPECT_THAT(file, Not(HasSubstr("http://")));
  EXPECT_THAT(file, Not(HasSubstr("https://")));
  // The charts are PNG, the photo's overlay JPEG (issue 18: a small page).
  int sources = 0, jpeg = 0;
  for (size_t at = file.find("src="); at != std::string::npos; at = file.find("src=", at + 1), ++sources) {
    if (file.substr(at, 28) == "src=\"data:image/jpeg;base64,") {
      ++jpeg;
    } else {
      EXPECT_EQ(file.substr(at, 27), "src=\"data:image/png;base64,");
    }
  }
  EXPECT_EQ(sources, 5);
  EXPECT_EQ(jpeg, 1);

  const CliRun r = Chromium(page, {"--dump-dom"});
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_THAT(r.out, HasSubstr("</html>")) << r.err;
  ExpectPageShowsResult(r.out, j);
  // Every image decoded: the overlay and four charts (radius by model, residual histogram, deviation map, the
  // photo's residual map).
  const std::string body = r.out.substr(r.out.find("<body"), r.out.find('>', r.out.find("<body")) - r.out.find("<body"));
  const std::string images = Attr(body, "data-images-ok");
  std::smatch m;
  ASSERT_TRUE(std::regex_match(images, m, std::regex("([0-9]+)/([0-9]+)"))) << "the page's load script did not run: "
                                                                            << body;
  EXPECT_EQ(m[1].str(), m[2].str()) << "images decoded / images";
  EXPECT_EQ(std::stoi(m[2].str()), 5);
}

TEST_F(ReportBrowser, TheScreenshotIsNotBlank) {
  RequireChromium();
  const fs::path shot = Dir() / "shot.png";
  fs::remove(shot);
  const CliRun r = Chromium(Out() / "report.html", {"--screenshot=" + shot.string(), "--hide-scrollbars"});
  ASSERT_EQ(r.code, 0) << r.err;
  const cv::Mat img = cv::imread(shot.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty()) << r.err;
  EXPECT_EQ(img.cols, 1280);
  // Not blank: a good part of the page differs from the white background, in many colours (text, the overlay
  // photo, the charts' palettes).
  cv::Mat gray;
  cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
  const double inked = static_cast<double>(cv::countNonZero(gray < 200)) / static_cast<double>(gray.total());
  std::cout << "screenshot " << img.cols << " x " << img.rows << ", " << 100 * inked << "% inked\n";
  EXPECT_GT(inked, 0.02);  // measured 7% on this page; a blank page is 0
  cv::Scalar mean, stddev;
  cv::meanStdDev(img, mean, stddev);
  EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 60);
}

TEST_F(ReportBrowser, TheReportCommandRegeneratesThePage) {
  RequireChromium();
  const fs::path page = Dir() / "again" / "page.html";
  fs::create_directories(page.parent_path());
  const CliRun r = Curvecheck({"report", (Out() / "result.json").string(), "-o", page.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("1 overlay image(s) embedded"));
  const CliRun dom = Chromium(page, {"--dump-dom"});
  ASSERT_EQ(dom.code, 0) << dom.err;
  ExpectPageShowsResult(dom.out, json::parse(Slurp(Out() / "result.json")));
  EXPECT_THAT(dom.out, HasSubstr("data-images-ok=\"5/5\""));
}

TEST_F(ReportBrowser, AMissingOverlayIsSaidInThePage) {
  const fs::path dir = Dir() / "bare";
  fs::create_directories(dir);
  fs::copy_file(Out() / "result.json", dir / "result.json", fs::copy_options::overwrite_existing);
  const CliRun r = Curvecheck({"report", (dir / "result.json").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("no overlay for photo.png: overlay-photo.png was not found beside result.json"));
  const std::string page = Slurp(dir / "report.html");
  EXPECT_THAT(page, HasSubstr("No overlay image: overlay-photo.png was not found beside result.json."));
  EXPECT_THAT(page, HasSubstr("<img class=\"chart\""));  // the charts are still there
}

TEST_F(ReportBrowser, TheReportCommandNeverOverwritesItsInputAndRefusesBrokenDocuments) {
  const std::string before = Slurp(Out() / "result.json");
  const CliRun over = Curvecheck({"report", (Out() / "result.json").string(), "-o", (Out() / "result.json").string()});
  ExpectOneLineFailure(over, {"result.json", "is an input of this command"});
  EXPECT_EQ(Slurp(Out() / "result.json"), before);
  const CliRun overlay = Curvecheck({"report", (Out() / "result.json").string(), "-o",
                                     (Out() / "overlay-photo.png").string()});
  ExpectOneLineFailure(overlay, {"overlay-photo.png", "is an input of this command"});

  json j = json::parse(before);
  j["fit"]["candidates"][1]["radius_mm"] = "1080";
  fs::create_directories(Dir() / "broken");
  std::ofstream(Dir() / "broken" / "result.json") << j.dump();
  const CliRun broken = Curvecheck({"report", (Dir() / "broken" / "result.json").string()});
  ExpectOneLineFailure(broken, {"broken/result.json", "key 'fit.candidates[1].radius_mm' is a string"});
  EXPECT_FALSE(fs::exists(Dir() / "broken" / "report.html"));
}

TEST_F(ReportBrowser, AnalyzeWithNoReportWritesNone) {
  const fs::path out = Dir() / "no-report";
  const CliRun r = Curvecheck({"analyze", "--camera", (Dir() / "small.cameramodel").string(), "--pattern",
                               (Dir() / "pattern.json").string(), (Dir() / "photo.png").string(), "-o", out.string(),
                               "--no-fit", "--no-overlays", "--no-report"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "result.json"));
  EXPECT_FALSE(fs::exists(out / "report.html"));
}

}  // namespace
}  // namespace curvecheck
