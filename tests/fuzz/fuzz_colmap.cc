// libFuzzer target: COLMAP's TXT model, the input cut at NUL bytes into cameras.txt, images.txt and points3D.txt.
// Parses or raises InvalidInput.
#include <cstdlib>

#include "core/error.h"
#include "scan/colmap.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto p = bareskin::fuzz::parts(bareskin::fuzz::text(data, size), 3);
  try {
    const bareskin::ColmapModel m = bareskin::parse_colmap_text_model(p[0], p[1], p[2], "fuzz");
    if (m.images.empty()) std::abort();  // documented: no image is refused
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
