// `curvecheck pattern` and `curvecheck check-screenshot` end to end (issue 19 parts 1-2), through the real binary:
// the pattern's three outputs and their contracts; an exact render checked as exact and `none` measured; a cropped
// capture refused with its reason and nothing written.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "tests/cli_test_util.h"

namespace {
namespace fs = std::filesystem;
using curvecheck::testing::CliRun;
using curvecheck::testing::Slurp;
using ::testing::HasSubstr;
using nlohmann::json;

class ThirdParty : public curvecheck::testing::CliTest {
 protected:
  ThirdParty() : CliTest("thirdparty") {}
  std::string P(const std::string& name) const { return (dir_ / name).string(); }
  static json Json(const fs::path& p) { return json::parse(Slurp(p)); }
  void Render(const std::string& name, const std::vector<std::string>& method) {
    std::vector<std::string> args = {"render", "--monitor", "49in-5120x1440-1000r", "--viewpoint", "0,0,500"};
    args.insert(args.end(), method.begin(), method.end());
    args.insert(args.end(), {"-o", P(name + ".png")});
    const CliRun r = Curvecheck(args);
    ASSERT_EQ(r.code, 0) << r.err;
  }
};

TEST_F(ThirdParty, PatternWritesTextureQuadAndExactPositions) {
  const CliRun r =
      Curvecheck({"pattern", "--monitor", "49in-5120x1440-1000r", "--viewpoint", "0,0,500", "-o", P("pat")});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("texture 5120 x 1440 px on the chord-plane quad"));
  const cv::Mat texture = cv::imread(P("pat/texture.png"), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(texture.empty());
  EXPECT_EQ(texture.cols, 5120);
  EXPECT_EQ(texture.rows, 1440);
  const json plane = Json(P("pat/plane.json")), pattern = Json(P("pat/pattern.json"));
  EXPECT_EQ(plane["format"], "curvecheck.plane/1");
  EXPECT_EQ(plane["texture"]["size_px"], json({5120, 1440}));
  EXPECT_EQ(plane["eye_mm"], json({0.0, 0.0, 500.0}));
  ASSERT_EQ(plane["corners"].size(), 4u);
  EXPECT_EQ(plane["corners"][0]["corner"], "top_left");
  EXPECT_EQ(plane["corners"][0]["uv_v_down"], json({0.0, 0.0}));
  EXPECT_EQ(plane["corners"][0]["uv_v_up"], json({0.0, 1.0}));
  // The chord plane of the 49" 1000R: z = -R cos(W / 2R), every corner on it, the eye 1326 mm in front.
  const double z = plane["plane"]["z_mm"].get<double>();
  EXPECT_NEAR(z, -825.9, 0.1);
  for (const json& c : plane["corners"]) {
    EXPECT_DOUBLE_EQ(c["in_screen_mm"][2].get<double>(), z);
    EXPECT_NEAR(c["from_eye_mm"][2].get<double>(), z - 500, 1e-9);
  }
  // pattern.json as `render` writes it: the same exact display positions as a render from this eye.
  EXPECT_EQ(pattern["format"], "curvecheck.pattern/1");
  Render("exact", {});
  const json rendered = Json(P("exact.json"));
  ASSERT_EQ(pattern["features"].size(), rendered["features"].size());
  for (size_t i = 0; i < pattern["features"].size(); ++i) {
    EXPECT_EQ(pattern["features"][i]["display_px"], rendered["features"][i]["display_px"]) << i;
  }
}

TEST_F(ThirdParty, CheckScreenshotMeasuresExactAndNoneAndRefusesACrop) {
  Render("exact", {});
  CliRun r = Curvecheck({"check-screenshot", "--pattern", P("exact.json"), P("exact.png"), "-o", P("cs-exact")});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("60 of 60 visible features measured"));
  const json exact = Json(P("cs-exact/screenshot_check.json"));
  EXPECT_EQ(exact["format"], "curvecheck.screenshot/1");
  EXPECT_LT(exact["max_px"].get<double>(), 0.02);
  EXPECT_EQ(exact["verdict"], "pass");
  ASSERT_EQ(exact["features"].size(), 60u);
  for (const char* key : {"id", "detected_px", "exact_px", "error_px"}) EXPECT_TRUE(exact["features"][0].contains(key));
  EXPECT_TRUE(fs::is_regular_file(P("cs-exact/error_map.png")));

  Render("none", {"--method", "none"});
  r = Curvecheck({"check-screenshot", "--pattern", P("none.json"), P("none.png"), "-o", P("cs-none")});
  ASSERT_EQ(r.code, 0) << r.err;  // a failed verdict is a result, not an error
  const json none = Json(P("cs-none/screenshot_check.json"));
  EXPECT_GT(none["max_px"].get<double>(), 20);
  EXPECT_EQ(none["verdict"], "fail");

  // A capture of a window's client area (30 rows lost to a title bar): refused, nothing written.
  const cv::Mat full = cv::imread(P("exact.png"), cv::IMREAD_GRAYSCALE);
  cv::imwrite(P("crop.png"), full(cv::Rect(0, 30, 5120, 1410)));
  r = Curvecheck({"check-screenshot", "--pattern", P("exact.json"), P("crop.png"), "-o", P("cs-crop")});
  curvecheck::testing::ExpectOneLineFailure(
      r, {P("crop.png"), "refused (wrong_size)", "5120 x 1410 px", "5120 x 1440 px", "full screen"});
  EXPECT_FALSE(fs::exists(P("cs-crop")));
}

}  // namespace
