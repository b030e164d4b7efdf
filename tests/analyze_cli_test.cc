// `curvecheck analyze` end to end, on photos made by the rig itself: `render` (Vulkan, lavapipe) ->
// `capture synth` (ray-traced, a true monitor of known radius) -> `analyze`, and the result.json checked against
// the truth. The camera is the default scene's 24 MP OPENCV8 lens scaled to 1500 x 1000 px (same field of view,
// a quarter of the resolution) to keep the test fast; everything else is the default scene.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include "core/camera_model.h"
#include "tests/cli_test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using curvecheck::testing::CliRun;
using curvecheck::testing::ExpectOneLineFailure;
using curvecheck::testing::Slurp;
using ::testing::HasSubstr;

class AnalyzeCli : public ::testing::Test {
 protected:
  // One folder per process: ctest runs each test in its own process, in parallel, and each sets up the suite.
  static fs::path Dir() { return curvecheck::testing::ProcessDir("analyze_cli_test"); }
  static CliRun Curvecheck(const std::vector<std::string>& args) {
    return curvecheck::testing::RunBinary(CURVECHECK_BINARY, args, Dir());
  }

  // A scene like datasets/scenes/default.yaml with the small camera and the given true radius.
  static fs::path WriteScene(const std::string& name, const std::string& true_radius) {
    const fs::path path = Dir() / (name + ".yaml");
    std::ofstream(path) << "format: curvecheck.scene/1\nmonitor: default\n"
                        << "camera: {model: small.cameramodel, position_mm: [0, 0, 500], look_at_mm: [0, 0, -1000]}\n"
                        << "true_monitor: {radius_mm: " << true_radius << "}\n"
                        << "optics: {supersample: 2, blur: gaussian, blur_px: 0.7, vignetting: 0.2, exposure: 0.9}\n"
                        << "sensor: {gamma: 1, full_well_e: 20000, read_noise_e: 3, seed: 3, bits: 8}\n";
    return path;
  }

  static void TearDownTestSuite() { fs::remove_all(Dir()); }
  static void SetUpTestSuite() {
    curvecheck::testing::FreshDir("analyze_cli_test");
    CameraModel cam = ReadCameraModel(fs::path(std::getenv("CURVECHECK_SOURCE_DIR")) /
                                      "datasets/cameras/default-24mp-opencv8.cameramodel");
    const double s = 0.25;  // pixel centres at integers: x' = (x + 0.5) s - 0.5
    cam.intrinsics[0] *= s;
    cam.intrinsics[1] *= s;
    cam.intrinsics[2] = (cam.intrinsics[2] + 0.5) * s - 0.5;
    cam.intrinsics[3] = (cam.intrinsics[3] + 0.5) * s - 0.5;
    cam.width = static_cast<int>(cam.width * s);
    cam.height = static_cast<int>(cam.height * s);
    WriteCameraModel(Dir() / "small.cameramodel", cam);
    for (const std::string method : {"exact", "none"}) {
      const CliRun r = Curvecheck({"render", "--monitor", "default", "--viewpoint", "0,0,500", "--squares", "24x7",
                                   "--method", method, "-o", (Dir() / (method + ".png")).string()});
      ASSERT_EQ(r.code, 0) << r.err;
    }
    // True radius 1080 mm on a nominal 1000R monitor (datasets/scenes/radius-8pct.yaml).
    const fs::path scene = WriteScene("scene", "1080");
    for (const std::string method : {"exact", "none"}) {
      const CliRun r = Curvecheck({"capture", "synth", "--scene", scene.string(), "--display",
                                   (Dir() / (method + ".png")).string(), "-o",
                                   (Dir() / ("photo-" + method + ".png")).string()});
      ASSERT_EQ(r.code, 0) << r.err;
    }
  }

  static nlohmann::json Result(const fs::path& dir) {
    return nlohmann::json::parse(Slurp(dir / "result.json"));
  }
};

TEST_F(AnalyzeCli, ARadius8PercentOffFailsTheVerificationAndIsMeasured) {
  // The pattern was rendered (exactly) for the nominal 1000R; the true monitor is 1080R. The correction is
  // therefore wrong for this monitor, and the verification must say so; the fit must find the true radius.
  const fs::path out = Dir() / "out-exact";
  const CliRun r = Curvecheck({"analyze", "--camera", (Dir() / "small.cameramodel").string(), "--pattern",
                               (Dir() / "exact.json").string(), (Dir() / "photo-exact.png").string(), "-o",
                               out.string()});
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const nlohmann::json j = Result(out);
  EXPECT_EQ(j["format"], "curvecheck.result/1");
  EXPECT_FALSE(j["verification"]["pass"].get<bool>());
  EXPECT_GT(j["verification"]["p95_display_px"].get<double>(), 0.5);
  // The error is seen (e beyond the tolerance), but at this quarter resolution (5 display px per camera px) U
  // holds the detector's systematic term of 2 x 0.05 x 5 = 0.5 display px, so the rule cannot state a fail:
  // inconclusive, never pass, with the advice to come closer.
  const nlohmann::json& v = j["verification"];
  EXPECT_GT(v["error_p95_display_px"].get<double>(), 0.5);
  EXPECT_NE(v["verdict"], "pass");
  EXPECT_THAT(r.out, ::testing::AnyOf(HasSubstr("verification: FAIL"), HasSubstr("verification: INCONCLUSIVE")));
  if (v["verdict"] == "inconclusive") {
    EXPECT_THAT(v["advice"].get<std::string>(), HasSubstr("m away"));
  }

  // The radius. At this quarter resolution (5 display px per camera px) the corner detector's pixel-locking
  // biased the radius by about 0.8% before issue 16 (1071.6 +- 1.5 mm for the true 1080 mm; now 1080.8 +- 2.3 with
  // the uncertainty budget), so this test asks for the truth within 2% and the nominal excluded.
  const nlohmann::json& fit = j["fit"];
  ASSERT_FALSE(fit["radius_mm"].is_null()) << fit.dump(1);
  const double radius = fit["radius_mm"];
  const double lo = fit["radius_ci95_mm"][0], hi = fit["radius_ci95_mm"][1];
  std::cout << "radius " << radius << " +- " << fit["radius_sigma_mm"] << " mm, 95% [" << lo << ", " << hi
            << "], model " << fit["model"] << "\n";
  EXPECT_EQ(fit["model"], "cylinder");
  EXPECT_NEAR(radius, 1080, 0.02 * 1080);
  EXPECT_GT(lo, 1000) << "the nominal radius should be excluded";
  // Every candidate is reported; the camera is 1.5 m in front of the screen centre.
  EXPECT_GE(fit["candidates"].size(), 5u);
  EXPECT_NEAR(fit["cameras"][0]["position_in_centre_mm"][2].get<double>(), 1500, 15);

  // Features: every one of the 23 x 6 corners, each with a detection, an expected position and residuals.
  EXPECT_EQ(j["features"].size(), 23u * 6u);
  for (const auto& f : j["features"]) {
    ASSERT_TRUE(f.contains("residual_px")) << f.dump();
    ASSERT_TRUE(f.contains("fit_residual_px")) << f.dump();
    EXPECT_LT(std::hypot(f["fit_residual_px"][0].get<double>(), f["fit_residual_px"][1].get<double>()), 0.3)
        << f.dump();
  }
  EXPECT_TRUE(fs::exists(out / "overlay-photo-exact.png"));
  // The detection-noise row's assumption is tested (23 x 6 corners: 22 x 6 pairs along the screen's rows, 23 x 5
  // along its columns) and the test is stated under the report's budget table.
  const nlohmann::json& ni = fit["uncertainty_budget"]["detection_noise_independence"];
  ASSERT_TRUE(ni["tested"].get<bool>()) << ni.dump(1);
  EXPECT_EQ(ni["pairs"]["along_rows"].get<int>(), 22 * 6);
  EXPECT_EQ(ni["pairs"]["along_columns"].get<int>(), 23 * 5);
  const std::string report = Slurp(out / "report.html");
  EXPECT_THAT(report, HasSubstr("id=\"noise-independence\""));
  EXPECT_THAT(report, HasSubstr(ni["independent"].get<bool>() ? "independent errors:"
                                                               : "independent errors, contradicted"));
}

// The detector's pixel-locking (issue 16): the verification estimates it on every photo (result.json), and
// `--correct-pixel-locking` removes it before the fit. How large it is depends on the detector and the board: on
// the default 16 x 5 board at this resolution it was 0.047 px and the bulk of the detection error; on this 24 x 7
// board it reads 0.003-0.006 +- 0.002 px. Either way the estimate is small and sure, the verdict does not depend
// on the correction, and the corrected fit still holds the truth (1080 mm).
TEST_F(AnalyzeCli, PixelLockingIsEstimatedAndCanBeRemovedBeforeTheFit) {
  const std::string camera = (Dir() / "small.cameramodel").string(), pattern = (Dir() / "exact.json").string();
  const fs::path plain = Dir() / "out-locking-plain", corrected = Dir() / "out-locking-corrected";
  CliRun r = Curvecheck({"analyze", "--camera", camera, "--pattern", pattern, (Dir() / "photo-exact.png").string(),
                         "-o", plain.string(), "--no-report", "--no-overlays"});
  ASSERT_EQ(r.code, 0) << r.err;
  r = Curvecheck({"analyze", "--camera", camera, "--pattern", pattern, (Dir() / "photo-exact.png").string(), "-o",
                  corrected.string(), "--no-report", "--no-overlays", "--correct-pixel-locking"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json a = Result(plain), b = Result(corrected);
  const nlohmann::json& pl = a["inputs"]["photos"][0]["verification"]["pixel_locking"];
  ASSERT_TRUE(pl.is_object()) << a["inputs"].dump(1);
  for (int c = 0; c < 2; ++c) EXPECT_LT(pl["amplitude_px"][c].get<double>(), 0.08) << pl.dump();
  for (int k = 0; k < 4; ++k) EXPECT_LT(pl["sigma_px"][k].get<double>(), 0.01) << pl.dump();
  EXPECT_LE(pl["noise_without_px"].get<double>(), 1.01 * a["verification"]["noise_px"].get<double>());
  // The verdict does not depend on the correction (it is applied to the fit only).
  EXPECT_EQ(a["verification"]["verdict"], b["verification"]["verdict"]);
  EXPECT_EQ(a["verification"]["error_p95_display_px"], b["verification"]["error_p95_display_px"]);
  const double noise_a = a["fit"]["noise_px"], noise_b = b["fit"]["noise_px"];
  const double ra = a["fit"]["radius_mm"], rb = b["fit"]["radius_mm"];
  std::cout << "fit noise " << noise_a << " -> " << noise_b << " px; radius " << ra << " -> " << rb << " mm\n";
  EXPECT_LT(noise_b, 1.05 * noise_a);
  EXPECT_NEAR(rb, ra, 3 * b["fit"]["radius_sigma_mm"].get<double>());
  EXPECT_LE(b["fit"]["radius_ci95_mm"][0].get<double>(), 1080);
  EXPECT_GE(b["fit"]["radius_ci95_mm"][1].get<double>(), 1080);
}

// Data that does not fit what it claims is flagged, never passed (issue 15): the same photo content twice counts
// once (a copy in another folder under the same file name: the same sigma as the photo alone, yet each photo read
// has its own overlay, the copy's marked as a duplicate), and a model family that cannot fit (`--models flat` on
// a curved monitor) is inadequate with a warning, its verdict not a pass.
TEST_F(AnalyzeCli, DataThatDoesNotFitIsFlaggedNotPassed) {
  const std::string camera = (Dir() / "small.cameramodel").string(), pattern = (Dir() / "exact.json").string();
  fs::create_directories(Dir() / "copy");
  fs::copy_file(Dir() / "photo-exact.png", Dir() / "copy" / "photo-exact.png", fs::copy_options::overwrite_existing);
  const fs::path once = Dir() / "out-once", twice = Dir() / "out-twice", flat = Dir() / "out-flat";
  ASSERT_EQ(Curvecheck({"analyze", "--camera", camera, "--pattern", pattern, (Dir() / "photo-exact.png").string(),
                        "-o", once.string(), "--no-report"})
                .code,
            0);
  fs::remove_all(twice);
  const CliRun r = Curvecheck({"analyze", "--camera", camera, "--pattern", pattern,
                               (Dir() / "photo-exact.png").string(), (Dir() / "copy" / "photo-exact.png").string(),
                               "-o", twice.string(), "--no-report"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json a = Result(once), b = Result(twice);
  EXPECT_EQ(b["inputs"]["photos"][1]["status"], "rejected");
  EXPECT_THAT(b["inputs"]["photos"][1]["reason"].get<std::string>(), HasSubstr("the same image content as"));
  EXPECT_EQ(b["inputs"]["photos"][1]["name"], "photo-exact-2.png");
  EXPECT_EQ(b["inputs"]["photos"][1]["duplicate_of"], "photo-exact.png");
  EXPECT_DOUBLE_EQ(b["fit"]["radius_sigma_mm"].get<double>(), a["fit"]["radius_sigma_mm"].get<double>());
  EXPECT_EQ(b["verification"]["features"], a["verification"]["features"]);
  EXPECT_GT(a["verification"]["features"].get<int>(), 100);
  // The fit uses the content once: one camera, as many fitted features as the photo alone.
  EXPECT_EQ(b["fit"]["cameras"].size(), 1u);
  EXPECT_EQ(b["fit"]["cameras"].size(), a["fit"]["cameras"].size());
  // Two overlays, one per photo read, with distinct names; the copy's is a PNG of its own (its mark differs).
  size_t overlays = 0;
  for (const auto& e : fs::directory_iterator(twice)) overlays += e.path().filename().string().rfind("overlay-", 0) == 0;
  EXPECT_EQ(overlays, 2u);
  const std::string first = Slurp(twice / "overlay-photo-exact.png"), copy = Slurp(twice / "overlay-photo-exact-2.png");
  EXPECT_EQ(copy.substr(0, 4), "\x89PNG");
  EXPECT_GT(copy.size(), first.size() / 2);
  EXPECT_NE(copy, first);
  EXPECT_THAT(r.out, HasSubstr("overlay-photo-exact-2.png"));

  const CliRun f = Curvecheck({"analyze", "--camera", camera, "--pattern", pattern, "--models", "flat",
                               (Dir() / "photo-exact.png").string(), "-o", flat.string(), "--no-report"});
  ASSERT_EQ(f.code, 0) << f.err;
  const nlohmann::json j = Result(flat);
  EXPECT_EQ(j["fit"]["status"], "inadequate");
  EXPECT_FALSE(j["fit"]["candidates"][0]["adequate"].get<bool>());
  EXPECT_GT(j["fit"]["candidates"][0]["noise_ratio"].get<double>(), 10);
  EXPECT_THAT(j["fit"]["warnings"].dump(), HasSubstr("--models flat"));
  EXPECT_NE(j["verification"]["verdict"], "pass");
  EXPECT_THAT(f.out, HasSubstr("flat INADEQUATE"));
  // The cylinder fits the same photo to its noise.
  EXPECT_EQ(a["fit"]["status"], "ok");
  EXPECT_TRUE(a["fit"]["adequate"].get<bool>());
  // Each camera position with the sigma of its own frame: the axis frame's z moves with the radius.
  const nlohmann::json& cam = a["fit"]["cameras"][0];
  EXPECT_EQ(cam["position_mm"], cam["position_in_axis_mm"]);
  EXPECT_GT(cam["position_in_axis_sigma_mm"][2].get<double>(), 0.5 * a["fit"]["radius_sigma_mm"].get<double>());
  EXPECT_LT(cam["position_in_centre_sigma_mm"][2].get<double>(), cam["position_in_axis_sigma_mm"][2].get<double>());
}

TEST_F(AnalyzeCli, UncorrectedRenderingFailsTheVerificationByAWideMargin) {
  const fs::path out = Dir() / "out-none";
  const CliRun r = Curvecheck({"analyze", "--camera", (Dir() / "small.cameramodel").string(), "--pattern",
                               (Dir() / "none.json").string(), (Dir() / "photo-none.png").string(), "-o",
                               out.string(), "--no-fit"});
  ASSERT_EQ(r.code, 0) << r.err;  // a failed verification is a result, not an error
  EXPECT_THAT(r.out, HasSubstr("verification: FAIL"));
  const nlohmann::json j = Result(out);
  EXPECT_FALSE(j["verification"]["pass"].get<bool>());
  EXPECT_GT(j["verification"]["p95_display_px"].get<double>(), 10 * j["verification"]["tolerance_display_px"].get<double>());
}

TEST_F(AnalyzeCli, BadPhotosAreRejectedWithReasonsAndTheGoodOnesAnalysed) {
  std::ofstream(Dir() / "corrupt.png") << "\x89PNG\r\n\x1a\n not really";
  const fs::path out = Dir() / "out-mixed";
  const CliRun r = Curvecheck({"analyze", "--camera", (Dir() / "small.cameramodel").string(), "--pattern",
                               (Dir() / "exact.json").string(), (Dir() / "corrupt.png").string(),
                               (Dir() / "exact.png").string(), (Dir() / "photo-exact.png").string(), "-o",
                               out.string(), "--no-fit", "--no-overlays"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = Result(out);
  const auto& photos = j["inputs"]["photos"];
  ASSERT_EQ(photos.size(), 3u);
  EXPECT_EQ(photos[0]["status"], "rejected");
  EXPECT_THAT(photos[0]["reason"].get<std::string>(), HasSubstr("corrupt.png"));
  // The display image itself is 5120 x 1440, not the camera's 1500 x 1000.
  EXPECT_EQ(photos[1]["status"], "rejected");
  EXPECT_THAT(photos[1]["reason"].get<std::string>(), HasSubstr("5120 x 1440 px but the camera model"));
  EXPECT_EQ(photos[2]["status"], "used");
  EXPECT_THAT(r.out, HasSubstr("rejected: "));
}

TEST_F(AnalyzeCli, NoUsablePhotoIsAOneLineFailure) {
  const CliRun r = Curvecheck({"analyze", "--camera", (Dir() / "small.cameramodel").string(), "--pattern",
                               (Dir() / "exact.json").string(), (Dir() / "exact.png").string(), "-o",
                               (Dir() / "out-bad").string()});
  ExpectOneLineFailure(r, {"exact.png", "5120 x 1440 px but the camera model"});
  EXPECT_FALSE(fs::exists(Dir() / "out-bad" / "result.json"));
}

TEST_F(AnalyzeCli, AnInputIsNeverOverwritten) {
  // -o pointing at the folder whose result.json is... the pattern file itself would be replaced: refuse.
  fs::create_directories(Dir() / "trap");
  fs::copy_file(Dir() / "exact.json", Dir() / "trap" / "result.json", fs::copy_options::overwrite_existing);
  const std::string before = Slurp(Dir() / "trap" / "result.json");
  const CliRun r = Curvecheck({"analyze", "--camera", (Dir() / "small.cameramodel").string(), "--pattern",
                               (Dir() / "trap" / "result.json").string(), (Dir() / "photo-exact.png").string(), "-o",
                               (Dir() / "trap").string()});
  ExpectOneLineFailure(r, {"result.json", "is an input of this command"});
  EXPECT_EQ(Slurp(Dir() / "trap" / "result.json"), before);
}

// The lens model misfit its calibration measured (the sidecar's "misfit", as curvecheck calibrate writes it) is the
// floor of the lens-model-misfit row, and --lens-misfit states it instead: the radius is the same, the stated
// field's u(k) doubles with its RMS (0.05 px in the sidecar, 0.1 px stated), and the row says where it came from.
TEST_F(AnalyzeCli, TheCalibrationsLensMisfitIsTheMisfitRowsFloor) {
  const std::string camera = (Dir() / "small.cameramodel").string(), pattern = (Dir() / "exact.json").string();
  const size_t n = ReadCameraModel(camera).intrinsics.size();
  nlohmann::json cov = nlohmann::json::array();
  for (size_t r = 0; r < n; ++r) cov.push_back(std::vector<double>(n, 0.0));
  const fs::path sidecar = Dir() / "misfit.intrinsics_covariance.json";
  std::ofstream(sidecar) << nlohmann::json{{"format", "curvecheck.intrinsics_covariance/1"},
                                           {"lensmodel", ReadCameraModel(camera).lensmodel},
                                           {"covariance", cov},
                                           {"misfit", {{"rms_px", 0.05}, {"length_px", 300}}}}
                                .dump();
  const fs::path from_sidecar = Dir() / "out-misfit-sidecar", stated = Dir() / "out-misfit-stated";
  const std::vector<std::string> common = {"analyze", "--camera", camera, "--pattern", pattern,
                                           (Dir() / "photo-exact.png").string(), "--lens-covariance",
                                           sidecar.string(), "--no-report", "--no-overlays"};
  std::vector<std::string> args = common;
  args.insert(args.end(), {"-o", from_sidecar.string()});
  CliRun r = Curvecheck(args);
  ASSERT_EQ(r.code, 0) << r.err;
  args = common;
  args.insert(args.end(), {"-o", stated.string(), "--lens-misfit", "0.1,300"});
  r = Curvecheck(args);
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json a = Result(from_sidecar), b = Result(stated);
  EXPECT_EQ(a["fit"]["radius_mm"], b["fit"]["radius_mm"]);
  const nlohmann::json &ma = a["fit"]["uncertainty_budget"]["lens_model_misfit"],
                       &mb = b["fit"]["uncertainty_budget"]["lens_model_misfit"];
  const double sa = ma["stated_curvature_per_mm"], sb = mb["stated_curvature_per_mm"];
  EXPECT_NEAR(sb, 2 * sa, 1e-9 * sb);
  EXPECT_GT(sa, ma["measured_curvature_per_mm"].get<double>()) << "the clean photo shows less than 0.05 px";
  EXPECT_EQ(ma["row_basis"], "calibration");
  std::string source_a, source_b;
  for (const nlohmann::json& c : a["fit"]["uncertainty_budget"]["components"]) {
    if (c["name"] == "lens model misfit") source_a = c["source"];
  }
  for (const nlohmann::json& c : b["fit"]["uncertainty_budget"]["components"]) {
    if (c["name"] == "lens model misfit") source_b = c["source"];
  }
  EXPECT_THAT(source_a, HasSubstr("the calibration's measured misfit (" + sidecar.string()));
  EXPECT_THAT(source_b, HasSubstr("stated with --lens-misfit"));
  args = common;
  args.insert(args.end(), {"-o", (Dir() / "out-misfit-bad").string(), "--lens-misfit", "0.1,-300"});
  ExpectOneLineFailure(Curvecheck(args), {"--lens-misfit", "0.1,-300 is not an RMS and a length"});
}

TEST_F(AnalyzeCli, TheCoverageFactorFollowsTheRowsDistributions) {
  // A 5% pitch tolerance (rectangular, u = 2.9% of R: some 31 mm against 6 mm for the other rows, the detector
  // systematic's the largest: with the rows propagated through the pixel-locking-corrected estimate, 2% left the
  // lens-model-misfit row's few degrees of freedom a say in the camera's z factor) dominates the budget: the 95%
  // factor falls from near 1.96 towards 0.95 sqrt(3) = 1.645 on the radius and on the camera's distance (scale moves a position in proportion to it: little near x = y = 0, where the normal rows keep
  // their Student's t), and the report says which row is rectangular.
  const std::string camera = (Dir() / "small.cameramodel").string(), pattern = (Dir() / "exact.json").string();
  const fs::path narrow = Dir() / "out-pitch-narrow", wide = Dir() / "out-pitch-wide";
  for (const auto& [out, percent] : {std::pair{narrow, "0"}, std::pair{wide, "5"}}) {
    const CliRun r = Curvecheck({"analyze", "--camera", camera, "--pattern", pattern,
                                 (Dir() / "photo-exact.png").string(), "--pitch-tolerance", percent,
                                 "--no-overlays", "-o", out.string()});
    ASSERT_EQ(r.code, 0) << r.err;
  }
  const nlohmann::json n = Result(narrow)["fit"], w = Result(wide)["fit"];
  EXPECT_EQ(n["radius_mm"], w["radius_mm"]);
  const nlohmann::json &bn = n["uncertainty_budget"], &bw = w["uncertainty_budget"];
  for (const nlohmann::json* b : {&bn, &bw}) {
    for (const nlohmann::json& c : (*b)["components"]) {
      EXPECT_EQ(c["distribution"], c["name"] == "pixel pitch" ? "rectangular" : "normal") << c["name"];
    }
  }
  const double kn = bn["coverage_factor"], kw = bw["coverage_factor"];
  EXPECT_GE(kn, 1.959);  // no rectangular row: Student's t
  // A rectangular row with a small normal one dips just below the rectangular's own 0.95 sqrt(3) = 1.6454: with
  // the normal's sigma 3% of the half-width a, the 95% point is 0.9508 a against u_c = 0.5781 a, a factor 1.6446.
  EXPECT_GT(kw, 1.64);
  EXPECT_LT(kw, 1.70);
  // The radius interval is the curvature's k +- factor u_c(k), inverted.
  const double k = bw["curvature"]["value_per_mm"], uk = bw["curvature"]["combined_standard_uncertainty_per_mm"];
  EXPECT_NEAR(w["radius_ci95_mm"][0].get<double>(), 1 / (k + kw * uk), 1e-6);
  EXPECT_NEAR(w["radius_ci95_mm"][1].get<double>(), 1 / (k - kw * uk), 1e-6);
  EXPECT_NEAR(bw["curvature"]["coverage_factor"].get<double>(), kw, 1e-12);
  // The 68% interval: +- u_c with normal rows alone, wider with the rectangle (1.18 u alone).
  // Student's t at the rows' Welch-Satterthwaite dof: 1 + 0.5 / nu + 0.25 / nu^2 to O(nu^-3) (Cornish-Fisher at
  // z = 1). Finite: since the smooth detector bias follows the detector's scatter (here a clean photo's, small), the
  // lens-model-misfit row's few degrees of freedom have a say.
  const double nu = bn["effective_dof"];
  EXPECT_GT(nu, 4);
  EXPECT_NEAR(bn["coverage_factor68"].get<double>(), 1 + 0.5 / nu + 0.25 / (nu * nu), 0.005) << nu;
  const double k68 = bw["coverage_factor68"];
  EXPECT_GT(k68, 1.1);
  EXPECT_LT(k68, 0.6827 * std::sqrt(3.0));
  EXPECT_NEAR(w["radius_ci68_mm"][0].get<double>(), 1 / (k + k68 * uk), 1e-6);
  EXPECT_NEAR(w["radius_ci68_mm"][1].get<double>(), 1 / (k - k68 * uk), 1e-6);
  for (const char* a : {"x", "y", "z"}) {
    const nlohmann::json& p = bw["camera_position"][a];
    const double v = p["value_mm"], u = p["combined_standard_uncertainty_mm"], f = p["coverage_factor"];
    EXPECT_LT(f, bn["camera_position"][a]["coverage_factor"].get<double>() + 1e-9) << a;
    std::cout << a << ": coverage factor " << bn["camera_position"][a]["coverage_factor"] << " -> " << f << "\n";
    if (std::string(a) == "z") {
      EXPECT_LT(f, 1.9);
    }
    EXPECT_GE(f, 0.95 * std::sqrt(3.0) - 1e-9) << a;
    EXPECT_NEAR(p["interval95_mm"][0].get<double>(), v - f * u, 1e-9 * (1 + std::abs(v))) << a;
  }
  EXPECT_THAT(Slurp(wide / "report.html"), HasSubstr("<td>B, rectangular</td>"));
}

TEST_F(AnalyzeCli, UsageErrors) {
  const CliRun r = Curvecheck({"analyze", "--camera", "x.cameramodel", "-o", "out"});
  EXPECT_EQ(r.code, 1);  // a usage error exits 1, as every error (app/cli.h)
  EXPECT_THAT(r.err, HasSubstr("see 'curvecheck analyze --help'"));
  const CliRun missing = Curvecheck({"analyze", "--camera", (Dir() / "nope.cameramodel").string(), "--pattern",
                                     (Dir() / "exact.json").string(), (Dir() / "photo-exact.png").string(), "-o",
                                     (Dir() / "out-nocam").string()});
  ExpectOneLineFailure(missing, {"nope.cameramodel"});
  const CliRun counts = Curvecheck({"analyze", "--camera", (Dir() / "small.cameramodel").string(), "--pattern",
                                    (Dir() / "exact.json").string(), "--pattern", (Dir() / "none.json").string(),
                                    (Dir() / "photo-exact.png").string(), "-o", (Dir() / "out-counts").string()});
  ExpectOneLineFailure(counts, {"--pattern", "2 pattern files for 1 photos"});
}

}  // namespace
}  // namespace curvecheck
