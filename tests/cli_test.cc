// End-to-end tests of the `curvecheck` command line: exit codes (0 ok, 1 failure, 2 usage), one-line errors
// naming the file or option and the problem, and the figures `info` prints.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace {
namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

struct CliRun {
  int code = -1;
  std::string out, err;
};

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string Quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("curvecheck_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  CliRun Curvecheck(const std::vector<std::string>& args) {
    std::string cmd = Quote(CURVECHECK_BINARY);
    for (const auto& a : args) cmd += " " + Quote(a);
    cmd += " >" + Quote((dir_ / "out").string()) + " 2>" + Quote((dir_ / "err").string());
    const int status = std::system(cmd.c_str());
    CliRun r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
    r.out = Slurp(dir_ / "out");
    r.err = Slurp(dir_ / "err");
    return r;
  }

  std::string Write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }

  // Exit 1 with exactly one line on stderr containing every expected piece.
  void ExpectFailure(const CliRun& r, const std::vector<std::string>& pieces) {
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    for (const auto& p : pieces) EXPECT_THAT(r.err, HasSubstr(p));
  }

  fs::path dir_;
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

TEST_F(Cli, UsageErrorsExitTwo) {
  EXPECT_EQ(Curvecheck({}).code, 2);
  EXPECT_EQ(Curvecheck({"frobnicate"}).code, 2);
  const CliRun r = Curvecheck({"info", "--no-such-option"});
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr("--no-such-option"));
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

TEST_F(Cli, PlannedSubcommandsFailHonestly) {
  for (const char* sub : {"capture", "calibrate", "analyze", "bench", "sweep"}) {
    const CliRun r = Curvecheck({sub, "--monitor", "default"});
    ExpectFailure(r, {"not implemented yet", "nothing was done"});
    EXPECT_THAT(r.out, Not(HasSubstr("written")));
  }
}

TEST_F(Cli, DemoRunsWhatExists) {
  const CliRun r = Curvecheck({"demo"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, AllOf(HasSubstr("geometry self-check"), HasSubstr("not yet available"),
                           HasSubstr("no files were written")));
}

}  // namespace
