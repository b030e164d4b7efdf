// libFuzzer target: the strict YAML/JSON config reader (core/config.h ConfigMap::Parse) and the readers built
// on it for monitor specs (core/monitor.h MonitorFromConfig) and pattern specs (pattern/pattern.h
// PatternSpecFromConfig). Seeds: fuzz/corpus/fuzz_config (datasets/monitors/*.yaml, pattern specs).
#include <cstddef>
#include <cstdint>

#include "core/config.h"
#include "core/monitor.h"
#include "fuzz/fuzz_util.h"
#include "pattern/pattern.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace curvecheck;
  const std::string text = fuzz::Text(data, size);
  fuzz::ParsesOrThrowsError([&] {
    const ConfigMap c = ConfigMap::Parse(text, "fuzz.yaml");
    // The same document through both readers: each must accept it or say why.
    fuzz::ParsesOrThrowsError([&] { MonitorFromConfig(c); });
    fuzz::ParsesOrThrowsError([&] { PatternSpecFromConfig(c); });
  });
  return 0;
}
