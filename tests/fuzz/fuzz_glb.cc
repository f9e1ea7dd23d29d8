// libFuzzer target: a .glb read back by read_glb (avatar/glb_read.h). Reads or raises InvalidInput; a summary it
// gives is consistent with the file's size.
#include <cstdlib>

#include "avatar/glb_read.h"
#include "core/error.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const auto s = bareskin::texture::read_glb(bareskin::fuzz::text(data, size), "fuzz.glb");
    if (s.vertices < 0 || s.triangles < 0 || size_t(s.vertices) > size) std::abort();
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
