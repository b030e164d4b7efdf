// Decimal numbers as a person types them: the one reader of the numbers a user gives (command-line options,
// `--set` values, config files, viewpoints), so that all of them accept the same text.
//
// Accepted: an optional sign, digits with an optional decimal point (at least one digit), an optional exponent
// ("-12", "+0.5", ".5", "5.", "1e-3", "010" is ten). Refused: empty text, spaces, hexadecimal ("0x10", which
// strtod and CLI11 read as 16), octal readings, "inf"/"nan", anything after the number, and values beyond the
// range of a double ("1e999").
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace curvecheck {

// The value of `text` if it is a finite decimal number as above; nullopt otherwise.
std::optional<double> ParseDecimal(std::string_view text);

// The value of `text` if it is a whole decimal number (sign and digits only, "12", "-3", "007") that fits in a
// long long; nullopt otherwise.
std::optional<long long> ParseWholeNumber(std::string_view text);

// What is wrong with `text` as a decimal number (as a whole number when `whole`), for a message, with the text
// quoted: "'' is not a number", "'0x10' is not a decimal number", "'inf' is not a finite number", "'1e999' is
// out of range", "'1.5' is not a whole number". Empty when `text` is fine.
std::string DecimalProblem(std::string_view text, bool whole = false);

}  // namespace curvecheck
