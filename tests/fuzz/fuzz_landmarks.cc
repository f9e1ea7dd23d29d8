// libFuzzer target: landmark JSON and .pts parsers accept or raise InvalidInput, nothing else.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "core/landmarks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    bareskin::parse_landmarks_json(text, "fuzz.json");
  } catch (const bareskin::InvalidInput&) {
  }
  try {
    bareskin::parse_landmarks_pts(text, "fuzz.pts");
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
