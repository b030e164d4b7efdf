// libFuzzer target: the image loader (core/image_io.h DecodeImage8, the memory entry point of ReadImage8), i.e.
// OpenCV's imdecode on arbitrary bytes plus our conversion. The decoders (libpng, libjpeg, ... from Debian) are
// not instrumented, so coverage guidance is weak inside them; what this checks is that every input gives an image
// or a curvecheck::Error, within the memory limit. Seeds: fuzz/corpus/fuzz_image (tiny PNG and JPEG files).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/image_io.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace curvecheck;
  fuzz::ParsesOrThrowsError([&] {
    const Image8 img = DecodeImage8(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.png");
    if (img.pixels.size() != static_cast<size_t>(img.width) * img.height * img.channels) std::abort();
  });
  return 0;
}
