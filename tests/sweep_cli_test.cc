// `curvecheck sweep` end to end on the embedded default scene (49" 1000R, camera 1.5 m in front, scaled to
// 1500 x 1000 px): a 3-point sweep of the viewpoint offset (the camera moved sideways from the viewpoint the
// pattern was rendered for). Proves: at offset 0 the point succeeds and the true radius (1000 mm) is inside the
// reported 95% interval, with a sigma below 2%; far out the exact rendering is wrong for the camera and the
// verification fails (reason verification_failed, p95 above the tolerance); shards 1/2 and 2/2 merged give the
// full run's rows exactly (timing columns aside); merge refuses shards of a different grid and overlapping
// shards; the outputs (CSV, JSON, summary with the boundary, chart) exist. Does not prove the boundary's
// position beyond these three points.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli_test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::CliRun;
using testing::RunBinary;
using testing::Slurp;

using testing::ReadCsv;
using testing::Rows;
using testing::WithoutTimes;

class SweepCli : public ::testing::Test {
 protected:
  static fs::path dir_;
  static CliRun full_, shard1_, shard2_;

  static CliRun Curvecheck(const std::vector<std::string>& args) {
    return RunBinary(CURVECHECK_BINARY, args, dir_);
  }
  static std::vector<std::string> SweepArgs(const std::string& out) {
    // Scale 0.5 (3000 x 2000 px, 2.5 display px per camera px at 1.5 m): at the default 0.25 the detector's
    // systematic term alone puts U at the 0.5 display px tolerance, and a correct correction is inconclusive.
    return {"sweep", "--factor", "viewpoint_offset=0:600:3", "--method", "exact", "--scale", "0.5", "--jobs", "2",
            "-o", (dir_ / out).string()};
  }

  static void SetUpTestSuite() {
    dir_ = curvecheck::testing::FreshDir("sweep_cli_test");
    full_ = Curvecheck(SweepArgs("full"));
    std::vector<std::string> a = SweepArgs("shards/s1");
    a.insert(a.end(), {"--shard", "1/2"});
    shard1_ = Curvecheck(a);
    a = SweepArgs("shards/s2");
    a.insert(a.end(), {"--shard", "2/2"});
    shard2_ = Curvecheck(a);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
};

fs::path SweepCli::dir_;
CliRun SweepCli::full_, SweepCli::shard1_, SweepCli::shard2_;

TEST_F(SweepCli, OnAxisSucceedsWithTheTrueRadiusAndFarOffsetFailsVerification) {
  ASSERT_EQ(full_.code, 0) << full_.err << full_.out;
  const Rows rows = ReadCsv(dir_ / "full" / "sweep.csv");
  ASSERT_EQ(rows.size(), 3u);
  const auto& on_axis = rows[0];
  EXPECT_EQ(on_axis.at("viewpoint_offset_mm"), "0");
  EXPECT_EQ(on_axis.at("success"), "1") << on_axis.at("reason") << " " << on_axis.at("detail");
  EXPECT_EQ(on_axis.at("verification_pass"), "1");
  EXPECT_LT(std::stod(on_axis.at("verification_p95_display_px")), 0.5);
  const double radius = std::stod(on_axis.at("radius_mm")), sigma = std::stod(on_axis.at("radius_sigma_mm"));
  EXPECT_EQ(std::stod(on_axis.at("true_radius_mm")), 1000);
  EXPECT_NEAR(std::stod(on_axis.at("radius_error_mm")), radius - 1000, 1e-3);
  // Within 0.6% of the truth, and within its 95% interval: before issue 16 the radius at this scale was
  // 998.8 +- 0.4 mm on every seed (995.5 +- 0.8 at 1500 x 1000 px), a systematic error of the detections (the
  // detector's pixel-locking) that the noise-derived sigma did not cover; the uncertainty budget's
  // detector-systematic row now holds it (sigma 1.2 mm here, measured 2026-12-02). Since the default scene's
  // lens departs from its model (imaging.lens_misfit_px 0.1 px at 6000 px), the budget's lens-model-misfit row,
  // measured from the residuals, widens it: sigma 3.64 mm (measured 2026-12-02).
  EXPECT_LT(std::abs(radius - 1000), 6);
  EXPECT_LT(sigma, 6);
  EXPECT_EQ(on_axis.at("truth_in_ci95"), std::abs(radius - 1000) <= 1.96 * sigma ? "1" : "0");
  EXPECT_EQ(on_axis.at("truth_in_ci95"), "1") << radius << " +- " << sigma;
  EXPECT_EQ(on_axis.at("fit_status"), "ok");

  const auto& far = rows[2];
  EXPECT_EQ(far.at("viewpoint_offset_mm"), "600");
  EXPECT_EQ(far.at("success"), "0");
  EXPECT_EQ(far.at("reason"), "verification_failed") << far.at("detail");
  EXPECT_GT(std::stod(far.at("verification_p95_display_px")), 0.5);

  // Every point is rendered for the same viewpoint: one render, then the cache.
  int cached = 0;
  for (const auto& row : rows) cached += row.at("render_ms") == "0" ? 1 : 0;
  EXPECT_EQ(cached, 2);
  // Seeds: --seed (1) + point index.
  EXPECT_EQ(rows[2].at("seed"), "3");

  const std::string summary = Slurp(dir_ / "full" / "sweep.txt");
  EXPECT_THAT(summary, HasSubstr("boundary: exact succeeds for viewpoint_offset_mm in "));
  EXPECT_THAT(full_.out, HasSubstr("boundary: exact succeeds for viewpoint_offset_mm in "));
  EXPECT_GT(fs::file_size(dir_ / "full" / "sweep-exact.png"), 10000u);
  EXPECT_TRUE(fs::exists(dir_ / "full" / "sweep-exact.gp"));
  const nlohmann::json meta = nlohmann::json::parse(Slurp(dir_ / "full" / "sweep.json"));
  EXPECT_EQ(meta.at("format"), "curvecheck.sweep/1");
  EXPECT_EQ(meta.at("grid").at("points"), 3);
  EXPECT_EQ(meta.at("shard").at("count"), 1);
}

TEST_F(SweepCli, ShardsMergeIntoTheFullRunsRows) {
  ASSERT_EQ(shard1_.code, 0) << shard1_.err << shard1_.out;
  ASSERT_EQ(shard2_.code, 0) << shard2_.err << shard2_.out;
  EXPECT_EQ(ReadCsv(dir_ / "shards/s1/sweep.csv").size(), 2u);  // points 0 and 2
  EXPECT_EQ(ReadCsv(dir_ / "shards/s2/sweep.csv").size(), 1u);  // point 1
  // Merge the folder that holds the shards.
  const CliRun m = Curvecheck({"sweep", "merge", (dir_ / "shards").string(), "-o", (dir_ / "merged").string()});
  ASSERT_EQ(m.code, 0) << m.err << m.out;
  const Rows full = ReadCsv(dir_ / "full" / "sweep.csv"), merged = ReadCsv(dir_ / "merged" / "sweep.csv");
  ASSERT_EQ(merged.size(), full.size());
  for (size_t i = 0; i < full.size(); ++i) EXPECT_EQ(WithoutTimes(merged[i]), WithoutTimes(full[i])) << i;
  EXPECT_TRUE(fs::exists(dir_ / "merged" / "sweep-exact.png"));
  const nlohmann::json meta = nlohmann::json::parse(Slurp(dir_ / "merged" / "sweep.json"));
  EXPECT_EQ(meta.at("missing_points"), 0);
}

TEST_F(SweepCli, MergeRefusesMismatchedOverlappingOrInputShards) {
  ASSERT_EQ(shard1_.code, 0) << shard1_.err;
  // A shard of another grid (here: another seed).
  fs::create_directories(dir_ / "other");
  fs::copy(dir_ / "shards/s2", dir_ / "other/s2", fs::copy_options::recursive);
  nlohmann::json meta = nlohmann::json::parse(Slurp(dir_ / "other/s2/sweep.json"));
  meta["grid"]["seed"] = 7;
  std::ofstream(dir_ / "other/s2/sweep.json") << meta.dump(1);
  CliRun r = Curvecheck({"sweep", "merge", (dir_ / "shards/s1").string(), (dir_ / "other/s2").string(), "-o",
                         (dir_ / "bad").string()});
  testing::ExpectOneLineFailure(r, {"sweep.json", "a shard of a different sweep", "seed: 7 here, 1 in"});
  EXPECT_FALSE(fs::exists(dir_ / "bad" / "sweep.csv"));
  // The same shard twice.
  r = Curvecheck({"sweep", "merge", (dir_ / "shards/s1").string(), (dir_ / "shards/s1").string(), "-o",
                  (dir_ / "bad").string()});
  testing::ExpectOneLineFailure(r, {"point 0 is also in", "the shards overlap"});
  // Into one of its inputs.
  r = Curvecheck({"sweep", "merge", (dir_ / "shards/s1").string(), "-o", (dir_ / "shards/s1").string()});
  testing::ExpectOneLineFailure(r, {"sweep.csv", "is an input of this command"});
  // A bad factor.
  r = Curvecheck({"sweep", "--factor", "tilt=0:1:2", "-o", (dir_ / "bad").string()});
  testing::ExpectOneLineFailure(r, {"--factor", "'tilt' is not a sweep factor", "yaw_deg"});
}

}  // namespace
}  // namespace curvecheck
