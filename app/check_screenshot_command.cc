// `curvecheck check-screenshot`: measures a framebuffer capture of another application's corrected pattern
// against pattern.json (analysis/screenshot_check.h); writes OUT/screenshot_check.json and OUT/error_map.png.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <opencv2/core.hpp>

#include "analysis/screenshot_check.h"
#include "app/cli.h"
#include "core/output_paths.h"
#include "app/thirdparty_commands.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "detect/detect.h"
#include "pattern/pattern_json.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct CheckScreenshotArgs {
  std::string pattern;
  std::string screenshot;
  double tolerance_px = 0.5;
  std::optional<double> gamma;
  double magnify = 0;  // 0 = auto
  std::string output = "screenshot-check";
};

int RunCheckScreenshot(const CheckScreenshotArgs& a) {
  const fs::path dir = a.output;
  const fs::path json_path = dir / "screenshot_check.json", map_path = dir / "error_map.png";
  CheckOutputs({{"-o DIR/screenshot_check.json", json_path}, {"-o DIR/error_map.png", map_path}},
               {a.pattern, a.screenshot});
  const PatternFile pattern = ReadPatternJson(a.pattern);
  cv::Mat image = ReadPhotoGray(a.screenshot);
  if (image.depth() == CV_16U) image.convertTo(image, CV_8U, 1.0 / 257);
  ScreenshotCheckOptions options;
  options.tolerance_px = a.tolerance_px;
  options.gamma = a.gamma;
  const ScreenshotCheck check = CheckScreenshot(image, pattern, options);
  if (check.refusal != ScreenshotRefusal::kNone) {
    throw Error(a.screenshot, fmt::format("refused ({}): {}", ScreenshotRefusalName(check.refusal), check.reason),
                check.refusal == ScreenshotRefusal::kNotFound
                    ? "capture the application's framebuffer while it shows the pattern of --pattern's texture.png"
                    : "capture the framebuffer at the display's resolution, full screen, unscaled and uncropped");
  }
  OutputFolder folder(dir, "-o");
  nlohmann::json doc = ScreenshotCheckToJson(check, pattern);
  doc["screenshot"] = fs::path(a.screenshot).filename().string();
  doc["pattern_json"] = fs::path(a.pattern).filename().string();
  doc["command"] = CommandLine();
  // Vectors magnified so that the largest is about 3% of the display's width.
  const double magnify = a.magnify > 0 ? a.magnify
                                       : std::max(1.0, 0.03 * pattern.monitor.width_px / std::max(1e-9, check.max_px));
  const GnuplotChart chart = ScreenshotErrorMap(check, pattern, magnify);
  ChartDataFolder data("check-screenshot error map");
  WriteFileAtomic(data.path() / chart.data_name, chart.data);
  const double aspect = static_cast<double>(pattern.monitor.height_px) / pattern.monitor.width_px;
  const std::string png = RenderGnuplot(chart.script, ChartFormat::kPng,
                                        {1600, std::max(400, static_cast<int>(1600 * aspect) + 200)}, data.path());
  OutputSet set;
  set.Write(json_path, doc.dump(1) + "\n");
  set.Write(map_path, png);
  set.Publish();
  folder.Keep();
  std::cout << fmt::format(
      "{} of {} visible features measured ({}); error vs exact: rms {:.4f} px, p95 {:.4f} px, max {:.4f} px "
      "(display px)\nverdict at tolerance {:g} px: {} (U = {:.4f} px, k = 2; T/U = {:.3g})\nwrote {} and {}\n",
      check.features.size(), check.pattern_features, check.detector, check.rms_px, check.p95_px, check.max_px,
      check.tolerance_px, check.verdict, check.expanded_uncertainty_px,
      check.expanded_uncertainty_px > 0 ? check.tolerance_px / check.expanded_uncertainty_px : INFINITY,
      json_path.string(), map_path.string());
  return 0;
}

}  // namespace

void AddCheckScreenshotCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<CheckScreenshotArgs>();
  CLI::App* cmd = app.add_subcommand(
      "check-screenshot",
      "Measure another application's correction from a framebuffer capture at display resolution: every feature "
      "against its exact display position in pattern.json; writes OUT/screenshot_check.json and OUT/error_map.png");
  cmd->add_option("--pattern", args->pattern, "pattern.json (from `curvecheck pattern` or `render`)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("screenshot", args->screenshot, "The capture (PNG, display resolution)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--tolerance", args->tolerance_px, "Tolerance on the largest error, display px")
      ->capture_default_str()
      ->check(InRange(1e-6, 1e6, "px", "a positive tolerance"));
  cmd->add_option("--gamma", args->gamma,
                  "Display gamma for linearizing code values (default: pattern.json's render gamma, else 2.2)")
      ->check(InRange(0.1, 10, "", "a display gamma"));
  cmd->add_option("--magnify", args->magnify, "Error vectors in the map magnified this many times (0 = auto)")
      ->check(InRange(0, 1e9, "", "a factor"));
  cmd->add_option("-o,--output", args->output, "Output folder")->capture_default_str();
  cmd->callback([&run, args] { run = [args] { return RunCheckScreenshot(*args); }; });
}

}  // namespace curvecheck::app
