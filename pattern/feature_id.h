#pragma once
// The grammar of a checkerboard corner's feature id (pattern.h Feature::id), in one place for every reader: the
// pattern.json contract's check, the screenshot check, and the fit's checkerboard polarity.

#include <charconv>
#include <limits>
#include <optional>
#include <string_view>

namespace curvecheck {

// "c<k>" (a checkerboard inner corner, k = row * (cols - 1) + col, pattern.h) -> k: decimal digits after the 'c',
// no sign, no leading zero but in "c0", at most 10 of them and below INT_MAX; nullopt for any other id.
inline std::optional<long> CornerIndexOfId(std::string_view id) {
  if (id.size() < 2 || id.size() > 11 || id[0] != 'c') return std::nullopt;
  const std::string_view digits = id.substr(1);
  if (digits.size() > 1 && digits[0] == '0') return std::nullopt;
  for (const char ch : digits) {
    if (ch < '0' || ch > '9') return std::nullopt;
  }
  long k = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), k);
  if (ec != std::errc() || end != digits.data() + digits.size() || k >= std::numeric_limits<int>::max()) {
    return std::nullopt;
  }
  return k;
}

}  // namespace curvecheck
