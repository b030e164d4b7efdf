#include "core/gnuplot.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>

#include "core/error.h"
#include "core/file_io.h"
#include "core/subprocess.h"

namespace curvecheck {
namespace fs = std::filesystem;
namespace {

std::string TerminalLine(ChartFormat format, ChartSize size) {
  if (format == ChartFormat::kSvg) {
    return fmt::format("set terminal svg size {},{} dynamic noenhanced font 'sans,11' background '#ffffff'\n",
                       size.width, size.height);
  }
  return fmt::format("set terminal pngcairo size {},{} noenhanced font 'sans,10'\n", size.width, size.height);
}

std::string FirstLines(const std::string& text, int n) {
  std::string out;
  int lines = 0;
  for (char c : text) {
    if (c == '\n') {
      if (++lines == n) break;
      out += " | ";
      continue;
    }
    out += c;
  }
  return out;
}

}  // namespace

std::string GnuplotString(std::string_view text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c == '\n' ? std::string("\\n") : std::string(1, c);
  }
  return out + "\"";
}

std::string RenderGnuplot(std::string_view script, ChartFormat format, ChartSize size, const fs::path& working_dir) {
  ChartDataFolder tmp;
  const fs::path image = tmp.path() / (format == ChartFormat::kSvg ? "chart.svg" : "chart.png");
  const fs::path gp = tmp.path() / "chart.gp";
  WriteFileAtomic(gp, TerminalLine(format, size) + fmt::format("set output {}\n", GnuplotString(image.string())) +
                          std::string(script) + "\nunset output\n");
  const ProcessResult run =
      RunProcess({"gnuplot", gp.string()}, working_dir.empty() ? fs::path() : fs::absolute(working_dir));
  const int rc = run.status;
  const std::string messages = run.stderr_text + run.stdout_text;
  if (rc == 127) throw Error("gnuplot", "the gnuplot program was not found", "install gnuplot-nox (./bootstrap does)");
  if (rc != 0 || !fs::exists(image) || fs::file_size(image) == 0) {
    throw Error("gnuplot", fmt::format("drawing a chart failed (exit {}): {}", rc, FirstLines(messages, 4)),
                "this is a bug in the chart script; please report it with the script");
  }
  return ReadFileToString(image);
}

fs::path WriteGnuplotChart(const fs::path& image, std::string_view script, ChartSize size) {
  const std::string ext = image.extension().string();
  if (ext != ".png" && ext != ".svg") {
    throw Error(image.string(), "a chart must be a .png or .svg file", "name the chart *.png or *.svg");
  }
  const ChartFormat format = ext == ".svg" ? ChartFormat::kSvg : ChartFormat::kPng;
  const fs::path dir = image.parent_path().empty() ? fs::path(".") : image.parent_path();
  WriteFileAtomic(image, RenderGnuplot(script, format, size, dir));
  fs::path gp = image;
  gp.replace_extension(".gp");
  WriteFileAtomic(gp, fmt::format("# Re-draw with: gnuplot {}\n", gp.filename().string()) + TerminalLine(format, size) +
                          fmt::format("set output {}\n", GnuplotString(image.filename().string())) +
                          std::string(script) + "\nunset output\n");
  return gp;
}

std::vector<bool> ParetoFront(const std::vector<double>& cost, const std::vector<double>& error) {
  if (cost.size() != error.size()) throw Error("ParetoFront", "cost and error differ in length");
  const size_t n = cost.size();
  std::vector<bool> front(n, false);
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(cost[i]) || !std::isfinite(error[i])) continue;
    bool dominated = false;
    for (size_t j = 0; j < n && !dominated; ++j) {
      if (j == i || !std::isfinite(cost[j]) || !std::isfinite(error[j])) continue;
      dominated = cost[j] <= cost[i] && error[j] <= error[i] && (cost[j] < cost[i] || error[j] < error[i]);
    }
    front[i] = !dominated;
  }
  return front;
}

std::string Base64(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (uint32_t(uint8_t(bytes[i])) << 16) | (uint32_t(uint8_t(bytes[i + 1])) << 8) |
                       uint32_t(uint8_t(bytes[i + 2]));
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = (uint32_t(uint8_t(bytes[i])) << 16) | (uint32_t(uint8_t(bytes[i + 1])) << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

}  // namespace curvecheck
