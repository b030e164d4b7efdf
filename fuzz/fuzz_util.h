// Shared by the libFuzzer targets: the contract every reader is fuzzed against.
//
// Every input either parses or throws curvecheck::Error (one line naming the input, the problem and the fix).
// Anything else is a finding: a crash or sanitizer report (libFuzzer stops by itself), another exception type
// (reported here with its message, then abort() so that libFuzzer saves the input), a hang (-timeout) or an
// allocation above -malloc_limit_mb / -rss_limit_mb.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <typeinfo>

#include "core/error.h"

namespace curvecheck::fuzz {

// Runs `read`; returns true if it parsed, false if it threw Error; aborts on anything else.
template <typename F>
bool ParsesOrThrowsError(F&& read) {
  try {
    read();
    return true;
  } catch (const Error& e) {
    // CURVECHECK_FUZZ_VERBOSE=1 prints each refusal (to check what a corpus file exercises).
    static const bool verbose = std::getenv("CURVECHECK_FUZZ_VERBOSE") != nullptr;
    if (verbose) std::fprintf(stderr, "Error: %s\n", e.what());
    // An Error must explain itself: empty messages would reach the user as a bare "Error".
    if (e.problem().empty()) {
      std::fprintf(stderr, "finding: curvecheck::Error with an empty problem (where '%s')\n", e.where().c_str());
      std::abort();
    }
    return false;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "finding: %s escaped instead of curvecheck::Error: %s\n", typeid(e).name(), e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "finding: a non-std exception escaped instead of curvecheck::Error\n");
    std::abort();
  }
}

inline std::string Text(const uint8_t* data, size_t size) { return std::string(reinterpret_cast<const char*>(data), size); }

}  // namespace curvecheck::fuzz
