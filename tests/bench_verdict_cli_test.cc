// `curvecheck bench verdict` end to end, small and seeded (issue 15, "Tests and benchmark"): the embedded default
// scene (49" 1000R), the camera 1.5 m from the screen centre on and off axis, at 0.25 and 0.3 of its resolution,
// 2 trials per cell, the three cases (correct, the viewpoint misstated by 25 mm, a true 1080R under the 1000R
// rendering): 24 trials. Proves: every trial reaches a verdict; no correct correction fails and no wrong one
// passes (inconclusive is allowed either way: the decision rule's guard band); every perturbed trial's true
// error exceeds the tolerance (so "wrong" is wrong in the tolerance's sense); the outputs (CSV, JSON, summary
// with the confusion matrix, the Wilson intervals, the machine and the command) exist and agree. Does not prove
// the rates the issue targets (5%): that takes the full bench (README, "Speed against accuracy").
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/cli_test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::CliRun;
using testing::Slurp;

class BenchVerdictCli : public testing::CliTest {
 protected:
  BenchVerdictCli() : CliTest("bench_verdict_cli_test") {}
};

TEST_F(BenchVerdictCli, NoCorrectCorrectionFailsAndNoWrongOnePasses) {
  const fs::path out = dir_ / "verdict";
  const CliRun r = Curvecheck({"bench", "verdict", "--scales", "0.25,0.3", "--distances", "1500", "--trials", "2",
                               "--seed", "7", "-o", out.string()});
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  std::cout << r.out;
  const nlohmann::json j = nlohmann::json::parse(Slurp(out / "verdict_bench.json"));
  EXPECT_EQ(j["format"], "curvecheck.bench.verdict/1");
  EXPECT_THAT(j["command"].get<std::string>(), HasSubstr("bench verdict --scales 0.25,0.3"));
  EXPECT_FALSE(j["machine"].get<std::string>().empty());
  ASSERT_EQ(j["trials"].size(), 24u);
  int correct = 0, wrong = 0;
  for (const auto& t : j["trials"]) {
    const std::string what = t.dump();
    const std::string verdict = t["verdict"], truth = t["truth"];
    EXPECT_NE(verdict, "none") << what;
    if (t["case"] == "correct") {
      ++correct;
      EXPECT_EQ(truth, "correct") << what;
      EXPECT_LT(t["true_error_p95_display_px"].get<double>(), 1e-6) << what;
      EXPECT_NE(verdict, "fail") << "a correct correction failed: " << what;
    } else {
      ++wrong;
      EXPECT_EQ(truth, "wrong") << what;
      EXPECT_GT(t["true_error_p95_display_px"].get<double>(), 0.5) << what;
      EXPECT_NE(verdict, "pass") << "a wrong correction passed: " << what;
    }
    EXPECT_EQ(t["seed"].get<int>(), 7 + t["index"].get<int>()) << what;
  }
  EXPECT_EQ(correct, 8);
  EXPECT_EQ(wrong, 16);
  const auto& s = j["summary"];
  EXPECT_EQ(s["false_fail_on_correct"]["k"], 0);
  EXPECT_EQ(s["false_pass_on_wrong"]["k"], 0);
  EXPECT_EQ(s["false_pass_on_wrong"]["n"], 16);
  EXPECT_EQ(s["false_fail_on_correct"]["wilson95"][0], 0.0);
  EXPECT_EQ(j["per_scale_distance"].size(), 2u);

  const std::string text = Slurp(out / "verdict_bench.txt");
  for (const char* piece : {"bench verdict --scales 0.25,0.3", "cores", "truth \\ verdict", "false-fail rate on correct: 0/",
                            "false-pass rate on wrong:   0/16 = 0.0% [0.0%, 19.4%]", "s per trial"}) {
    EXPECT_THAT(text, HasSubstr(piece));
  }
  const std::string csv = Slurp(out / "verdict_bench.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 25);
  EXPECT_FALSE(fs::exists(out / ".verdict-scratch"));
}

TEST_F(BenchVerdictCli, BadOptionsFailWithOneLine) {
  testing::ExpectOneLineFailure(Curvecheck({"bench", "verdict", "--scales", "0.5,1.5", "-o", (dir_ / "o").string()}),
                                {"--scales", "1.5 is outside (0, 1]"});
  testing::ExpectOneLineFailure(Curvecheck({"bench", "verdict", "--distances", "50", "-o", (dir_ / "o").string()}),
                                {"--distances", "50 mm is outside"});
  testing::ExpectOneLineFailure(Curvecheck({"bench", "verdict", "--views", "sideways", "-o", (dir_ / "o").string()}),
                                {"--views", "'sideways' is not a view"});
  testing::ExpectOneLineFailure(Curvecheck({"bench", "verdict", "--trials", "0", "-o", (dir_ / "o").string()}),
                                {"--trials", "out of range"});
}

}  // namespace
}  // namespace curvecheck
