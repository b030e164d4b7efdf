// Internal to the HTML report (analysis/report.cc, report_charts.cc): escaping and number formatting of
// result.json values for the page and for gnuplot data files.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace curvecheck::report_internal {

using json = nlohmann::json;

// `text` for HTML element content and attribute values: markup characters as entities, control characters other
// than tab and newline (which a result.json string may carry as \u0001) as U+FFFD.
std::string Html(std::string_view text);

// A string value, or "" when `v` is not a string.
std::string Str(const json& v);

// A number, or nullopt when `v` is not a number.
std::optional<double> Opt(const json& v);

// Member `key` of object `o` as a number, nullopt when absent or null.
std::optional<double> OptAt(const json& o, const char* key);

// The exact value for a data-value attribute: shortest round-trip decimal, or "null".
std::string Exact(std::optional<double> x);

// For reading: fixed decimals, or an em dash when there is no number.
std::string Fixed(std::optional<double> x, int decimals);

// An element with an id whose data-value is the exact number and whose text is the rounded one.
std::string ValueSpan(const std::string& id, std::optional<double> x, int decimals);

// Decimals that show a value with uncertainty `sigma` to about two significant digits of sigma (0..4).
int DecimalsFor(std::optional<double> sigma);

// "(x, y, z)" of a 3-vector with fixed decimals.
std::string Vec3(const json& v, int decimals);

// A number for a gnuplot data file ("NaN" for none, which gnuplot leaves out or draws transparent).
std::string Dat(std::optional<double> x);

// A label inside a gnuplot data file: double-quoted, without quotes, comment characters or line breaks of its own.
std::string DatLabel(std::string_view s);

// A number rounded to 1, 2 or 5 times a power of ten.
double NiceNumber(double x);

// Whether the bytes start with the PNG signature.
bool IsPng(std::string_view bytes);

}  // namespace curvecheck::report_internal
