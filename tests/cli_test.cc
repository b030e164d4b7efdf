// End-to-end tests of the `curvecheck` command line: exit codes (0 ok, 1 any error), one-line errors
// naming the file or option and the problem, and the figures `info` prints.
#include "tests/cli_test_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "core/image_io.h"
#include <sstream>

namespace {
namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

using curvecheck::testing::CliRun;
using curvecheck::testing::Quote;
using curvecheck::testing::Slurp;

class Cli : public curvecheck::testing::CliTest {
 protected:
  Cli() : CliTest("cli_test") {}

  std::string Write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
};

TEST_F(Cli, HelpEverywhere) {
  CliRun r = Curvecheck({"--help"});
  EXPECT_EQ(r.code, 0);
  for (const char* sub : {"info", "render", "capture", "calibrate", "analyze", "demo", "bench", "sweep"}) {
    EXPECT_THAT(r.out, HasSubstr(sub));
    CliRun s = Curvecheck({sub, "--help"});
    EXPECT_EQ(s.code, 0) << sub;
    EXPECT_THAT(s.out, HasSubstr("--help")) << sub;
  }
  EXPECT_THAT(Curvecheck({"info", "--help"}).out, HasSubstr("--viewpoint"));
}

// One exit code for every error (app/cli.h): usage errors exit 1 like bad values, with one line pointing at the
// subcommand's help (tests/robustness_values_cli_test.cc has the rest of the rule).
TEST_F(Cli, UsageErrorsExitOne) {
  EXPECT_EQ(Curvecheck({}).code, 1);
  EXPECT_EQ(Curvecheck({"frobnicate"}).code, 1);
  const CliRun r = Curvecheck({"info", "--no-such-option"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("--no-such-option"));
  EXPECT_THAT(r.err, HasSubstr("see 'curvecheck info --help'"));
}

TEST_F(Cli, InfoOnTheDefaultPreset) {
  const CliRun r = Curvecheck({"info"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, AllOf(HasSubstr("5120 x 1440 px"), HasSubstr("1198.12 mm wide"), HasSubstr("336.97 mm high"),
                           HasSubstr("1000 mm (1000R)")));
}

TEST_F(Cli, InfoJsonGivesThesisFieldOfView) {
  const CliRun r = Curvecheck({"info", "--json", "--monitor", "49in-5120x1440-1000r", "--viewpoint", "0,0,-500"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["format"], "curvecheck.info/1");
  EXPECT_NEAR(j["viewing"]["horizontal_fov_deg"].get<double>(), 120, 1.0);
  EXPECT_NEAR(j["monitor"]["height_mm"].get<double>(), 336.97, 0.005);
  EXPECT_NEAR(j["monitor"]["radius_mm"].get<double>(), 1000, 1e-9);
}

TEST_F(Cli, InfoFromAFileAndFlatMonitor) {
  const std::string f = Write("flat.yaml", "resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: flat\n");
  const CliRun r = Curvecheck({"info", "--json", "--monitor", f, "--viewpoint", "0,0,500"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["monitor"]["radius_mm"], "flat");
  EXPECT_NEAR(j["viewing"]["horizontal_fov_deg"].get<double>(), 100, 1.0);
  const CliRun t = Curvecheck({"info", "--monitor", "27in-2560x1440-flat", "--viewpoint", "0,0,600"});
  EXPECT_THAT(t.out, HasSubstr("44.9"));  // px/deg at the centre
}

TEST_F(Cli, ListPresets) {
  const CliRun r = Curvecheck({"info", "--list-presets"});
  ASSERT_EQ(r.code, 0);
  for (const char* p : {"49in-5120x1440-1000r", "49in-5120x1440-1800r", "34in-3440x1440-1900r",
                        "38in-3840x1600-2300r", "55in-3840x2160-1000r", "27in-2560x1440-flat"}) {
    EXPECT_THAT(r.out, HasSubstr(p));
  }
}

TEST_F(Cli, BadMonitorFiles) {
  const std::string valid_rest = "diagonal_in: 49\nradius_mm: 1000\n";
  struct Case {
    std::string name, text, expected;
  };
  const std::vector<Case> cases = {
      {"malformed.yaml", "resolution: [5120, 1440\n" + valid_rest, "not valid YAML at line"},
      {"missing.yaml", "resolution: [5120, 1440]\ndiagonal_in: 49\n", "key 'radius_mm' is missing"},
      {"negative.yaml", "resolution: [5120, 1440]\ndiagonal_in: -49\nradius_mm: 1000\n",
       "key 'diagonal_in' is -49, but must be greater than zero"},
      {"zero.yaml", "resolution: [5120, 0]\n" + valid_rest, "key 'resolution[1]' is 0"},
      {"nan.yaml", "resolution: [5120, 1440]\ndiagonal_in: .nan\nradius_mm: 1000\n", "not a finite number"},
      {"type.yaml", "resolution: [5120, 1440]\ndiagonal_in: [49]\nradius_mm: 1000\n", "must be a number, got a list"},
      {"radius.yaml", "resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: 50\n", "wrap more than 360 deg"},
      {"typo.yaml", "resolution: [5120, 1440]\ndiagonal: 49\nradius_mm: 1000\n", "key 'diagonal' is not a known key"},
  };
  for (const Case& c : cases) {
    const std::string f = Write(c.name, c.text);
    SCOPED_TRACE(c.name);
    ExpectFailure(Curvecheck({"info", "--monitor", f}), {f, c.expected});
  }
  ExpectFailure(Curvecheck({"info", "--monitor", (dir_ / "absent.yaml").string()}),
                {"absent.yaml", "neither a monitor preset nor an existing file"});
}

TEST_F(Cli, BadViewpoints) {
  ExpectFailure(Curvecheck({"info", "--viewpoint", "0,0,-1200"}),
                {"--viewpoint", "(0, 0, -1200) mm is on or behind the screen surface"});
  ExpectFailure(Curvecheck({"info", "--viewpoint", "0,0,-1000"}), {"--viewpoint", "on or behind"});  // on it
  ExpectFailure(Curvecheck({"info", "--monitor", "27in-2560x1440-flat", "--viewpoint", "10,0,-5"}),
                {"on or behind", "z > 0"});
  ExpectFailure(Curvecheck({"info", "--viewpoint", "0,0"}), {"--viewpoint", "expected 3 numbers, got 2"});
  ExpectFailure(Curvecheck({"info", "--viewpoint", "0,nan,0"}), {"--viewpoint", "not finite"});
}

TEST_F(Cli, SweepWithoutAFactorFailsNamingTheOption) {
  // `sweep` was a planned subcommand until issue 7; its own end-to-end tests are in tests/sweep_cli_test.cc.
  const CliRun r = Curvecheck({"sweep", "-o", (dir_ / "sweep").string()});
  ExpectFailure(r, {"--factor", "0 factors given"});
  EXPECT_THAT(r.out, Not(HasSubstr("wrote")));
}

// The demo-only program (app/demo_main.cc, what `./bootstrap demo` builds and runs): the one subcommand, the same
// error rule as curvecheck under its own name.
TEST_F(Cli, DemoProgramOffersTheDemoAloneUnderItsOwnName) {
  const CliRun help = curvecheck::testing::RunBinary(CURVECHECK_DEMO_BINARY, {"--help"}, dir_);
  EXPECT_EQ(help.code, 0);
  EXPECT_THAT(help.out, AllOf(HasSubstr("demo"), Not(HasSubstr("analyze")), Not(HasSubstr("calibrate"))));
  EXPECT_THAT(curvecheck::testing::RunBinary(CURVECHECK_DEMO_BINARY, {"demo", "--help"}, dir_).out,
              HasSubstr("--output"));
  const CliRun version = curvecheck::testing::RunBinary(CURVECHECK_DEMO_BINARY, {"--version"}, dir_);
  EXPECT_EQ(version.code, 0);
  EXPECT_THAT(version.out, HasSubstr("curvecheck-demo "));
  const CliRun other = curvecheck::testing::RunBinary(CURVECHECK_DEMO_BINARY, {"analyze", "x.png"}, dir_);
  EXPECT_EQ(other.code, 1);
  EXPECT_THAT(other.err,
              HasSubstr("curvecheck-demo: error: analyze: is not a subcommand; see 'curvecheck-demo --help'"));
  const CliRun option = curvecheck::testing::RunBinary(CURVECHECK_DEMO_BINARY, {"demo", "--frobnicate"}, dir_);
  EXPECT_EQ(option.code, 1);
  EXPECT_THAT(option.err, HasSubstr("see 'curvecheck-demo demo --help'"));
}

TEST_F(Cli, DemoRunsEndToEndAndFindsTheTrueRadius) {
  // render -> synthetic capture (24 MP) -> analyze on the default scene, whose true monitor is the nominal 1000R;
  // run by the demo-only program, as `./bootstrap demo` does (`curvecheck demo` registers the same subcommand,
  // app/demo_command.cc).
  const CliRun r = curvecheck::testing::RunBinary(CURVECHECK_DEMO_BINARY, {"demo", "-o", (dir_ / "demo").string()},
                                                  dir_);
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  EXPECT_THAT(r.out, AllOf(HasSubstr("verification: PASS"), HasSubstr("inside its 95% interval"),
                           HasSubstr("model cylinder")));
  for (const char* f : {"pattern.png", "pattern.json", "photo.png", "photo.truth.json", "analysis/result.json",
                        "analysis/overlay-photo.png", "datasets/scenes/default.yaml"}) {
    EXPECT_TRUE(fs::exists(dir_ / "demo" / f)) << f;
  }
  const nlohmann::json result = nlohmann::json::parse(Slurp(dir_ / "demo" / "analysis" / "result.json"));
  const nlohmann::json& fit = result["fit"];
  EXPECT_LE(fit["radius_ci95_mm"][0].get<double>(), 1000.0);
  EXPECT_GE(fit["radius_ci95_mm"][1].get<double>(), 1000.0);
  EXPECT_LT(fit["radius_sigma_mm"].get<double>(), 5.0);
  // The demo writes the report too (its content is checked in a browser by tests/report_browser_test.cc).
  const std::string html = Slurp(dir_ / "demo" / "analysis" / "report.html");
  EXPECT_THAT(html, AllOf(HasSubstr("id=\"radius-mm\""), HasSubstr("id=\"verdict\""), Not(HasSubstr("https://"))));
}

}  // namespace

namespace {

// `curvecheck render` writes the PNG and the pattern.json for every method and both pattern kinds; the
// features' display positions in the JSON agree with the geometry (checked in render/ tests) and the image has
// the display's size.
TEST_F(Cli, RenderEveryMethodAndPattern) {
  for (const char* pattern : {"checkerboard", "apriltag", "both"}) {
    for (const char* method : {"exact", "warp", "mesh", "strips", "none"}) {
      SCOPED_TRACE(std::string(pattern) + " " + method);
      const std::string out = (dir_ / (std::string(pattern) + "_" + method + ".png")).string();
      const CliRun r = Curvecheck({"render", "--monitor", "34in-3440x1440-1900r", "--viewpoint", "0,0,-1000",
                                   "--pattern", pattern, "--method", method, "-o", out});
      ASSERT_EQ(r.code, 0) << r.err;
      ASSERT_TRUE(fs::exists(out));
      const fs::path json = fs::path(out).replace_extension(".json");
      const nlohmann::json j = nlohmann::json::parse(Slurp(json));
      EXPECT_EQ(j["format"], "curvecheck.pattern/1");
      EXPECT_EQ(j["method"], method);
      EXPECT_EQ(j["monitor"]["resolution"][0], 3440);
      EXPECT_GT(j["features"].size(), 10u);
      // The image shows the pattern: black and white pixels, not only the grey surround.
      const curvecheck::Image8 img = curvecheck::ReadImage8(out);
      EXPECT_EQ(img.width, 3440);
      const auto [lo, hi] = std::minmax_element(img.pixels.begin(), img.pixels.end());
      EXPECT_LT(*lo, 20);
      EXPECT_GT(*hi, 235);
    }
  }
}

TEST_F(Cli, RenderAccuracyReportsMappingError) {
  const std::string out = (dir_ / "strips.png").string();
  const CliRun r = Curvecheck({"render", "--monitor", "34in-3440x1440-1900r", "--viewpoint", "0,0,-1300", "--method",
                               "strips", "--strips", "16", "-o", out, "--error-map", (dir_ / "err.png").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(Slurp(fs::path(out).replace_extension(".json")));
  const double max_px = j["mapping_error_px"]["max"].get<double>();
  EXPECT_GT(max_px, 0.01);  // 16 strips on a 1900R panel: visibly approximate...
  EXPECT_LT(max_px, 1.0);   // ...but within a pixel
  EXPECT_TRUE(fs::exists(dir_ / "err.png"));
}

TEST_F(Cli, RenderBadInput) {
  ExpectFailure(Curvecheck({"render", "--method", "magic", "-o", (dir_ / "x.png").string()}),
                {"--method", "unknown method 'magic'"});
  ExpectFailure(Curvecheck({"render", "-o", (dir_ / "x.jpg").string()}), {"does not end in .png"});
  ExpectFailure(Curvecheck({"render", "--viewpoint", "0,0,-1500", "-o", (dir_ / "x.png").string()}),
                {"--viewpoint", "on or behind the screen"});
  ExpectFailure(Curvecheck({"render", "--method", "warp", "--viewpoint", "0,0,-900", "-o", (dir_ / "x.png").string()}),
                {"180 deg"});
  ExpectFailure(Curvecheck({"render", "--squares", "16by5", "-o", (dir_ / "x.png").string()}),
                {"--squares", "not of the form CxR"});
  ExpectFailure(Curvecheck({"render", "-o", (dir_ / "missing-folder" / "x.png").string()}), {"does not exist"});
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
  // The output may not overwrite an input.
  const std::string monitor = Write("mon.png", "resolution: [1280, 720]\ndiagonal_in: 27\nradius_mm: flat\n");
  ExpectFailure(Curvecheck({"render", "--monitor", monitor, "-o", monitor}), {"is an input of this command"});
  EXPECT_THAT(Slurp(monitor), HasSubstr("radius_mm: flat"));
}

TEST_F(Cli, RenderRefusesDisplaysBeyondTheDeviceLimits) {
  const std::string wide = Write("wide.yaml", "resolution: [40000, 100]\nactive_area_mm: [9000, 22.5]\nradius_mm: flat\n");
  ExpectFailure(Curvecheck({"render", "--monitor", wide, "--viewpoint", "0,0,1000", "-o", (dir_ / "w.png").string()}),
                {"exceeds the device's limit"});
  EXPECT_FALSE(fs::exists(dir_ / "w.png"));
  ExpectFailure(Curvecheck({"render", "--margin", "0.5", "-o", (dir_ / "m.png").string()}), {"margin", "0.45"});
}

TEST_F(Cli, RenderWithoutVulkanDriverIsAClearError) {
  const std::string cmd = "VK_DRIVER_FILES=/nonexistent/icd.json VK_ICD_FILENAMES=/nonexistent/icd.json " +
                          Quote(CURVECHECK_BINARY) + " render -o " + Quote((dir_ / "x.png").string()) + " 2>" +
                          Quote((dir_ / "err").string());
  const int status = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string err = Slurp(dir_ / "err");
  EXPECT_THAT(err, HasSubstr("Vulkan"));
  EXPECT_THAT(err, HasSubstr("install mesa-vulkan-drivers"));
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
}

TEST_F(Cli, BenchRenderWritesCsvAndChart) {
  const CliRun r = Curvecheck({"bench", "render", "--quick", "--runs", "1", "--monitor", "27in-2560x1440-flat",
                               "--viewpoint", "0,0,600", "-o", (dir_ / "bench").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string csv = Slurp(dir_ / "bench" / "render_bench.csv");
  EXPECT_THAT(csv, HasSubstr("method,setting,median_ms"));
  EXPECT_THAT(csv, HasSubstr("flip_mean_100cm,flip_mean_25cm"));
  EXPECT_THAT(csv, HasSubstr("exact,\"exact analytic\""));
  // The Pareto flags follow their definition: a row is marked iff no other row is at least as fast and at
  // least as accurate, and strictly better in one.
  struct Row {
    double ms, err;
    bool pareto;
  };
  std::vector<Row> rows;
  std::stringstream lines(csv);
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("method,", 0) == 0) continue;
    std::vector<std::string> f;
    std::string cell;
    bool quoted = false;
    for (char ch : line) {
      if (ch == '"') quoted = !quoted;
      else if (ch == ',' && !quoted) f.push_back(cell), cell.clear();
      else cell += ch;
    }
    f.push_back(cell);
    ASSERT_EQ(f.size(), 16u) << line;
    rows.push_back({std::stod(f[2]), std::stod(f[7]), f[15] == "1"});
    // The FLIP axis: a mean FLIP in [0, 1] at 100 cm for every setting the flat monitor allows; the exact
    // method's analytic anti-aliasing is within 0.02 of its 16 x 16 supersampled reference.
    ASSERT_FALSE(f[9].empty()) << line;
    EXPECT_GE(std::stod(f[9]), 0.0) << line;
    EXPECT_LE(std::stod(f[9]), 1.0) << line;
    if (f[1] == "exact analytic") {
      EXPECT_LT(std::stod(f[9]), 0.02);
    }
  }
  ASSERT_GE(rows.size(), 8u);
  for (const Row& row : rows) {
    const bool dominated = std::any_of(rows.begin(), rows.end(), [&](const Row& q) {
      return &q != &row && q.ms <= row.ms && q.err <= row.err && (q.ms < row.ms || q.err < row.err);
    });
    EXPECT_EQ(row.pareto, !dominated);
  }
  EXPECT_TRUE(fs::exists(dir_ / "bench" / "render_bench.png"));
  EXPECT_TRUE(fs::exists(dir_ / "bench" / "render_bench_flip.png"));
  EXPECT_TRUE(fs::exists(dir_ / "bench" / "maps" / "reference_100cm.png"));
  EXPECT_THAT(r.out, HasSubstr("Pareto front"));
  EXPECT_THAT(r.out, HasSubstr("FLIP Pareto front at 25 cm"));
}

// `bench models` on the 1 deg lean scene (embedded), small grid, one seed: the model that contains the truth
// (cylinder+lean) recovers the surface to a fraction of a tenth of a millimetre and the radius within 3 of its
// sigmas, the plain cylinder cannot (the lean moves the top and bottom edges by H/2 sin 1 deg = 2.9 mm), the
// selection picks cylinder+lean, and the Pareto flags follow their definition.
TEST_F(Cli, BenchModelsScoresEveryModelAgainstTheTruth) {
  const CliRun r = Curvecheck({"bench", "models", "--scenes", "lean-1deg", "--seeds", "1", "--grid-cols", "21",
                               "--grid-rows", "7", "-o", (dir_ / "bench").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  struct Row {
    std::string model;
    double ms = 0, radius_err = NAN, sigma = NAN, surface = NAN;
    bool chosen = false, front_radius = false, front_surface = false;
  };
  std::map<std::string, Row> rows;
  std::stringstream lines(Slurp(dir_ / "bench" / "models_bench.csv"));
  const auto num = [](const std::string& c) { return c.empty() ? NAN : std::stod(c); };
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("scene,", 0) == 0) continue;
    std::vector<std::string> f;
    std::stringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    if (line.back() == ',') f.emplace_back();
    ASSERT_EQ(f.size(), 13u) << line;
    EXPECT_EQ(f[0], "lean-1deg");
    rows[f[1]] = {f[1], std::stod(f[5]), num(f[6]), num(f[7]), num(f[8]), f[10] == "1", f[11] == "1", f[12] == "1"};
  }
  ASSERT_EQ(rows.size(), 6u) << r.out;
  const Row& lean = rows.at("cylinder+lean");
  const Row& cyl = rows.at("cylinder");
  EXPECT_LT(lean.surface, 0.1);
  EXPECT_GT(cyl.surface, 10 * lean.surface);
  EXPECT_LT(std::abs(lean.radius_err), 3 * lean.sigma);
  EXPECT_GT(rows.at("flat").surface, 20);  // a flat model of a 1000R panel is off by the sagitta
  EXPECT_TRUE(std::isnan(rows.at("flat").radius_err));
  EXPECT_TRUE(lean.chosen);
  for (const auto& [name, row] : rows) {
    EXPECT_EQ(row.chosen, name == "cylinder+lean") << name;
    const auto dominated = [&](double Row::*err) {
      if (!std::isfinite(row.*err)) return true;
      return std::any_of(rows.begin(), rows.end(), [&](const auto& q) {
        const Row& o = q.second;
        return o.model != row.model && std::isfinite(o.*err) && o.ms <= row.ms && o.*err <= row.*err &&
               (o.ms < row.ms || o.*err < row.*err);
      });
    };
    EXPECT_EQ(row.front_radius, !dominated(&Row::radius_err)) << name;
    EXPECT_EQ(row.front_surface, !dominated(&Row::surface)) << name;
  }
  EXPECT_TRUE(fs::exists(dir_ / "bench" / "models_bench.png"));
  EXPECT_TRUE(fs::exists(dir_ / "bench" / "models_bench.gp"));
}

}  // namespace

namespace {

// `capture synth` end to end: render a pattern, photograph it with a small synthetic camera, and check the
// truth file against the geometry (every feature visible, inside the image) and the photo's content.
TEST_F(Cli, CaptureSynthWritesPhotoAndTruth) {
  const fs::path src = fs::path(std::getenv("CURVECHECK_SOURCE_DIR"));
  // A small camera (1200 x 800) with the default lens scaled, looking at the 27" flat from 700 mm.
  std::ofstream(dir_ / "small.cameramodel")
      << "{ 'lensmodel': 'LENSMODEL_OPENCV8', 'intrinsics': [1400, 1400, 599.5, 399.5, -0.05, 0.02, 0.0002, "
         "-0.0002, -0.005, 0.001, 0.001, -0.001], 'imagersize': [1200, 800], 'extrinsics': [0,0,0,0,0,0] }\n";
  std::ofstream(dir_ / "scene.yaml") << "format: curvecheck.scene/1\nmonitor: 27in-2560x1440-flat\n"
                                        "camera: {model: small.cameramodel, position_mm: [50, 30, 700]}\n"
                                        "optics: {supersample: 2, blur: gaussian, blur_px: 0.5}\n"
                                        "sensor: {seed: 3, bits: 16}\n";
  const std::string pattern = (dir_ / "pattern.png").string();
  ASSERT_EQ(Curvecheck({"render", "--monitor", "27in-2560x1440-flat", "--viewpoint", "50,30,700", "--squares",
                        "10x6", "-o", pattern}).code, 0);
  const CliRun r = Curvecheck({"capture", "synth", "--scene", (dir_ / "scene.yaml").string(), "--display", pattern,
                               "-o", (dir_ / "photo.png").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("45 of 45 features visible"));
  const nlohmann::json truth = nlohmann::json::parse(Slurp(dir_ / "photo.truth.json"));
  EXPECT_EQ(truth["format"], "curvecheck.truth/1");
  ASSERT_EQ(truth["features"].size(), 45u);
  for (const auto& f : truth["features"]) {
    EXPECT_TRUE(f["visible"].get<bool>());
    EXPECT_GT(f["image_px"][0].get<double>(), 0);
    EXPECT_LT(f["image_px"][0].get<double>(), 1200);
  }
  const curvecheck::Image8 photo = curvecheck::ReadImage8(dir_ / "photo.png");
  EXPECT_EQ(photo.width, 1200);
  EXPECT_EQ(photo.height, 800);
  // Bad input: a display image that is not the monitor's size.
  ExpectFailure(Curvecheck({"capture", "synth", "--scene", (dir_ / "scene.yaml").string(), "--display",
                            (dir_ / "photo.png").string(), "-o", (dir_ / "x.png").string()}),
                {"photo.json"});
}

}  // namespace
