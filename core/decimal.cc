#include "core/decimal.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <system_error>

namespace curvecheck {
namespace {

bool Digit(char c) { return c >= '0' && c <= '9'; }

// The length of the decimal number at the start of `t` (sign, digits, point, exponent), or 0; sets *whole when
// it has neither a point nor an exponent.
size_t DecimalLength(std::string_view t, bool* whole) {
  size_t i = 0;
  if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
  size_t digits = 0;
  while (i < t.size() && Digit(t[i])) ++i, ++digits;
  *whole = true;
  if (i < t.size() && t[i] == '.') {
    *whole = false;
    ++i;
    while (i < t.size() && Digit(t[i])) ++i, ++digits;
  }
  if (digits == 0) return 0;
  if (i < t.size() && (t[i] == 'e' || t[i] == 'E')) {
    size_t j = i + 1;
    if (j < t.size() && (t[j] == '+' || t[j] == '-')) ++j;
    const size_t start = j;
    while (j < t.size() && Digit(t[j])) ++j;
    if (j > start) {
      *whole = false;
      i = j;
    }
  }
  return i;
}

std::string Lower(std::string_view t) {
  std::string s(t);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

}  // namespace

std::optional<double> ParseDecimal(std::string_view text) {
  bool whole = false;
  if (text.empty() || DecimalLength(text, &whole) != text.size()) return std::nullopt;
  // from_chars takes no leading '+' and never reads hexadecimal in chars_format::general.
  const std::string_view t = text.front() == '+' ? text.substr(1) : text;
  double v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v, std::chars_format::general);
  if (ec != std::errc() || end != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<long long> ParseWholeNumber(std::string_view text) {
  bool whole = false;
  if (text.empty() || DecimalLength(text, &whole) != text.size() || !whole) return std::nullopt;
  const std::string_view t = text.front() == '+' ? text.substr(1) : text;
  long long v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v, 10);
  if (ec != std::errc() || end != t.data() + t.size()) return std::nullopt;
  return v;
}

std::string DecimalProblem(std::string_view text, bool whole) {
  const std::string quoted = fmt::format("'{}'", text);
  if (text.empty()) return quoted + " is not a number";
  bool is_whole = false;
  const size_t n = DecimalLength(text, &is_whole);
  if (n == text.size()) {
    if (whole && !is_whole) return quoted + " is not a whole number";
    if (whole ? !ParseWholeNumber(text) : !ParseDecimal(text)) return quoted + " is out of range";
    return "";
  }
  const std::string low = Lower(text);
  const std::string_view unsigned_low = std::string_view(low).substr(low[0] == '+' || low[0] == '-' ? 1 : 0);
  if (unsigned_low == "inf" || unsigned_low == "infinity" || unsigned_low == "nan" || unsigned_low == ".inf" ||
      unsigned_low == ".nan") {
    return quoted + " is not a finite number";
  }
  if (unsigned_low.starts_with("0x")) return quoted + " is not a decimal number";
  return quoted + " is not a number";
}

}  // namespace curvecheck
