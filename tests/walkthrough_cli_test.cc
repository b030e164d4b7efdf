// docs/walkthrough.md ("Check your own monitor"), run: the page is the single source of its commands. Its fenced
// blocks are typed by their info string:
//   ```sh walkthrough   a command the user runs as written: run here, in the page's order
//   ```sh stand-in      what this test does instead of a step with the real camera (synthetic photos): run here
//   ```sh by-hand       a step with the real monitor and camera, or another way to do a step: not run; each
//                       `curvecheck` command in it must name a subcommand whose --help lists every option it uses
//   ```text output      lines `analyze` prints: each must match a printed line, with any number for the numbers
// Every runnable block gets a fresh `bash -eu -o pipefail` in one empty folder, the built curvecheck first on PATH,
// so a flag, a file name or an output line that changes fails this test, naming the block's line in the page.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/stopwatch.h"
#include "core/subprocess.h"
#include "tests/cli_test_util.h"

namespace curvecheck::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

fs::path SourceDir() {
  const char* s = std::getenv("CURVECHECK_SOURCE_DIR");
  return s ? s : CURVECHECK_SOURCE_DIR;
}

fs::path Page() { return SourceDir() / "docs" / "walkthrough.md"; }

struct Block {
  std::string kind;  // the fence's info string, e.g. "sh walkthrough"
  int line = 0;      // of the opening fence, 1-based
  std::string text;
};

// The fenced blocks of a Markdown file, in order.
std::vector<Block> ReadBlocks(const fs::path& md) {
  std::istringstream in(Slurp(md));
  std::vector<Block> blocks;
  bool open = false;
  size_t indent = 0;  // of the opening fence (a block inside a list item): taken off its lines
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    const size_t first = std::min(line.find_first_not_of(' '), line.size());
    if (line.compare(first, 3, "```") != 0) {
      if (open) blocks.back().text += line.substr(std::min(first, indent)) + "\n";
      continue;
    }
    if (open) {
      open = false;
      continue;
    }
    open = true;
    indent = first;
    blocks.push_back({line.substr(first + 3), n, ""});
  }
  EXPECT_FALSE(open) << md << ": a fence is not closed";
  return blocks;
}

std::vector<Block> BlocksOfKind(const std::vector<Block>& all, const std::set<std::string>& kinds) {
  std::vector<Block> out;
  for (const Block& b : all) {
    if (kinds.count(b.kind)) out.push_back(b);
  }
  return out;
}

std::string Tail(const std::string& text, size_t chars = 3000) {
  return text.size() <= chars ? text : "..." + text.substr(text.size() - chars);
}

json ReadJson(const fs::path& p) {
  EXPECT_TRUE(fs::is_regular_file(p)) << p << " is missing";
  return json::parse(Slurp(p));
}

// A line of the page's `text output` block as a pattern: every number stands for any number.
std::regex LinePattern(const std::string& line) {
  static const std::regex number(R"(-?[0-9]+(\.[0-9]+)?(e[-+]?[0-9]+)?)");
  static const std::regex special(R"([.^$|()\[\]{}*+?\\])");
  std::string pattern;
  std::sregex_iterator it(line.begin(), line.end(), number), end;
  size_t at = 0;
  for (; it != end; ++it) {
    pattern += std::regex_replace(line.substr(at, it->position() - at), special, R"(\$&)");
    pattern += R"(-?[0-9]+(\.[0-9]+)?(e[-+]?[0-9]+)?)";
    at = it->position() + it->length();
  }
  pattern += std::regex_replace(line.substr(at), special, R"(\$&)");
  return std::regex("^" + pattern + "$");
}

// The `curvecheck ...` command lines of a shell block (continuation lines joined), as words.
std::vector<std::vector<std::string>> CurvecheckCommands(const std::string& script) {
  std::string joined = std::regex_replace(script, std::regex("\\\\\n"), " ");
  std::vector<std::vector<std::string>> commands;
  std::istringstream lines(joined);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string s; words >> s;) w.push_back(s);
    for (size_t i = 0; i < w.size(); ++i) {
      if (w[i] != "curvecheck") continue;
      commands.emplace_back(w.begin() + static_cast<long>(i) + 1, w.end());
      break;
    }
  }
  return commands;
}

TEST(WalkthroughPage, IsLinkedFromTheTopOfTheReadmeAndHasEveryKindOfBlock) {
  std::istringstream readme(Slurp(SourceDir() / "README.md"));
  std::string top;
  std::string line;
  for (int i = 0; i < 20 && std::getline(readme, line); ++i) top += line + "\n";
  EXPECT_THAT(top, ::testing::HasSubstr("docs/walkthrough.md"));
  const std::vector<Block> blocks = ReadBlocks(Page());
  for (const std::string kind : {"sh walkthrough", "sh stand-in", "sh by-hand", "text output"}) {
    EXPECT_FALSE(BlocksOfKind(blocks, {kind}).empty()) << "no ```" << kind << " block in " << Page();
  }
  for (const Block& b : blocks) {
    if (b.kind.starts_with("sh")) {
      EXPECT_THAT(b.kind, ::testing::AnyOf("sh walkthrough", "sh stand-in", "sh by-hand"))
          << Page() << ":" << b.line << ": a shell block must say whether it is run (walkthrough, stand-in) or not";
    }
  }
}

// The steps with the real monitor and camera cannot run here; their options are checked against the commands'
// help, so that they cannot name an option that does not exist (or no longer does).
TEST(WalkthroughPage, ByHandCommandsUseRealSubcommandsAndOptions) {
  const std::set<std::string> nested = {"capture", "bench", "sweep"};
  int checked = 0;
  for (const Block& b : BlocksOfKind(ReadBlocks(Page()), {"sh by-hand"})) {
    for (const std::vector<std::string>& words : CurvecheckCommands(b.text)) {
      ASSERT_FALSE(words.empty()) << Page() << ":" << b.line;
      std::vector<std::string> sub = {words[0]};
      if (nested.count(words[0]) && words.size() > 1 && !words[1].starts_with("-")) sub.push_back(words[1]);
      std::vector<std::string> args = sub;
      args.push_back("--help");
      const CliRun help = RunBinary(CURVECHECK_BINARY, args, {});
      std::string usage = "Usage: curvecheck";
      for (const std::string& word : sub) usage += " " + word;
      // An unknown subcommand's --help prints the program's help (exit 0): its usage line names no subcommand.
      if (help.code != 0 || help.out.find(usage + " ") == std::string::npos) {
        ADD_FAILURE() << Page() << ":" << b.line << ": `" << usage.substr(7) << "` is not a curvecheck command\n"
                      << help.err;
        continue;
      }
      for (const std::string& w : words) {
        if (!w.starts_with("--")) continue;
        const std::string option = w.substr(0, w.find('='));
        EXPECT_TRUE(std::regex_search(help.out, std::regex(option + "([^a-z0-9-]|$)")))
            << Page() << ":" << b.line << ": `curvecheck " << sub[0] << (sub.size() > 1 ? " " + sub[1] : "")
            << "` has no option " << option << " (see its --help)";
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 10);
}

TEST(Walkthrough, RunsEndToEndWithSyntheticPhotosInPlaceOfTheCamera) {
  const std::vector<Block> all = ReadBlocks(Page());
  const fs::path dir = FreshDir("walkthrough");
  const std::string path = "PATH=" + fs::path(CURVECHECK_BINARY).parent_path().string() + ":" +
                           (std::getenv("PATH") ? std::getenv("PATH") : "/usr/bin:/bin");
  std::string printed;
  for (const Block& b : BlocksOfKind(all, {"sh walkthrough", "sh stand-in"})) {
    const Stopwatch watch;
    const ProcessResult r = RunProcess({"env", path, "CURVECHECK_SOURCE_DIR=" + SourceDir().string(), "bash", "-eu", "-o", "pipefail", "-c", b.text}, dir);
    std::cout << "docs/walkthrough.md:" << b.line << " (" << b.kind << "): exit " << r.status << ", "
              << watch.Ms() / 1000 << " s\n";
    printed += r.stdout_text;
    ASSERT_EQ(r.status, 0) << "docs/walkthrough.md:" << b.line << " (```" << b.kind << ") failed in " << dir
                           << " (kept)"
                           << "\n--- stderr\n" << Tail(r.stderr_text) << "\n--- stdout\n" << Tail(r.stdout_text);
  }

  // The plan (section 3) and its positions.
  const json plan = ReadJson(dir / "plan" / "plan.json");
  EXPECT_EQ(plan.value("format", ""), "curvecheck.plan/1");
  ASSERT_TRUE(plan.contains("positions") && plan["positions"].is_array() && !plan["positions"].empty()) << plan;
  for (const json& p : plan["positions"]) {
    EXPECT_EQ(p.at("position_mm").size(), 3u);
    EXPECT_EQ(p.at("look_at_mm").size(), 3u);
  }
  EXPECT_TRUE(plan.at("predicted_radius_sigma_mm").is_number());
  EXPECT_TRUE(plan.at("predicted_verification_u_display_px").is_number());
  const size_t positions = plan["positions"].size();

  // The camera, calibrated from the screen (section 6): the first radius it states is near the truth.
  EXPECT_TRUE(fs::is_regular_file(dir / "cam.cameramodel"));
  const json calibration = ReadJson(dir / "cam.calibration.json");
  const double calibration_radius = calibration.at("screen").at("radius_mm").get<double>();
  const double calibration_sigma = calibration.at("screen").at("radius_sigma_mm").get<double>();
  EXPECT_GT(calibration_sigma, 0);
  EXPECT_LE(std::abs(calibration_radius - 1000), 4 * calibration_sigma)
      << "cam.calibration.json: radius " << calibration_radius << " +- " << calibration_sigma << " mm, truth 1000";

  // One session folder per pattern (section 7), each with its photo.
  for (const std::string& name : [&] {
         std::vector<std::string> names = {"eye"};
         for (size_t k = 1; k <= positions; ++k) names.push_back("p" + std::to_string(k));
         return names;
       }()) {
    const json manifest = ReadJson(dir / "sessions" / name / "manifest.json");
    EXPECT_EQ(manifest.value("format", ""), "curvecheck.session/1");
    EXPECT_EQ(manifest.at("shots").size(), 1u) << name;
  }

  // The analysis (sections 8-9): exact corrections of the monitor described, so the verdict is pass, and the true
  // radius (the synthetic monitor is an ideal 1000R) lies in the reported 95% interval.
  const json result = ReadJson(dir / "check" / "result.json");
  EXPECT_TRUE(fs::file_size(dir / "check" / "report.html") > 10000);
  const json& verification = result.at("verification");
  EXPECT_EQ(verification.value("verdict", ""), "pass") << verification.dump(1).substr(0, 2000);
  const json& fit = result.at("fit");
  EXPECT_EQ(fit.value("radius_status", ""), "measured");
  ASSERT_TRUE(fit.at("radius_ci95_mm").is_array());
  const double lo = fit["radius_ci95_mm"][0].get<double>(), hi = fit["radius_ci95_mm"][1].get<double>();
  EXPECT_LE(lo, 1000);
  EXPECT_GE(hi, 1000);
  std::cout << "verdict " << verification.value("verdict", "") << ", e = " << verification["error_p95_display_px"]
            << ", U = " << verification["expanded_uncertainty_display_px"] << " display px; radius "
            << fit["radius_mm"] << " +- " << fit["radius_sigma_mm"] << " mm, 95% interval " << lo << " .. " << hi
            << " (" << fit.value("model", "") << "); calibration from the screen: " << calibration_radius << " +- "
            << calibration_sigma << " mm; " << positions << " planned positions\n";
  size_t used = 0;
  for (const json& p : result.at("inputs").at("photos")) used += p.value("status", "") == "used" ? 1 : 0;
  EXPECT_EQ(used, positions + 1);

  // What the page quotes of the printed summary.
  std::vector<std::string> lines;
  std::istringstream out(printed);
  for (std::string l; std::getline(out, l);) lines.push_back(l);
  for (const Block& b : BlocksOfKind(all, {"text output"})) {
    std::istringstream quoted(b.text);
    for (std::string q; std::getline(quoted, q);) {
      if (q.empty()) continue;
      const std::regex pattern = LinePattern(q);
      EXPECT_TRUE(std::any_of(lines.begin(), lines.end(), [&](const std::string& l) { return std::regex_match(l, pattern); }))
          << "docs/walkthrough.md:" << b.line << ": no printed line is like\n  " << q << "\nprinted:\n" << Tail(printed);
    }
  }
  std::error_code ec;
  if (!HasFailure()) fs::remove_all(dir, ec);  // kept after a failure, to look at
}

}  // namespace
}  // namespace curvecheck::testing
