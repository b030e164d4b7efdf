#include "analysis/report_format.h"

#include <fmt/format.h>

#include <cmath>

namespace curvecheck::report_internal {


// `text` for HTML element content and attribute values: markup characters as entities, control characters other
// than tab and newline (which a result.json string may carry as \u0001) as U+FFFD.
std::string Html(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 && c != '\n' && c != '\t') {
          out += "&#xFFFD;";
        } else {
          out += c;
        }
    }
  }
  return out;
}

std::string Str(const json& v) { return v.is_string() ? v.get<std::string>() : std::string(); }

std::optional<double> Opt(const json& v) {
  if (v.is_number()) return v.get<double>();
  return std::nullopt;
}
// Member `key` of object `o` as a number, nullopt when absent or null.
std::optional<double> OptAt(const json& o, const char* key) {
  const auto it = o.find(key);
  return it == o.end() ? std::nullopt : Opt(*it);
}

// The exact value for a data-value attribute: shortest round-trip decimal, or "null".
std::string Exact(std::optional<double> x) { return x ? fmt::format("{}", *x) : "null"; }

// For reading: fixed decimals, or an em dash when there is no number.
std::string Fixed(std::optional<double> x, int decimals) {
  return x ? fmt::format("{:.{}f}", *x, decimals) : std::string("&#8212;");
}

// An element with an id whose data-value is the exact number and whose text is the rounded one.
std::string ValueSpan(const std::string& id, std::optional<double> x, int decimals) {
  return fmt::format("<span id=\"{}\" class=\"value\" data-value=\"{}\">{}</span>", id, Exact(x), Fixed(x, decimals));
}

// Decimals that show a value with uncertainty `sigma` to about two significant digits of sigma (0..4).
int DecimalsFor(std::optional<double> sigma) {
  if (!sigma || !(*sigma > 0)) return 1;
  return std::clamp(1 - static_cast<int>(std::floor(std::log10(*sigma))), 0, 4);
}

std::string Vec3(const json& v, int decimals) {
  if (!v.is_array() || v.size() != 3) return "&#8212;";
  return fmt::format("({}, {}, {})", Fixed(Opt(v[0]), decimals), Fixed(Opt(v[1]), decimals),
                     Fixed(Opt(v[2]), decimals));
}

// A number for a gnuplot data file ("NaN" for none, which gnuplot leaves out or draws transparent).
std::string Dat(std::optional<double> x) { return x && std::isfinite(*x) ? fmt::format("{}", *x) : "NaN"; }

// A label inside a gnuplot data file: double-quoted, without quotes, comment characters or line breaks of its own.
std::string DatLabel(std::string_view s) {
  std::string out = "\"";
  for (char c : s) out += (c == '"' || c == '\\') ? '\'' : (c == '\n' || c == '\r' || c == '#' ? ' ' : c);
  return out + "\"";
}

// A number rounded to 1, 2 or 5 times a power of ten.
double NiceNumber(double x) {
  if (!(x > 0) || !std::isfinite(x)) return 1;
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  const double m = x / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

bool IsPng(std::string_view bytes) { return bytes.size() > 8 && bytes.substr(0, 8) == "\x89PNG\r\n\x1a\n"; }

}  // namespace curvecheck::report_internal
