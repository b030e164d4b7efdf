// `curvecheck report RESULT.json [-o report.html]`: (re)writes the self-contained HTML page of an analysis from its
// result.json and the overlay images beside it (overlay-<photo>.png, as `analyze` writes them). A missing overlay
// is said in the page, not an error. The page goes next to RESULT.json as report.html unless -o says otherwise;
// an input is never overwritten.
#include "app/report_command.h"

#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "analysis/report.h"
#include "analysis/result_reader.h"
#include "core/output_paths.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/stopwatch.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct ReportArgs {
  std::string result;
  std::string output;
};

int RunReport(const ReportArgs& a) {
  const Stopwatch watch;
  const fs::path result_path = a.result;
  const fs::path dir = result_path.has_parent_path() ? result_path.parent_path() : fs::path(".");
  const fs::path out = a.output.empty() ? dir / "report.html" : fs::path(a.output);
  const nlohmann::json result = ReadResultJson(result_path);
  const ReportAssets assets = LoadReportAssets(result, dir, result_path.string());
  std::vector<fs::path> inputs = {result_path};
  for (const auto& [name, bytes] : assets.overlay_png) inputs.push_back(dir / OverlayFileName(name));
  for (const auto& [name, why] : assets.overlay_missing) inputs.push_back(dir / OverlayFileName(name));
  CheckNotAnInput(out, inputs);
  CheckWritable(out);
  const std::string html = ReportHtml(result, assets);
  WriteFileAtomic(out, html);
  const double ms = watch.Ms();
  std::cout << fmt::format("wrote {} ({:.2f} MB, {} overlay image(s) embedded{}) in {:.0f} ms\n", out.string(),
                           html.size() / 1e6, assets.overlay_png.size(),
                           assets.overlay_missing.empty()
                               ? std::string()
                               : fmt::format(", {} missing", assets.overlay_missing.size()),
                           ms);
  for (const auto& [name, why] : assets.overlay_missing) std::cout << "no overlay for " << name << ": " << why << "\n";
  return 0;
}

}  // namespace

void AddReportCommand(CLI::App& app, std::function<int()>& run) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "report",
      "Write the self-contained HTML report (report.html) of an analysis from its result.json and the overlay images "
      "beside it");
  cmd->add_option("result", args->result, "result.json written by curvecheck analyze")->required();
  cmd->add_option("-o,--output", args->output, "The page to write (default: report.html beside RESULT.json)");
  cmd->callback([&run, args] { run = [args] { return RunReport(*args); }; });
}

}  // namespace curvecheck::app
