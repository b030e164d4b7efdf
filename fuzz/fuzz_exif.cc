// libFuzzer target: the EXIF reader of `capture import` (capture/exif.h ReadExif), which reads untrusted photo bytes.
// Its contract is stronger than the other readers': it never throws and always returns a JSON object (empty for
// files without EXIF or with malformed EXIF). Seeds: fuzz/corpus/fuzz_exif (a JPEG with an EXIF block, the bare
// TIFF of that block, a JPEG without EXIF).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string_view>

#include "capture/exif.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const nlohmann::json j = curvecheck::ReadExif(std::string_view(reinterpret_cast<const char*>(data), size));
    if (!j.is_object()) {
      std::fprintf(stderr, "finding: ReadExif returned %s, not an object\n", j.dump().c_str());
      std::abort();
    }
    j.dump();  // every text it returns must be valid UTF-8 for the manifest (dump throws otherwise)
  } catch (const std::exception& e) {
    std::fprintf(stderr, "finding: ReadExif threw (it must never throw): %s\n", e.what());
    std::abort();
  }
  return 0;
}
