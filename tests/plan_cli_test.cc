// `curvecheck plan` end to end (issue 20 part 1): plan for the default scene's camera at quarter resolution,
// take the realistic synthetic photos (`capture synth`, imaging preset ilc24) at every planned position,
// analyse them in one `analyze` run and hold the measured radius sigma to the prediction within a factor 1.3,
// for three seeds of the photos (sensor noise and the true lens's misfit field both drawn anew), and the
// predicted verification U against analyze's on the photo from the eye point. Also: plan.json's contract, and
// the refusals of bad input.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/cli_test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using curvecheck::testing::CliRun;
using curvecheck::testing::ExpectOneLineFailure;
using curvecheck::testing::Slurp;

class PlanCli : public ::testing::Test {
 protected:
  static fs::path Dir() { return curvecheck::testing::ProcessDir("plan_cli_test"); }
  static fs::path Source() { return std::getenv("CURVECHECK_SOURCE_DIR"); }
  static CliRun Curvecheck(const std::vector<std::string>& args) {
    return curvecheck::testing::RunBinary(CURVECHECK_BINARY, args, Dir());
  }
  // The default scene with the camera at `position` looking at `look_at`, the photo noise and the true lens's
  // misfit drawn from `seed`.
  static fs::path Scene(const std::string& name, const nlohmann::json& position,
                        const nlohmann::json& look_at, int seed) {
    const fs::path path = Dir() / (name + ".yaml");
    std::ofstream(path)
        << "format: curvecheck.scene/1\nmonitor: default\n"
        << "camera: {model: " << (Source() / "datasets/cameras/default-24mp-opencv8.cameramodel").string()
        << ", position_mm: " << position.dump() << ", look_at_mm: " << look_at.dump() << "}\n"
        << "optics: {supersample: 2, blur: gaussian, blur_px: 0.7, vignetting: 0.2, exposure: 0.9}\n"
        << "sensor: {gamma: 1, full_well_e: 20000, read_noise_e: 3, seed: " << seed << ", bits: 8}\n"
        << "imaging: {preset: ilc24, lens_seed: " << seed << "}\n";
    return path;
  }
  static void SetUpTestSuite() {
    curvecheck::testing::FreshDir("plan_cli_test");
    const CliRun r = Curvecheck(
        {"render", "--monitor", "default", "--viewpoint", "0,0,500", "-o", (Dir() / "p.png").string()});
    ASSERT_EQ(r.code, 0) << r.err;
    const CliRun c = Curvecheck(
        {"capture", "synth", "--scene", Scene("ref", {0, 0, 500}, {0, 0, -1000}, 1).string(), "--display",
         (Dir() / "p.png").string(), "-o", (Dir() / "ref.png").string(), "--scale", "0.25"});
    ASSERT_EQ(c.code, 0) << c.err;
  }
  static void TearDownTestSuite() { fs::remove_all(Dir()); }
};

// The plan's prediction against analyze on photos from the planned positions, two seeds of the photos. The
// plan is deterministic (its own simulated draws are seeded); the photos are not the plan's draws.
TEST_F(PlanCli, PredictedRadiusSigmaWithinAFactor1p3OfTheMeasuredOne) {
  const CliRun p = Curvecheck({"plan", "--monitor", "default", "--camera",
                               (Dir() / "ref.cameramodel").string(), "--pattern", (Dir() / "p.json").string(),
                               "--target-sigma-mm", "2", "-o", (Dir() / "plan").string()});
  ASSERT_EQ(p.code, 0) << p.err;
  EXPECT_THAT(p.out, ::testing::HasSubstr("predicted radius sigma"));
  const nlohmann::json plan = nlohmann::json::parse(Slurp(Dir() / "plan" / "plan.json"));
  EXPECT_EQ(plan["format"], "curvecheck.plan/1");
  ASSERT_GE(plan["positions"].size(), 1u);
  EXPECT_TRUE(fs::exists(Dir() / "plan" / "plan.png"));
  EXPECT_TRUE(plan["predicted_verification_u_display_px"].is_number());
  const double predicted = plan["predicted_radius_sigma_mm"];
  EXPECT_LE(predicted, 2.0);
  EXPECT_TRUE(plan["target_reached"]);
  // The verification capability against analyze's U on the photo from the eye point (the suite's ref.png).
  {
    const CliRun a = Curvecheck({"analyze", "--camera", (Dir() / "ref.cameramodel").string(), "--pattern",
                                 (Dir() / "p.json").string(), (Dir() / "ref.png").string(), "-o",
                                 (Dir() / "an-eye").string(), "--no-report", "--no-overlays", "--no-fit"});
    ASSERT_EQ(a.code, 0) << a.err;
    const nlohmann::json result = nlohmann::json::parse(Slurp(Dir() / "an-eye" / "result.json"));
    const double u = result["verification"]["expanded_uncertainty_display_px"];
    const double u_predicted = plan["predicted_verification_u_display_px"];
    std::cout << "verification U: predicted " << u_predicted << ", measured " << u << " display px\n";
    EXPECT_GE(u, u_predicted / 1.3);
    EXPECT_LE(u, u_predicted * 1.3);
  }
  for (int seed : {2, 3, 4}) {
    std::vector<std::string> args = {"analyze", "--camera", (Dir() / "ref.cameramodel").string(), "--pattern",
                                     (Dir() / "p.json").string()};
    for (size_t i = 0; i < plan["positions"].size(); ++i) {
      const nlohmann::json& q = plan["positions"][i];
      const std::string name = "s" + std::to_string(seed) + "-" + std::to_string(i);
      const CliRun c = Curvecheck({"capture", "synth", "--scene",
                                   Scene(name, q["position_mm"], q["look_at_mm"], seed).string(), "--display",
                                   (Dir() / "p.png").string(), "-o", (Dir() / (name + ".png")).string(),
                                   "--scale", "0.25"});
      ASSERT_EQ(c.code, 0) << c.err;
      args.push_back((Dir() / (name + ".png")).string());
    }
    const fs::path out = Dir() / ("an" + std::to_string(seed));
    args.insert(args.end(), {"-o", out.string(), "--no-report", "--no-overlays"});
    const CliRun a = Curvecheck(args);
    ASSERT_EQ(a.code, 0) << a.err;
    const nlohmann::json result = nlohmann::json::parse(Slurp(out / "result.json"));
    ASSERT_TRUE(result["fit"]["radius_sigma_mm"].is_number()) << a.out;
    const double measured = result["fit"]["radius_sigma_mm"];
    std::cout << "seed " << seed << ": " << plan["positions"].size() << " planned photos, predicted "
              << predicted << " mm, measured " << measured << " mm (ratio " << measured / predicted << ")\n";
    EXPECT_GE(measured, predicted / 1.3) << "seed " << seed;
    EXPECT_LE(measured, predicted * 1.3) << "seed " << seed;
  }
}

// Bad input needs no photos: a suite of its own, without PlanCli's render and capture.
TEST(PlanCliInput, RefusesBadInput) {
  const fs::path dir = curvecheck::testing::FreshDir("plan_cli_input_test");
  const auto Curvecheck = [&](const std::vector<std::string>& args) {
    return curvecheck::testing::RunBinary(CURVECHECK_BINARY, args, dir);
  };
  ExpectOneLineFailure(Curvecheck({"plan", "--monitor", "default", "-o", (dir / "x").string()}),
                       {"--camera", "--sensor-px"});
  ExpectOneLineFailure(Curvecheck({"plan", "--monitor", "default", "--sensor-px", "6000", "--focal-px",
                                   "5000", "-o", (dir / "x").string()}),
                       {"--sensor-px"});
  // A flat monitor has no radius to plan for.
  ExpectOneLineFailure(Curvecheck({"plan", "--monitor", "27in-2560x1440-flat", "--sensor-px", "6000,4000",
                                   "--focal-px", "5000", "-o", (dir / "x").string()}),
                       {"flat"});
  EXPECT_FALSE(fs::exists(dir / "x" / "plan.json"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace curvecheck
