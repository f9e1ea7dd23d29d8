// libFuzzer target: the protobuf reader of the MediaPipe canonical face accepts or raises InvalidInput.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "template/mediapipe_face.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    bareskin::decode_canonical_face(std::string(reinterpret_cast<const char*>(data), size), "fuzz.binarypb");
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
