// Robustness, round 2 (issue 17): values, sweeps, usage. Through the real `curvecheck` binary: every bad value or
// usage error exits 1 with one stderr line "curvecheck: error: WHERE: problem; fix" (app/cli.h: one exit code for
// every error), numbers are decimal only and never empty, viewpoints, imager scales and hold times are bounded with
// the reason; and the results that are not errors: a sweep where no point succeeds (exit 0, every output, a chart
// that says so), --version, the benches' default scene from any folder. Each case is a row of README's "Bad input"
// table (block "Round 2: values, sweeps, usage").
//
// What this does not prove: that every numeric option of every subcommand goes through the decimal check (the
// check is attached to all of them in one place, app/cli.cc RequireDecimalNumbers; a handful are exercised here).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/cli_test_util.h"

namespace {
namespace fs = std::filesystem;
using curvecheck::testing::CliRun;
using curvecheck::testing::Slurp;
using ::testing::HasSubstr;
using ::testing::Not;

class RobustnessValues : public curvecheck::testing::CliTest {
 protected:
  RobustnessValues() : CliTest("robustness_values_cli_test") {}
  std::string D(const std::string& name) const { return (dir_ / name).string(); }
  static std::string Source() {
    const char* s = std::getenv("CURVECHECK_SOURCE_DIR");
    return s ? s : CURVECHECK_SOURCE_DIR;
  }
};

struct Case {
  std::string name;                 // the README row
  std::vector<std::string> args;    // the command line
  std::vector<std::string> pieces;  // of the one stderr line (exit 1)
};

// Bad values and usage errors: exit 1, one line, the option or subcommand, the problem, the fix. Nothing is written:
// each command is given an output in the test's folder, which stays empty.
TEST_F(RobustnessValues, BadValuesAndUsageErrorsExitOneWithOneLine) {
  const std::string scene = Source() + "/datasets/scenes/default.yaml";
  const std::vector<Case> cases = {
      {"sweep --cols 0", {"sweep", "--factor", "yaw=0", "--cols", "0", "-o", D("sw")},
       {"curvecheck: error: --cols: the number of squares across is 0, but must be in [2, 1000]; give 2 to 1000"}},
      {"sweep --rows -3", {"sweep", "--factor", "yaw=0", "--rows", "-3", "-o", D("sw")},
       {"--rows: the number of squares down is -3, but must be in [2, 1000]"}},
      {"empty number", {"sweep", "--factor", "yaw=0", "--tolerance", "", "-o", D("sw")},
       {"curvecheck: error: --tolerance: '' is not a number; give a decimal number such as 0.5\n"}},
      {"hexadecimal number", {"sweep", "--factor", "yaw=0", "--tolerance", "0x10", "-o", D("sw")},
       {"--tolerance: '0x10' is not a decimal number; give a decimal number such as 0.5"}},
      {"fraction for a count", {"sweep", "--factor", "yaw=0", "--jobs", "1.5", "-o", D("sw")},
       {"--jobs: '1.5' is not a whole number; give a whole number such as 1"}},
      {"unparsable number", {"sweep", "--factor", "yaw=0", "--jobs", "abc", "-o", D("sw")},
       {"--jobs: 'abc' is not a number"}},
      {"number out of range", {"sweep", "--factor", "yaw=0", "--jobs", "0", "-o", D("sw")},
       {"--jobs: is 0; give 1 to 256 workers"}},
      {"hexadecimal in a viewpoint", {"info", "--viewpoint", "0,0,0x10"},
       {"--viewpoint: '0x10' is not a decimal number in '0,0,0x10'"}},
      {"empty --set value",
       {"capture", "synth", "--scene", scene, "--display", D("none.png"), "--set", "optics.blur_px=", "-o", D("p.png")},
       {"--set optics.blur_px=: has no value after '='; give one, e.g. optics.blur_px=1.5"}},
      {"hexadecimal --set value",
       {"capture", "synth", "--scene", scene, "--display", D("none.png"), "--set", "optics.blur_px=0x10", "-o",
        D("p.png")},
       {"key 'optics.blur_px' must be a decimal number, got '0x10'"}},
      {"viewpoint beyond 1 km", {"info", "--viewpoint", "0,0,1e160"},
       {"--viewpoint: viewpoint (0, 0, 1e+160) mm is 1e+160 mm from the screen centre, beyond 1 km (1e6 mm)",
        "give a viewpoint within 1 km of the screen"}},
      {"imager scale too small",
       {"capture", "synth", "--scene", scene, "--display", D("none.png"), "--scale", "0.0001", "-o", D("p.png")},
       {"--scale: 0.0001 shrinks the 6000 x 4000 px imager to 1 x 0 px, below 64 px on its short side",
        "give a scale of at least 0.016"}},
      {"present --hold-ms 0", {"present", "--hold-ms", "0", D("none.png")},
       {"--hold-ms: 0 is outside 1..86400000 ms (at least 1 ms, at most one day); see 'curvecheck present --help'"}},
      {"unknown option", {"info", "--no-such-option"},
       {"curvecheck: error: info: the following argument was not expected: --no-such-option; see 'curvecheck info "
        "--help'"}},
      {"missing argument of a nested subcommand", {"sweep", "merge", "-o", D("m")},
       {"sweep merge: dirs is required; see 'curvecheck sweep merge --help'"}},
      {"missing option value", {"info", "--monitor"}, {"--monitor:", "see 'curvecheck info --help'"}},
      {"unknown subcommand", {"frobnicate"}, {"frobnicate: is not a subcommand; see 'curvecheck --help'"}},
      {"no subcommand", {}, {"curvecheck: a subcommand is required; see 'curvecheck --help'"}},
      {"unknown scene", {"bench", "fit", "--scene", "nowhere"},
       {"--scene: 'nowhere' is neither a file nor an embedded scene; give a scene YAML, or an embedded scene:",
        "close", "default", "phone"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const CliRun r = Curvecheck(c.args);
    curvecheck::testing::ExpectOneLineFailure(r, c.pieces);
    EXPECT_THAT(r.err, ::testing::StartsWith("curvecheck: error: "));
    EXPECT_TRUE(fs::is_empty(dir_)) << "wrote something";
  }
}

// A leading zero is decimal (CLI11 alone reads an integer's base from its prefix: 010 would be 8): --cols 010 is 10
// squares, which the sweep's grid in sweep.json records. The sweep's one point is refused quickly (yaw 80 deg puts
// the camera behind the screen's edge), so this runs in a second.
TEST_F(RobustnessValues, LeadingZerosAreDecimal) {
  const CliRun r = Curvecheck({"sweep", "--factor", "yaw=80", "--cols", "010", "--rows", "007", "-o", D("sw")});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(Slurp(dir_ / "sw" / "sweep.json"));
  EXPECT_EQ(j["grid"]["board"], (nlohmann::json{10, 7}));
}

// A sweep where no point succeeds is a result (issue 17: it exited 1 from gnuplot, "this is a bug", without
// sweep.txt or the chart): exit 0, every output, a chart titled with the failures, and the summary saying it.
// One factor (yaw 80 and 85 deg: the viewpoint is behind the screen's edge, render refused) and two factors.
TEST_F(RobustnessValues, SweepWhereNoPointSucceedsIsAResult) {
  for (const std::vector<std::string>& factors :
       {std::vector<std::string>{"--factor", "yaw=80:85:2"},
        std::vector<std::string>{"--factor", "distance=400:400:1", "--factor", "yaw=80:85:2"}}) {
    SCOPED_TRACE(factors.size() == 2 ? "one factor" : "two factors");
    const fs::path out = dir_ / (factors.size() == 2 ? "one" : "two");
    std::vector<std::string> args = {"sweep"};
    args.insert(args.end(), factors.begin(), factors.end());
    args.insert(args.end(), {"-o", out.string()});
    const CliRun r = Curvecheck(args);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.err, "");
    for (const char* f : {"sweep.csv", "sweep.json", "sweep.txt", "sweep-exact.png", "sweep-exact.gp"}) {
      EXPECT_TRUE(fs::exists(out / f)) << f;
    }
    EXPECT_GT(fs::file_size(out / "sweep-exact.png"), 5000u);
    EXPECT_THAT(Slurp(out / "sweep-exact.gp"), HasSubstr("no point succeeded: 2 of 2 failed (2 render_refused)"));
    EXPECT_THAT(Slurp(out / "sweep.txt"), HasSubstr("exact: 0 of 2 points succeed, 2 render_refused"));
    const nlohmann::json j = nlohmann::json::parse(Slurp(out / "sweep.json"));
    EXPECT_EQ(j["rows"], 2);
    EXPECT_EQ(j["outcomes"]["render_refused"], 2);
    EXPECT_FALSE(fs::exists(out / ".sweep-scratch-1"));
  }
  // Its merge is a result too.
  const CliRun m = Curvecheck({"sweep", "merge", D("one"), "-o", D("merged")});
  ASSERT_EQ(m.code, 0) << m.err;
  EXPECT_TRUE(fs::exists(dir_ / "merged" / "sweep-exact.png"));
}

// `sweep merge` refuses a shard whose sweep.csv was cut inside its header (issue 17: it merged 0 points and exited
// 0 while the shard's sweep.json said 2), naming the file; the merged output is not written.
TEST_F(RobustnessValues, MergeRefusesAShardCutInsideItsHeader) {
  ASSERT_EQ(Curvecheck({"sweep", "--factor", "yaw=80:85:2", "-o", D("shard")}).code, 0);
  const std::string csv = Slurp(dir_ / "shard" / "sweep.csv");
  std::ofstream(dir_ / "shard" / "sweep.csv", std::ios::trunc) << csv.substr(0, 60);  // inside the header line
  ASSERT_LT(csv.find('\n'), csv.size());
  ASSERT_GT(csv.find('\n'), 60u);
  const CliRun r = Curvecheck({"sweep", "merge", D("shard"), "-o", D("merged")});
  curvecheck::testing::ExpectOneLineFailure(
      r, {(dir_ / "shard" / "sweep.csv").string() + ": holds 0 rows, but sweep.json beside it says 2",
          "run this shard again, or give the sweep.csv that `curvecheck sweep` wrote"});
  EXPECT_FALSE(fs::exists(dir_ / "merged" / "sweep.csv"));
}

// --version prints the version the report page records (PROJECT_VERSION of CMakeLists.txt).
TEST_F(RobustnessValues, Version) {
  const CliRun r = Curvecheck({"--version"});
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out, std::string("curvecheck ") + CURVECHECK_VERSION + "\n");
  EXPECT_EQ(r.err, "");
}

// The benches' default scene is the embedded one (issue 17: datasets/scenes/default.yaml, a path relative to the
// repository root): `bench fit` from an empty folder runs on it, and an embedded name works as --scene.
TEST_F(RobustnessValues, BenchDefaultSceneWorksFromAnyFolder) {
  for (const std::vector<std::string>& scene : {std::vector<std::string>{}, std::vector<std::string>{"--scene", "close"}}) {
    std::vector<std::string> args = {"bench", "fit", "--runs", "1", "--seeds", "2"};
    args.insert(args.end(), scene.begin(), scene.end());
    const CliRun r = Curvecheck(args, "-C " + dir_.string());
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_THAT(r.out, HasSubstr(scene.empty() ? "scene embedded scene default" : "scene embedded scene close"));
    EXPECT_THAT(r.out, HasSubstr("95% interval coverage"));
  }
  // One seed (how the timings are taken) has no scatter: the bench says so instead of printing nan.
  const CliRun one = Curvecheck({"bench", "fit", "--runs", "1", "--seeds", "1"}, "-C " + dir_.string());
  ASSERT_EQ(one.code, 0) << one.err;
  EXPECT_THAT(one.out, HasSubstr("need --seeds 2 or more"));
  EXPECT_THAT(one.out, Not(HasSubstr("nan")));
}

}  // namespace
