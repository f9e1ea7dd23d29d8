// libFuzzer target: core's PNG decoder (shard members, maps) decodes or raises InvalidInput, and never allocates
// more than the memory limit the header promises.
#include <cstdlib>

#include "core/error.h"
#include "core/png.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("BARESKIN_MAX_MEMORY", "64M", 1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const bareskin::Image image = bareskin::decode_png(bareskin::fuzz::text(data, size), "fuzz.png");
    if (image.pixels.size() != size_t(image.width) * size_t(image.height) * size_t(image.channels)) std::abort();
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
