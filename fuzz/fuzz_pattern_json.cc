// libFuzzer target: the pattern.json reader (pattern/pattern_json.h ParsePatternJson, the text entry point of
// ReadPatternJson). Seeds: fuzz/corpus/fuzz_pattern_json (small rendered pattern.json files).
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_util.h"
#include "pattern/pattern_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace curvecheck;
  const std::string text = fuzz::Text(data, size);
  fuzz::ParsesOrThrowsError([&] { ParsePatternJson(text, "fuzz.json"); });
  return 0;
}
