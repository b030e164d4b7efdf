// The project's one error type for programmer, configuration and I/O errors (style.md rule 7).
//
// Every message is one line that names the file (or the option), what is wrong and what to do:
//   "monitor.yaml: key 'radius_mm' is -5; it must be a positive number of millimetres or 'flat'"
// Expected outcomes of measurement (pattern not found, fit ill-conditioned) are results, not errors.
#pragma once

#include <stdexcept>
#include <string>

namespace curvecheck {

class Error : public std::runtime_error {
 public:
  // where: the file or command-line option at fault ("" when none applies).
  // problem: what is wrong, with the offending value.
  // fix: what the user should do ("" when obvious from the problem).
  Error(std::string where, std::string problem, std::string fix = "");

  const std::string& where() const { return where_; }
  const std::string& problem() const { return problem_; }
  const std::string& fix() const { return fix_; }

 private:
  std::string where_, problem_, fix_;
};

// Throws Error(where, "NAME is V, but must be in [LO, HI]", fix) unless v is finite and within [lo, hi]: the
// options' range checks.
void RequireInRange(const std::string& where, const char* name, double v, double lo, double hi, const char* fix);

}  // namespace curvecheck
