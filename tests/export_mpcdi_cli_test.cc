// `curvecheck export-mpcdi` end to end (app/export_mpcdi_command.cc): the archive it writes, read back with the
// shipped reader (mpcdi/mpcdi_file.h), against the warp computed here from the same inputs; result.json fits that
// give no radius refused with their reason; bad options.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/file_io.h"
#include "core/screen_geometry.h"
#include "mpcdi/mpcdi_file.h"
#include "mpcdi/warp_grid.h"
#include "tests/cli_test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;

class ExportMpcdiCli : public testing::CliTest {
 protected:
  ExportMpcdiCli() : CliTest("export_mpcdi_cli") {}
  // A real result.json of `analyze` (fuzz corpus): a 49" 1000R panel measured at 1071.6 mm.
  static json Result(const std::string& name) {
    return json::parse(ReadFileToString(fs::path(std::getenv("CURVECHECK_SOURCE_DIR")) / "fuzz/corpus/fuzz_result_json" /
                                        (name + ".json")));
  }
  fs::path Write(const std::string& name, const json& j) {
    WriteFileAtomic(dir_ / name, j.dump());
    return dir_ / name;
  }
  // Largest |u, v| difference between two grids of the same size.
  static double MaxDifference(const WarpGrid& a, const WarpGrid& b) {
    EXPECT_EQ(a.uv.size(), b.uv.size());
    double d = 0;
    for (size_t k = 0; k < a.uv.size() && k < b.uv.size(); ++k) d = std::max(d, double((a.uv[k] - b.uv[k]).norm()));
    return d;
  }
};

TEST_F(ExportMpcdiCli, MonitorPresetWritesTheNominalCorrection) {
  const CliRun r = Curvecheck({"export-mpcdi", "--monitor", "49in-5120x1440-1000r", "--viewpoint", "0,0,500", "-o",
                               (dir_ / "w.mpcdi").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("grid 321 x 91 samples"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("interpolation error max 0.004"));
  const MpcdiContents c = ReadMpcdi(dir_ / "w.mpcdi");
  EXPECT_EQ(c.profile, "2d");
  EXPECT_EQ(c.version, "2.0");
  EXPECT_EQ(c.buffer_width_px, 5120);
  EXPECT_EQ(c.alpha_width_px, 5120);
  EXPECT_EQ(c.alpha_height_px, 1440);
  const Monitor m = MonitorFromDiagonal("49", 5120, 1440, 49, 1000);
  EXPECT_LT(MaxDifference(c.warp, MakeWarpGrid(m, {0, 0, 500}, nullptr, 321, 91)), 1e-7);

  // --grid, and --radius-mm: the same viewpoint relative to the screen centre on a 1200 mm cylinder.
  const CliRun g = Curvecheck({"export-mpcdi", "--monitor", "49in-5120x1440-1000r", "--radius-mm", "1200",
                               "--distance-mm", "1500", "--grid", "33,9", "-o", (dir_ / "g.mpcdi").string()});
  ASSERT_EQ(g.code, 0) << g.err;
  const Monitor m1200 = MonitorFromDiagonal("49", 5120, 1440, 49, 1200);
  EXPECT_LT(MaxDifference(ReadMpcdi(dir_ / "g.mpcdi").warp,
                          MakeWarpGrid(m1200, ScreenCentreInScreen(m1200) + Eigen::Vector3d(0, 0, 1500), nullptr, 33, 9)),
            1e-7);
}

TEST_F(ExportMpcdiCli, ResultJsonUsesTheFittedRadiusAndTheDeviationField) {
  json result = Result("cylinder-1080r");
  const double radius = result["fit"]["radius_mm"].get<double>();
  ASSERT_NEAR(radius, 1071.65, 0.01);
  const CliRun r = Curvecheck({"export-mpcdi", "--result", Write("result.json", result).string(), "--viewpoint",
                               "0,0,500", "--grid", "65,19", "-o", (dir_ / "r.mpcdi").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("model cylinder, radius 1071.6 mm +- 1.5 mm"));
  // --viewpoint is in the nominal (1000R) frame: 1500 mm in front of the screen centre, wherever the fitted axis is.
  const Monitor fitted = MonitorFromDiagonal("49", 5120, 1440, 49, radius);
  const Eigen::Vector3d eye = ScreenCentreInScreen(fitted) + Eigen::Vector3d(0, 0, 1500);
  EXPECT_LT(MaxDifference(ReadMpcdi(dir_ / "r.mpcdi").warp, MakeWarpGrid(fitted, eye, nullptr, 65, 19)), 1e-7);

  // cylinder+deviation: the map of result.json (u fastest, v = -1 at the top; null = 0 mm) moves the screen.
  result["fit"]["model"] = "cylinder+deviation";
  DeviationMap dev;
  dev.nu = 4;
  dev.nv = 3;
  json mm = json::array();
  for (int k = 0; k < 12; ++k) {
    dev.mm.push_back(k == 5 ? 0.0 : 0.5 * k - 2);
    mm.push_back(k == 5 ? json(nullptr) : json(0.5 * k - 2));
  }
  result["deviations"]["map"] = {{"nu", 4}, {"nv", 3}, {"mm", mm}, {"sigma_mm", json::array()}};
  for (int k = 0; k < 12; ++k) result["deviations"]["map"]["sigma_mm"].push_back(0.1);
  const CliRun d = Curvecheck({"export-mpcdi", "--result", Write("dev.json", result).string(), "--viewpoint",
                               "0,0,500", "--grid", "65,19", "-o", (dir_ / "d.mpcdi").string()});
  ASSERT_EQ(d.code, 0) << d.err;
  EXPECT_THAT(d.out, ::testing::HasSubstr("1 of 12 cells of the deviation map have no feature near them"));
  const WarpGrid expected = MakeWarpGrid(fitted, eye, &dev, 65, 19);
  const WarpGrid got = ReadMpcdi(dir_ / "d.mpcdi").warp;
  EXPECT_LT(MaxDifference(got, expected), 1e-7);
  // The field matters: 1.5 mm of bulge moves the warp by far more than the float storage (6e-8).
  EXPECT_GT(MaxDifference(got, MakeWarpGrid(fitted, eye, nullptr, 65, 19)), 1e-4);
}

TEST_F(ExportMpcdiCli, FitsWithoutARadiusAreRefusedWithTheirReason) {
  const std::string out = (dir_ / "x.mpcdi").string();
  auto run = [&](const fs::path& result) {
    return Curvecheck({"export-mpcdi", "--result", result.string(), "--viewpoint", "0,0,500", "-o", out});
  };
  ExpectFailure(run(Write("ill.json", Result("edited-ill-conditioned"))),
                {"ill.json", "has no radius", "radius ill-conditioned: the photos cover a narrow part of the screen",
                 "bounded below, by 5000 mm", "--monitor M [--radius-mm R]"});
  ExpectFailure(run(Write("nofit.json", Result("uncorrected-nofit"))), {"nofit.json", "the analysis has no fit"});
  json inadequate = Result("cylinder-1080r");
  inadequate["fit"]["status"] = "inadequate";
  ExpectFailure(run(Write("inadequate.json", inadequate)),
                {"does not fit the photos to their noise", "its radius is not a measurement"});
  json illc = Result("cylinder-1080r");
  illc["fit"]["status"] = "ill_conditioned";
  illc["fit"]["condition_note"] = "radius unobservable: test";
  ExpectFailure(run(Write("illc.json", illc)), {"do not determine the radius", "radius unobservable: test"});
  json flat = Result("cylinder-1080r");
  flat["fit"]["model"] = "flat";
  ExpectFailure(run(Write("flat.json", flat)), {"the chosen model is flat"});
  EXPECT_FALSE(fs::exists(out)) << "nothing is written on refusal";
}

TEST_F(ExportMpcdiCli, BadOptions) {
  ExpectFailure(Curvecheck({"export-mpcdi", "--monitor", "49in-5120x1440-1000r", "--viewpoint", "0,0,500", "-o",
                            (dir_ / "w.zip").string()}),
                {"-o", "does not end in .mpcdi"});
  ExpectFailure(Curvecheck({"export-mpcdi", "--viewpoint", "0,0,500", "-o", (dir_ / "w.mpcdi").string()}),
                {"neither --result nor --monitor"});
  ExpectFailure(Curvecheck({"export-mpcdi", "--monitor", "49in-5120x1440-1000r", "-o", (dir_ / "w.mpcdi").string()}),
                {"--viewpoint", "no viewpoint given"});
  ExpectFailure(Curvecheck({"export-mpcdi", "--monitor", "49in-5120x1440-1000r", "--viewpoint", "0,0,500", "--grid",
                            "1,5", "-o", (dir_ / "w.mpcdi").string()}),
                {"--grid", "from 2 to 8192"});
  ExpectFailure(Curvecheck({"export-mpcdi", "--monitor", "49in-5120x1440-1000r", "--viewpoint", "0,0,-900", "-o",
                            (dir_ / "w.mpcdi").string()}),
                {"does not meet the plane of the source image", "move the viewpoint back"});
  EXPECT_FALSE(fs::exists(dir_ / "w.mpcdi"));
}

}  // namespace
}  // namespace curvecheck
