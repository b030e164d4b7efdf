#include "core/error.h"

#include <fmt/format.h>

#include <cmath>
#include <utility>

namespace curvecheck {
namespace {

std::string Compose(const std::string& where, const std::string& problem, const std::string& fix) {
  std::string line = where.empty() ? problem : where + ": " + problem;
  if (!fix.empty()) line += "; " + fix;
  // One line, whatever the parts contained.
  for (char& c : line) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return line;
}

}  // namespace

Error::Error(std::string where, std::string problem, std::string fix)
    : std::runtime_error(Compose(where, problem, fix)),
      where_(std::move(where)),
      problem_(std::move(problem)),
      fix_(std::move(fix)) {}

void RequireInRange(const std::string& where, const char* name, double v, double lo, double hi, const char* fix) {
  if (!(std::isfinite(v) && v >= lo && v <= hi)) {
    throw Error(where, fmt::format("{} is {}, but must be in [{}, {}]", name, v, lo, hi), fix);
  }
}

}  // namespace curvecheck
