// libFuzzer target: a TensorFlow.js weight manifest (the input up to its first NUL byte) over one weight file (the
// rest, served for every path the manifest names). Decodes or raises InvalidInput.
#include <cstdlib>

#include "core/error.h"
#include "detect/tfjs_manifest.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("BARESKIN_MAX_MEMORY", "64M", 1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto parts = bareskin::fuzz::parts(bareskin::fuzz::text(data, size), 2);
  try {
    const auto tensors = bareskin::detect::decode_tfjs_weights(parts[0], "fuzz/weights_manifest.json",
                                                               [&](const std::string&) { return parts[1]; });
    for (const auto& t : tensors) {
      size_t count = 1;
      for (int64_t d : t.shape) count *= size_t(d);
      if ((t.is_int ? t.ints.size() : t.values.size()) != count) std::abort();
    }
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
