// libFuzzer target: any bytes given to the safetensors parser must either parse into views that lie inside the
// buffer, or raise InvalidInput. Anything else (crash, other exception, out-of-bounds read under ASan) is a bug.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "core/safetensors.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const bareskin::SafeTensors st = bareskin::SafeTensors::parse(std::string(reinterpret_cast<const char*>(data), size), "fuzz");
    for (const std::string& name : st.names()) {
      const bareskin::TensorView& t = st.tensor(name);
      volatile double sink = 0;
      for (int64_t i = 0; i < t.numel() && i < 64; ++i) sink = sink + t.as_double(i);
    }
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
